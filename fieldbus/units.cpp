// Time and bit-rate spellings of the plan file (see units.h).
#include "fieldbus/units.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace rtplc::fieldbus {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// Splits "1.5ms" into 1.5 and "ms". The number is digits with at most one dot
// (no sign, no exponent: a plan file is written by people, and "1e-3" next to
// "1ms" only invites mistakes).
bool split_number(std::string_view text, double& value, std::string_view& unit) {
  size_t i = 0;
  bool digits = false, dot = false;
  for (; i < text.size(); ++i) {
    const char ch = text[i];
    if (ch >= '0' && ch <= '9') {
      digits = true;
    } else if (ch == '.' && !dot) {
      dot = true;
    } else {
      break;
    }
  }
  if (!digits) return false;
  auto [p, ec] = std::from_chars(text.data(), text.data() + i, value);
  if (ec != std::errc() || p != text.data() + i || !std::isfinite(value)) return false;
  unit = trim(text.substr(i));
  return true;
}

}  // namespace

std::optional<Nanos> parse_time(std::string_view text) {
  double v = 0;
  std::string_view unit;
  if (!split_number(trim(text), v, unit)) return std::nullopt;
  double scale = 0;
  if (unit.empty() || unit == "s") {
    scale = 1e9;
  } else if (unit == "ms") {
    scale = 1e6;
  } else if (unit == "us") {
    scale = 1e3;
  } else if (unit == "ns") {
    scale = 1;
  } else {
    return std::nullopt;
  }
  const double ns = v * scale;
  if (ns > 3600e9) return std::nullopt;
  const double whole = std::round(ns);
  // "1.5ms" * 1e6 is 1500000.0000000002 in binary; accept a hair of noise but
  // not a real fraction of a nanosecond.
  if (std::fabs(ns - whole) > 1e-6 * std::max(1.0, ns) && std::fabs(ns - whole) > 1e-3) {
    return std::nullopt;
  }
  return static_cast<Nanos>(whole);
}

std::optional<double> parse_bit_rate(std::string_view text) {
  double v = 0;
  std::string_view unit;
  if (!split_number(trim(text), v, unit)) return std::nullopt;
  double scale = 0;
  if (unit.empty() || unit == "bit/s" || unit == "bps" || unit == "baud") {
    scale = 1;
  } else if (unit == "kbit/s" || unit == "kbps" || unit == "k") {
    scale = 1e3;
  } else if (unit == "Mbit/s" || unit == "Mbps" || unit == "M") {
    scale = 1e6;
  } else {
    return std::nullopt;
  }
  const double rate = v * scale;
  if (!(rate >= 1) || rate > 1e9) return std::nullopt;
  return rate;
}

std::string format_time(Nanos t) {
  if (t == 0) return "0s";
  const char* sign = t < 0 ? "-" : "";
  const Nanos a = t < 0 ? -t : t;
  const char* unit = "ns";
  Nanos div = 1;
  if (a >= kNanosPerSecond) {
    unit = "s";
    div = kNanosPerSecond;
  } else if (a >= 1'000'000) {
    unit = "ms";
    div = 1'000'000;
  } else if (a >= 1'000) {
    unit = "us";
    div = 1'000;
  }
  // Whole part, then up to the digits the unit leaves (exact: no float).
  std::string out = sign + std::to_string(a / div);
  Nanos frac = a % div;
  if (frac != 0) {
    std::string digits;
    for (Nanos d = div / 10; d > 0; d /= 10) {
      digits += static_cast<char>('0' + (frac / d) % 10);
    }
    while (!digits.empty() && digits.back() == '0') digits.pop_back();
    out += "." + digits;
  }
  return out + unit;
}

Nanos bits_time(int64_t bits, double bits_per_second) {
  const double ns = static_cast<double>(bits) * 1e9 / bits_per_second;
  // Round up, but do not let 2000.0000000001 become 2001.
  const double down = std::floor(ns);
  return static_cast<Nanos>(ns - down < 1e-6 ? down : down + 1);
}

}  // namespace rtplc::fieldbus
