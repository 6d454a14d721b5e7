// Durations, channel addresses and names of the runtime configuration (see values.h).
#include "config/values.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace rtplc::config {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// Parses a decimal number of at most `max` into `out`, digits only.
bool parse_part(std::string_view s, uint32_t max, uint32_t& out) {
  if (s.empty() || s.size() > 5) return false;
  uint32_t v = 0;
  for (char ch : s) {
    if (ch < '0' || ch > '9') return false;
    v = v * 10 + static_cast<uint32_t>(ch - '0');
  }
  if (v > max) return false;
  out = v;
  return true;
}

// "%g" with enough digits to round-trip the values people write, without
// trailing zeros.
std::string shortest(double v) {
  char buf[64];
  for (int prec = 6; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, v);
    double back = 0;
    auto [p, ec] = std::from_chars(buf, buf + std::char_traits<char>::length(buf), back);
    (void)p;
    if (ec == std::errc() && back == v) break;
  }
  return buf;
}

}  // namespace

std::optional<int64_t> parse_integer(std::string_view text) {
  text = trim(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return std::nullopt;
  int64_t v = 0;
  auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || p != text.data() + text.size()) return std::nullopt;
  return v;
}

std::optional<double> parse_real(std::string_view text) {
  text = trim(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  // from_chars also reads "inf", "nan" and hex-less oddities; a leading letter
  // is never a number here.
  if (text.empty() || !(text.front() == '-' || text.front() == '.' ||
                        (text.front() >= '0' && text.front() <= '9'))) {
    return std::nullopt;
  }
  double v = 0;
  auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || p != text.data() + text.size() || !std::isfinite(v)) {
    return std::nullopt;
  }
  return v;
}

std::optional<double> parse_duration_s(std::string_view text) {
  text = trim(text);
  // Split the number from its unit at the first letter ('e' of an exponent
  // counts as part of the number only when a digit or sign follows it).
  size_t split = text.size();
  for (size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
    if ((ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z')) {
      if ((ch == 'e' || ch == 'E') && i + 1 < text.size() &&
          ((text[i + 1] >= '0' && text[i + 1] <= '9') || text[i + 1] == '-' ||
           text[i + 1] == '+')) {
        continue;
      }
      split = i;
      break;
    }
  }
  std::string_view unit = text.substr(split);
  auto number = parse_real(trim(text.substr(0, split)));
  if (!number || *number < 0) return std::nullopt;
  // Division, not multiplication by 1e-3: 10 / 1000 is the double nearest to
  // 0.01, while 10 * 1e-3 is one ulp off it.
  double s = 0;
  if (unit.empty() || unit == "s") {
    s = *number;
  } else if (unit == "ms") {
    s = *number / 1e3;
  } else if (unit == "us") {
    s = *number / 1e6;
  } else if (unit == "ns") {
    s = *number / 1e9;
  } else {
    return std::nullopt;
  }
  if (!std::isfinite(s)) return std::nullopt;
  return s;
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds)) return shortest(seconds);
  const double a = std::fabs(seconds);
  if (a == 0) return "0s";
  if (a < 1e-6) return shortest(seconds * 1e9) + "ns";
  if (a < 1e-3) return shortest(seconds * 1e6) + "us";
  if (a < 1) return shortest(seconds * 1e3) + "ms";
  return shortest(seconds) + "s";
}

std::optional<ChannelAddress> parse_channel(std::string_view text) {
  // p<N>.d<N>.c<N>
  const size_t dot1 = text.find('.');
  if (dot1 == std::string_view::npos) return std::nullopt;
  const size_t dot2 = text.find('.', dot1 + 1);
  if (dot2 == std::string_view::npos) return std::nullopt;
  std::string_view ps = text.substr(0, dot1);
  std::string_view ds = text.substr(dot1 + 1, dot2 - dot1 - 1);
  std::string_view cs = text.substr(dot2 + 1);
  if (ps.size() < 2 || ps[0] != 'p' || ds.size() < 2 || ds[0] != 'd' || cs.size() < 2 ||
      cs[0] != 'c') {
    return std::nullopt;
  }
  uint32_t p = 0, d = 0, c = 0;
  if (!parse_part(ps.substr(1), 255, p) || !parse_part(ds.substr(1), 255, d) ||
      !parse_part(cs.substr(1), 65535, c)) {
    return std::nullopt;
  }
  return ChannelAddress{static_cast<uint8_t>(p), static_cast<uint8_t>(d), static_cast<uint16_t>(c)};
}

std::string to_string(const ChannelAddress& a) {
  return "p" + std::to_string(a.p) + ".d" + std::to_string(a.d) + ".c" + std::to_string(a.c);
}

bool is_valid_name(std::string_view name) {
  if (name.empty() || name.size() > kMaxNameLength) return false;
  for (char ch : name) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') ||
                    (ch >= '0' && ch <= '9') || ch == '_' || ch == '-';
    if (!ok) return false;
  }
  return true;
}

bool is_valid_label(std::string_view label) {
  if (label.empty() || label.size() > 31) return false;
  for (char ch : label) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') ||
                    (ch >= '0' && ch <= '9') || ch == '_' || ch == '-' || ch == '.';
    if (!ok) return false;
  }
  return true;
}

}  // namespace rtplc::config
