// The small value syntaxes of the runtime configuration (spec runtime.md,
// "Configuration"): durations ("10ms"), process-image channel addresses
// ("p0.d0.c0") and names. YAML-free, so the runtime and the command line can
// parse the same spellings the config file uses (e.g. `rtplc set`, `rtplc swap`).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rtplc::config {

// Durations: a number followed by an optional unit, "250us", "10ms", "0.5s", "2"
// (plain numbers are seconds, as the FBD language's stime() is). Units: ns, us,
// ms, s. Returns seconds, or nullopt for anything malformed, negative or not
// finite. Ranges are the caller's business (a period and a timeout differ).
std::optional<double> parse_duration_s(std::string_view text);

// The shortest exact-looking spelling of a duration for messages and docs:
// 0.01 -> "10ms", 0.00025 -> "250us", 2 -> "2s", 0.0105 -> "10.5ms".
std::string format_duration(double seconds);

// A process-image channel as the FBD I/O blocks name it: processor p (0..255),
// module d (0..255), channel c (0..65535). See docs/language.md, "Devices and labels".
struct ChannelAddress {
  uint8_t p = 0;
  uint8_t d = 0;
  uint16_t c = 0;
  friend bool operator==(const ChannelAddress&, const ChannelAddress&) = default;
};

// "p0.d1.c12" -> {0, 1, 12}. Exactly that shape: lower-case letters, decimal
// numbers without sign; nullopt otherwise or when a part is out of range.
std::optional<ChannelAddress> parse_channel(std::string_view text);

// The canonical spelling, "p0.d1.c12" (what `rtplc sim --plant-input` takes).
std::string to_string(const ChannelAddress& a);

// Task, driver and runtime names: 1..31 of [A-Za-z0-9_-]. They become thread
// names, shared-memory object names and socket names, so nothing else is allowed.
inline constexpr size_t kMaxNameLength = 31;
bool is_valid_name(std::string_view name);

// Channel labels as the FBD language allows them: 1..31 of [A-Za-z0-9_.-].
bool is_valid_label(std::string_view label);

// Strict number syntaxes shared by the loader: the whole text must be the number.
// Integers are decimal with an optional sign; reals also take a fraction and an
// exponent ("1e-3", ".5"). Non-finite reals are rejected.
std::optional<int64_t> parse_integer(std::string_view text);
std::optional<double> parse_real(std::string_view text);

}  // namespace rtplc::config
