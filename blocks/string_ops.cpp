// The string opcodes (see string_ops.h). Every position and count arrives as a
// double; out-of-range ones give the results documented in docs/st.md
// ("Strings"): never a read outside the string, never a result past its cap.
#include "blocks/string_ops.h"

#include "common/text.h"

#include <algorithm>
#include <cctype>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace rtplc {
namespace {

constexpr uint32_t kMax = kMaxStringLength;

// A whole count or position: trunc(v), clamped so int64 arithmetic on it is safe.
int64_t whole(double v) {
  if (!(v == v)) return 0;
  return static_cast<int64_t>(std::trunc(std::clamp(v, -1e9, 1e9)));
}

// A character code: a byte of a STRING or a UTF-16 code unit of a WSTRING.
using Unit = uint16_t;

// Reads the string at V[at] into `buf` (kMax units); its length.
uint32_t read(const double* V, uint32_t n_values, uint32_t at, Unit* buf) {
  if (at >= n_values) return 0;
  const double len = V[at];
  const uint32_t room = std::min(n_values - at - 1, kMax);
  const uint32_t n = len >= 0 ? static_cast<uint32_t>(std::min(std::floor(len), static_cast<double>(room))) : 0;
  for (uint32_t i = 0; i < n; ++i) {
    const double c = V[at + 1 + i];
    buf[i] = c >= 0 && c <= 65535 ? static_cast<Unit>(c) : static_cast<Unit>('?');
  }
  return n;
}

void write(double* V, uint32_t out, uint32_t cap, const Unit* s, size_t n) {
  const size_t len = std::min<size_t>(n, cap);
  V[out] = static_cast<double>(len);
  for (size_t i = 0; i < len; ++i) V[out + 1 + i] = s[i];
}

int compare(const Unit* a, uint32_t na, const Unit* b, uint32_t nb) {
  for (uint32_t i = 0; i < na && i < nb; ++i) {
    if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
  }
  return na < nb ? -1 : na > nb ? 1 : 0;
}

void copy_units(Unit* to, const Unit* from, size_t n) { std::copy(from, from + n, to); }

bool same_units(const Unit* a, const Unit* b, size_t n) { return std::equal(a, a + n, b); }

// ---- numbers as text --------------------------------------------------------

// A fixed buffer the formats append to: no allocation on the task's path.
struct Text {
  char buf[160];
  size_t n = 0;
  void add(const char* fmt, ...) __attribute__((format(printf, 2, 3))) {
    va_list ap;
    va_start(ap, fmt);
    const int k = std::vsnprintf(buf + n, sizeof buf - n, fmt, ap);
    va_end(ap);
    if (k > 0) n = std::min(sizeof buf - 1, n + static_cast<size_t>(k));
  }
};

// A whole number of the value's type, without rounding it twice.
void integer_text(Text& t, double v, bool is_unsigned) {
  const double w = std::trunc(v);
  if (!(std::fabs(w) < 1.8e19)) return t.add("0");
  if (is_unsigned && w >= 0) return t.add("%" PRIu64, static_cast<uint64_t>(w));
  t.add("%" PRId64, static_cast<int64_t>(std::clamp(w, -9.2e18, 9.2e18)));
}

// Seconds and nanoseconds of a time held in seconds on the nanosecond grid.
void split_ns(double v, int64_t& sec, int64_t& ns) {
  const double total = std::round(std::clamp(v, -9.2e9, 9.2e9) * 1e9);
  const auto t = static_cast<int64_t>(total);
  sec = t / 1000000000;
  ns = t % 1000000000;
}

void time_text(Text& t, double v, StringDialect d) {
  int64_t sec = 0, ns = 0;
  split_ns(v, sec, ns);
  const bool neg = sec < 0 || ns < 0;
  if (neg) {
    sec = -sec;
    ns = -ns;
  }
  const int64_t days = sec / 86400, h = sec % 86400 / 3600, m = sec % 3600 / 60, s = sec % 60;
  t.add(neg ? "T#-" : "T#");
  if (d == StringDialect::kCodesys) {
    // CODESYS: the units that are not zero, largest first; T#0ms for zero.
    const int64_t parts[] = {days, h, m, s, ns / 1000000, ns % 1000000 / 1000, ns % 1000};
    const char* units[] = {"d", "h", "m", "s", "ms", "us", "ns"};
    bool any = false;
    for (int k = 0; k < 7; ++k) {
      if (parts[k] == 0) continue;
      t.add("%" PRId64 "%s", parts[k], units[k]);
      any = true;
    }
    if (!any) t.add("0ms");
    return;
  }
  // MatIEC: days, hours, minutes and seconds down to the last that is not
  // zero (all of them when there is a fraction), then the fraction in ms.
  t.add("%" PRId64 "d", days);
  if (s == 0 && ns == 0 && m == 0 && h == 0) return;
  t.add("%" PRId64 "h", h);
  if (s == 0 && ns == 0 && m == 0) return;
  t.add("%" PRId64 "m", m);
  if (s == 0 && ns == 0) return;
  t.add("%" PRId64 "s", s);
  if (ns != 0) t.add("%gms", static_cast<double>(ns) / 1e6);
}

void date_text(Text& t, double v, StringFormat f, StringDialect d) {
  int64_t sec = 0, ns = 0;
  if (f == StringFormat::kTod) {
    split_ns(v, sec, ns);
  } else {
    // DATE and DT are on the microsecond grid (seconds since 1970 leave a
    // double no room for nanoseconds in 2255).
    const auto us = static_cast<int64_t>(std::round(std::clamp(v, -9.2e12, 9.2e12) * 1e6));
    sec = us / 1000000;
    ns = us % 1000000 * 1000;
  }
  if (ns < 0) {
    ns += 1000000000;
    sec -= 1;
  }
  const bool codesys = d == StringDialect::kCodesys;
  // The seconds: whole, or MatIEC's %09.6f / CODESYS's milliseconds.
  auto seconds = [&](int ss) {
    if (ns == 0) return t.add("%02d", ss);
    if (codesys) return t.add("%02d.%03d", ss, static_cast<int>(ns / 1000000));
    t.add("%09.6f", ss + static_cast<double>(ns) / 1e9);
  };
  if (f == StringFormat::kTod) {
    const int64_t day = ((sec % 86400) + 86400) % 86400;
    t.add("TOD#%02d:%02d:", static_cast<int>(day / 3600), static_cast<int>(day % 3600 / 60));
    return seconds(static_cast<int>(day % 60));
  }
  // The civil date of day number `days` since 1970-01-01, in integers (no
  // gmtime_r: it takes glibc's time zone lock and may read /etc/localtime).
  const int64_t days = (sec >= 0 ? sec : sec - 86399) / 86400, in_day = sec - days * 86400;
  const int64_t z = days + 719468, era = (z >= 0 ? z : z - 146096) / 146097;
  const int64_t doe = z - era * 146097, yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const int64_t doy = doe - (365 * yoe + yoe / 4 - yoe / 100), mp = (5 * doy + 2) / 153;
  const int mday = static_cast<int>(doy - (153 * mp + 2) / 5 + 1), mon = static_cast<int>(mp < 10 ? mp + 3 : mp - 9);
  const int year = static_cast<int>(yoe + era * 400 + (mon <= 2 ? 1 : 0));
  if (f == StringFormat::kDate) return t.add("D#%d-%02d-%02d", year, mon, mday);
  t.add("DT#%d-%02d-%02d-%02d:%02d:", year, mon, mday, static_cast<int>(in_day / 3600),
        static_cast<int>(in_day % 3600 / 60));
  seconds(static_cast<int>(in_day % 60));
}

void format_into(Text& t, double v, StringFormat f, StringDialect d) {
  if (!std::isfinite(v)) v = 0;
  switch (f) {
    case StringFormat::kSigned:
      return integer_text(t, v, false);
    case StringFormat::kUnsigned:
      return integer_text(t, v, true);
    case StringFormat::kBits:
      if (d == StringDialect::kCodesys || !(std::fabs(v) < 1.8e19)) return integer_text(t, v, true);
      return t.add("16#%" PRIx64, static_cast<uint64_t>(std::trunc(std::fabs(v))));
    case StringFormat::kReal:
      return t.add("%.*g", d == StringDialect::kCodesys ? 7 : 10, static_cast<double>(static_cast<float>(v)));
    case StringFormat::kLreal:
      return t.add("%.*g", d == StringDialect::kCodesys ? 16 : 10, v);
    case StringFormat::kBool:
      return t.add(v != 0 ? "TRUE" : "FALSE");
    case StringFormat::kTime:
      return time_text(t, v, d);
    case StringFormat::kDate:
    case StringFormat::kTod:
    case StringFormat::kDt:
      return date_text(t, v, f, d);
  }
}

// ---- text as numbers ----------------------------------------------------------

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool iequal(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::toupper(static_cast<unsigned char>(a[i])) != std::toupper(static_cast<unsigned char>(b[i]))) return false;
  }
  return true;
}

// An integer literal's text: sign, `2#` `8#` `16#` bases, `_` between digits;
// what follows the digits (a fraction, letters) is ignored; no digit gives 0.
double parse_integer(std::string_view s) {
  s = trim(s);
  bool neg = false;
  if (!s.empty() && (s[0] == '-' || s[0] == '+')) {
    neg = s[0] == '-';
    s.remove_prefix(1);
  }
  int base = 10;
  for (const auto& [prefix, b] : {std::pair{"2#", 2}, std::pair{"8#", 8}, std::pair{"16#", 16}}) {
    if (s.substr(0, std::strlen(prefix)) == prefix) {
      base = b;
      s.remove_prefix(std::strlen(prefix));
      break;
    }
  }
  double v = 0;
  for (char c : s) {
    if (c == '_') continue;
    const int digit = std::isdigit(static_cast<unsigned char>(c)) ? c - '0'
                      : std::isxdigit(static_cast<unsigned char>(c)) && base == 16
                          ? std::toupper(static_cast<unsigned char>(c)) - 'A' + 10
                          : -1;
    if (digit < 0 || digit >= base) break;
    v = v * base + digit;
  }
  return neg ? -v : v;
}

double parse_real(std::string_view s) {
  // From its first 64 characters: strtod may allocate for a longer run of
  // digits, and no number needs more.
  char buf[65];
  s = trim(s);
  const size_t n = std::min<size_t>(s.size(), 64);
  std::memcpy(buf, s.data(), n);
  buf[n] = '\0';
  char* end = nullptr;
  const double v = std::strtod(buf, &end);
  return std::isfinite(v) ? v : 0.0;
}

// `T#1d2h3m4s5ms6us7ns` (also `TIME#`, `t#`, a leading `-`, `_`, fractions on
// the last unit): seconds; text that is no duration gives 0.
double parse_time(std::string_view s) {
  s = trim(s);
  for (std::string_view p : {"TIME#", "T#"}) {
    if (s.size() >= p.size() && iequal(s.substr(0, p.size()), p)) {
      s.remove_prefix(p.size());
      break;
    }
  }
  bool neg = false;
  if (!s.empty() && s[0] == '-') {
    neg = true;
    s.remove_prefix(1);
  }
  double total = 0;
  bool any = false;
  while (!s.empty()) {
    size_t i = 0;
    while (i < s.size() && (std::isdigit(static_cast<unsigned char>(s[i])) || s[i] == '.' || s[i] == '_')) ++i;
    if (i == 0) return 0;
    char digits[64];
    size_t nd = 0;
    for (char c : s.substr(0, i)) {
      if (c != '_' && nd < sizeof digits) digits[nd++] = c;
    }
    const double number = parse_real(std::string_view(digits, nd));
    s.remove_prefix(i);
    size_t u = 0;
    while (u < s.size() && std::isalpha(static_cast<unsigned char>(s[u]))) ++u;
    const std::string_view unit = s.substr(0, u);
    s.remove_prefix(u);
    double scale = 0;
    if (iequal(unit, "d")) scale = 86400;
    else if (iequal(unit, "h")) scale = 3600;
    else if (iequal(unit, "m")) scale = 60;
    else if (iequal(unit, "s")) scale = 1;
    else if (iequal(unit, "ms")) scale = 1e-3;
    else if (iequal(unit, "us")) scale = 1e-6;
    else if (iequal(unit, "ns")) scale = 1e-9;
    else return 0;
    total += number * scale;
    any = true;
  }
  if (!any) return 0;
  return std::round((neg ? -total : total) * 1e9) / 1e9;
}

// MatIEC's __pstring_to_sint: `2#`, `8#`, `16#` only at the very start (any
// character not a digit of the base skipped); else decimal read from the
// right, a character at or above '.' that is no digit restarting the number
// (so the digits before the leftmost such character count: '12.7' is 12,
// '1_000' is 1), characters below '.' skipped, negative only when the text
// starts with '-', at most 20 digits.
double matiec_integer(std::string_view s) {
  if (s.empty()) return 0;
  int base = 0;
  size_t from = 0;
  if (s.substr(0, 2) == "2#") base = 2, from = 2;
  else if (s.substr(0, 2) == "8#") base = 8, from = 2;
  else if (s.substr(0, 3) == "16#") base = 16, from = 3;
  if (base != 0) {
    uint64_t v = 0;
    unsigned shift = 0;
    const unsigned step = base == 2 ? 1 : base == 8 ? 3 : 4;
    for (size_t l = s.size(); l-- > from && shift < 64;) {
      const char c = s[l];
      int digit = -1;
      if (c >= '0' && c <= '9') digit = c - '0';
      else if (base == 16 && std::isxdigit(static_cast<unsigned char>(c))) digit = std::toupper(c) - 'A' + 10;
      if (digit < 0 || digit >= base) continue;
      v |= static_cast<uint64_t>(digit) << shift;
      shift += step;
    }
    return static_cast<double>(static_cast<int64_t>(v));
  }
  const double sign = s[0] == '-' ? -1.0 : 1.0;
  double v = 0, fac = sign;
  int digits = 0;
  for (size_t l = s.size(); l-- > 0 && digits < 20;) {
    const char c = s[l];
    if (c >= '0' && c <= '9') {
      v += (c - '0') * fac;
      fac *= 10;
      ++digits;
    } else if (c >= '.') {
      v = 0;
      fac = sign;
      digits = 0;
    }
  }
  return v;
}

// CODESYS's D#, TOD# and DT# texts (also DATE#, TIME_OF_DAY#,
// DATE_AND_TIME#): seconds since 1970-01-01 (DATE, DT) or midnight (TOD);
// 0 for text that is none.
double parse_date(std::string_view s, StringFormat f) {
  s = trim(s);
  const size_t hash = s.find('#');
  if (hash != std::string_view::npos) s.remove_prefix(hash + 1);
  char buf[64];
  const size_t n = std::min(s.size(), sizeof buf - 1);
  std::memcpy(buf, s.data(), n);
  buf[n] = '\0';
  int y = 0, mo = 0, da = 0, h = 0, mi = 0;
  double sec = 0;
  auto days_from_civil = [](int64_t yy, unsigned m, unsigned dd) {
    yy -= m <= 2;
    const int64_t era = (yy >= 0 ? yy : yy - 399) / 400;
    const auto yoe = static_cast<unsigned>(yy - era * 400);
    const unsigned mp = m > 2 ? m - 3 : m + 9;
    const unsigned doy = (153 * mp + 2) / 5 + dd - 1;
    const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + static_cast<int64_t>(doe) - 719468;
  };
  if (f == StringFormat::kTod) {
    if (std::sscanf(buf, "%d:%d:%lf", &h, &mi, &sec) < 2) return 0;
    return h * 3600.0 + mi * 60.0 + sec;
  }
  if (f == StringFormat::kDate) {
    if (std::sscanf(buf, "%d-%d-%d", &y, &mo, &da) != 3 || mo < 1 || mo > 12 || da < 1 || da > 31) return 0;
    return static_cast<double>(days_from_civil(y, static_cast<unsigned>(mo), static_cast<unsigned>(da))) * 86400.0;
  }
  if (std::sscanf(buf, "%d-%d-%d-%d:%d:%lf", &y, &mo, &da, &h, &mi, &sec) < 5 || mo < 1 || mo > 12 || da < 1 ||
      da > 31) {
    return 0;
  }
  return static_cast<double>(days_from_civil(y, static_cast<unsigned>(mo), static_cast<unsigned>(da))) * 86400.0 +
         h * 3600.0 + mi * 60.0 + sec;
}

}  // namespace

std::string format_for_string(double v, StringFormat f, StringDialect d) {
  Text t;
  format_into(t, v, f, d);
  return std::string(t.buf, t.n);
}

double parse_from_string(std::string_view s, StringFormat f, StringDialect d) {
  const bool matiec = d == StringDialect::kMatiec;
  switch (f) {
    case StringFormat::kSigned:
    case StringFormat::kUnsigned:
    case StringFormat::kBits:
      return matiec ? matiec_integer(s) : parse_integer(s);
    case StringFormat::kReal:
    case StringFormat::kLreal:
      // MatIEC reads a text with a '.' after its first character as a C
      // double, any other as an integer ('1e3' is 1).
      if (matiec) return s.find('.', 1) != std::string_view::npos && s.size() > 1 ? parse_real(s) : matiec_integer(s);
      return parse_real(s);
    case StringFormat::kBool: {
      if (matiec) return s.size() == 1 ? (s[0] == '1' ? 1.0 : 0.0) : iequal(s, "TRUE") ? 1.0 : 0.0;
      const std::string_view t = trim(s);
      return iequal(t, "TRUE") || t == "1" ? 1.0 : 0.0;
    }
    case StringFormat::kTime:
    case StringFormat::kDate:
    case StringFormat::kTod:
    case StringFormat::kDt:
      // MatIEC reads every time type as a number of whole seconds.
      if (matiec) return std::trunc(parse_from_string(s, StringFormat::kLreal, d));
      return f == StringFormat::kTime ? parse_time(s) : parse_date(s, f);
  }
  return 0;
}

// Appends units[0..n) to `out` as UTF-8 (see utf8_of_units).
static void append_utf8_units(std::string& out, const Unit* units, uint32_t n, bool keep_lone) {
  for (uint32_t i = 0; i < n; ++i) {
    uint32_t c = units[i];
    if (c >= 0xD800 && c <= 0xDBFF && i + 1 < n && units[i + 1] >= 0xDC00 && units[i + 1] <= 0xDFFF) {
      c = 0x10000 + ((c - 0xD800) << 10) + (units[++i] - 0xDC00u);
    } else if (c >= 0xD800 && c <= 0xDFFF && !keep_lone) {
      c = 0xFFFD;
    }
    append_utf8(out, c);
  }
}

std::string string_value(const double* V, uint32_t n_values, uint32_t at, bool wide) {
  Unit buf[kMax];
  const uint32_t n = read(V, n_values, at, buf);
  std::string out;
  out.reserve(n);
  if (wide) {
    // A lone surrogate half shows as U+FFFD.
    append_utf8_units(out, buf, n, false);
    return out;
  }
  for (uint32_t i = 0; i < n; ++i) out += static_cast<char>(buf[i] <= 255 ? buf[i] : '?');
  return out;
}

std::string utf8_of_units(const std::vector<uint16_t>& units) {
  std::string out;
  append_utf8_units(out, units.data(), static_cast<uint32_t>(units.size()), true);
  return out;
}

std::vector<uint16_t> utf16_units(std::string_view utf8) {
  std::vector<uint16_t> out;
  for (size_t i = 0; i < utf8.size();) {
    const auto b = static_cast<unsigned char>(utf8[i]);
    uint32_t c = b, more = 0;
    if (b >= 0xF8) c = 0xFFFD, more = 0;  // no UTF-8 lead byte
    else if (b >= 0xF0) c = b & 0x07u, more = 3;
    else if (b >= 0xE0) c = b & 0x0Fu, more = 2;
    else if (b >= 0xC0) c = b & 0x1Fu, more = 1;
    else if (b >= 0x80) more = 0, c = 0xFFFD;  // a stray continuation byte
    size_t k = 1;
    for (; k <= more && i + k < utf8.size() && (static_cast<unsigned char>(utf8[i + k]) & 0xC0) == 0x80; ++k) {
      c = (c << 6) | (static_cast<unsigned char>(utf8[i + k]) & 0x3Fu);
    }
    if (k <= more) c = 0xFFFD;  // cut short
    i += k;
    if (c >= 0x10000) {
      c -= 0x10000;
      out.push_back(static_cast<uint16_t>(0xD800 + (c >> 10)));
      out.push_back(static_cast<uint16_t>(0xDC00 + (c & 0x3FF)));
    } else {
      out.push_back(static_cast<uint16_t>(c));
    }
  }
  return out;
}

bool writes_wide_string(const Instr& I, const double* prepared) {
  return I.op == Op::SCopy && prepared != nullptr && prepared[1] == 1;
}

void string_op(const Instr& I, double* V, uint32_t n_values, const double* P) noexcept {
  Unit a[kMax], b[kMax], r[2 * kMax];
  // (SLen and SFind have no parameters: P[0] is not theirs to read)
  const uint32_t cap = op_param_count(I.op) > 0 ? static_cast<uint32_t>(P[0]) : 0;
  switch (I.op) {
    case Op::SConst: {
      for (uint32_t i = 0; i < cap; ++i) r[i] = static_cast<Unit>(P[1 + i]);
      write(V, I.out, cap, r, cap);
      return;
    }
    case Op::SCopy: {
      // Into a STRING (P[1] = 0) a code above 255 is '?' (WSTRING_TO_STRING).
      const uint32_t n = read(V, n_values, I.in[0], a);
      if (P[1] == 0) {
        for (uint32_t i = 0; i < n; ++i) a[i] = a[i] <= 255 ? a[i] : static_cast<Unit>('?');
      }
      write(V, I.out, cap, a, n);
      return;
    }
    case Op::SSet: {
      const uint32_t n = read(V, n_values, I.in[0], a);
      write(V, I.out, cap, a, n);
      return;
    }
    case Op::SSel: {
      const uint32_t n = read(V, n_values, V[I.in[2]] != 0.0 ? I.in[1] : I.in[0], a);
      write(V, I.out, cap, a, n);
      return;
    }
    case Op::SCat: {
      const uint32_t na = read(V, n_values, I.in[0], a), nb = read(V, n_values, I.in[1], b);
      copy_units(r, a, na);
      copy_units(r + na, b, nb);
      write(V, I.out, cap, r, na + nb);
      return;
    }
    case Op::SLeft:
    case Op::SRight: {
      const uint32_t n = read(V, n_values, I.in[0], a);
      const auto k = static_cast<uint32_t>(std::clamp<int64_t>(whole(V[I.in[1]]), 0, n));
      write(V, I.out, cap, I.op == Op::SLeft ? a : a + (n - k), k);
      return;
    }
    case Op::SMid: {
      // L characters from position P: nothing when P is outside 1..n.
      const uint32_t n = read(V, n_values, I.in[0], a);
      const int64_t l = whole(V[I.in[1]]), p = whole(V[I.in[2]]);
      if (p < 1 || p > n || l <= 0) {
        write(V, I.out, cap, a, 0);
        return;
      }
      write(V, I.out, cap, a + (p - 1), static_cast<size_t>(std::min<int64_t>(l, n - p + 1)));
      return;
    }
    case Op::SIns: {
      // s2 after the first P characters of s1 (P below 0 as 0, past the end as n).
      const uint32_t na = read(V, n_values, I.in[0], a), nb = read(V, n_values, I.in[1], b);
      const auto p = static_cast<uint32_t>(std::clamp<int64_t>(whole(V[I.in[2]]), 0, na));
      copy_units(r, a, p);
      copy_units(r + p, b, nb);
      copy_units(r + p + nb, a + p, na - p);
      write(V, I.out, cap, r, na + nb);
      return;
    }
    case Op::SDel: {
      // L characters from position P removed: nothing when P is outside 1..n.
      const uint32_t n = read(V, n_values, I.in[0], a);
      const int64_t l = whole(V[I.in[1]]), p = whole(V[I.in[2]]);
      if (p < 1 || p > n || l <= 0) {
        write(V, I.out, cap, a, n);
        return;
      }
      const auto keep = static_cast<uint32_t>(p - 1);
      const auto from = static_cast<uint32_t>(std::min<int64_t>(n, p - 1 + l));
      copy_units(r, a, keep);
      copy_units(r + keep, a + from, n - from);
      write(V, I.out, cap, r, keep + (n - from));
      return;
    }
    case Op::SLen:
      V[I.out] = static_cast<double>(read(V, n_values, I.in[0], a));
      return;
    case Op::SFind: {
      const uint32_t na = read(V, n_values, I.in[0], a), nb = read(V, n_values, I.in[1], b);
      double pos = 0;
      if (nb > 0 && nb <= na) {
        for (uint32_t i = 0; i + nb <= na; ++i) {
          if (same_units(a + i, b, nb)) {
            pos = i + 1;
            break;
          }
        }
      }
      V[I.out] = pos;
      return;
    }
    case Op::SCmp: {
      const uint32_t na = read(V, n_values, I.in[0], a), nb = read(V, n_values, I.in[1], b);
      const int c = compare(a, na, b, nb);
      bool y = false;
      switch (static_cast<int>(P[0])) {
        case 0: y = c == 0; break;
        case 1: y = c != 0; break;
        case 2: y = c < 0; break;
        case 3: y = c <= 0; break;
        case 4: y = c > 0; break;
        default: y = c >= 0; break;
      }
      V[I.out] = y ? 1.0 : 0.0;
      return;
    }
    case Op::SFmt: {
      Text t;
      format_into(t, V[I.in[0]], static_cast<StringFormat>(static_cast<int>(P[1])),
                  static_cast<StringDialect>(static_cast<int>(P[2])));
      for (size_t i = 0; i < t.n; ++i) r[i] = static_cast<unsigned char>(t.buf[i]);
      write(V, I.out, cap, r, t.n);
      return;
    }
    case Op::SParse: {
      const uint32_t n = read(V, n_values, I.in[0], a);
      char text[kMax];
      for (uint32_t i = 0; i < n; ++i) text[i] = static_cast<char>(a[i] <= 255 ? a[i] : '?');
      V[I.out] = parse_from_string(std::string_view(text, n),
                                   static_cast<StringFormat>(static_cast<int>(P[0])),
                                   static_cast<StringDialect>(static_cast<int>(P[1])));
      return;
    }
    default:
      return;
  }
}

}  // namespace rtplc
