// Times and bit rates of the fieldbus planner (docs/fieldbus.md, "Units"; spec
// io-links.md, "Fieldbus bandwidth allocation"). The planner and the simulation
// count time in whole nanoseconds so the conditions of the design technique
// (gamma L_p + N_c L_c + R <= T_1, ...) compare exactly, with no rounding
// surprise at equality; only the renderers turn them into seconds.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rtplc::fieldbus {

using Nanos = int64_t;

inline constexpr Nanos kNanosPerSecond = 1'000'000'000;

// "20us", "5ms", "0.1s", "1.5ms", "250ns" or a plain number of seconds ("0.002").
// nullopt for anything malformed, negative, not finite, above one hour or not a
// whole number of nanoseconds after scaling (e.g. "0.5ns").
std::optional<Nanos> parse_time(std::string_view text);

// Bits per second: "500kbit/s", "1Mbit/s", "19200", "19200bit/s", "125kbps",
// "9.6kbit/s". nullopt for malformed, zero, negative or above 1 Gbit/s.
std::optional<double> parse_bit_rate(std::string_view text);

// The shortest readable spelling: 585714 -> "585.714us", 5000000 -> "5ms",
// 1500 -> "1.5us", 0 -> "0s". Negative values keep their sign.
std::string format_time(Nanos t);

// Seconds as a double, for JSON and plots.
inline double to_seconds(Nanos t) {
  return static_cast<double>(t) / 1e9;
}

// The time `bits` take at `bits_per_second`, rounded up to the next nanosecond
// (a worst case must not shrink by rounding).
Nanos bits_time(int64_t bits, double bits_per_second);

}  // namespace rtplc::fieldbus
