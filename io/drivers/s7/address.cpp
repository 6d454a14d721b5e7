// The S7 address syntax and value conversions (issue 4, item 4). The parser is a
// cursor over the text with one function per production; each error names the
// column and what would have been accepted there.
//
//   address  := db_item | area_item | timer_counter [ ':' TYPE ]
//   db_item  := 'DB' n '.' 'DB' ( 'X' n '.' bit | 'B' n | 'W' n | 'D' n )
//   area_item:= ('I'|'E'|'Q'|'A'|'M') ( n '.' bit | 'X' n '.' bit | 'B' n | 'W' n | 'D' n )
//   timer_counter := ('C'|'Z'|'T') n
#include "io/drivers/s7/address.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>

namespace rtplc::s7 {
namespace {

constexpr uint32_t kMaxByteOffset = (1u << 21) - 1;  // 24-bit bit address

class Cursor {
 public:
  explicit Cursor(std::string_view t) : text_(t) {}

  bool done() const { return pos_ >= text_.size(); }
  char peek() const { return done() ? '\0' : static_cast<char>(std::toupper(static_cast<unsigned char>(text_[pos_]))); }
  bool accept(char c) {
    if (peek() != c) return false;
    ++pos_;
    return true;
  }
  size_t pos() const { return pos_; }
  std::string_view rest() const { return text_.substr(pos_); }
  void skip(size_t n) { pos_ += n; }

  Error fail(std::string_view what) const {
    const std::string at = done() ? "at the end" : fmt::format("at column {} ('{}')", pos_ + 1, text_.substr(pos_));
    return make_error(fmt::format("bad S7 address '{}' {}: expected {}", text_, at, what));
  }

  Result<uint32_t> number(std::string_view what, uint32_t max) {
    const size_t start = pos_;
    uint64_t v = 0;
    while (!done() && std::isdigit(static_cast<unsigned char>(text_[pos_]))) {
      v = v * 10 + static_cast<uint64_t>(text_[pos_] - '0');
      if (v > max) {
        pos_ = start;
        return make_error(fmt::format("bad S7 address '{}': {} at column {} is larger than {}", text_, what, start + 1, max));
      }
      ++pos_;
    }
    if (pos_ == start) return fail(what);
    return static_cast<uint32_t>(v);
  }

 private:
  std::string_view text_;
  size_t pos_ = 0;
};

// The unit letter after DB/I/Q/M: X (bit), B, W, D.
Result<void> parse_sized(Cursor& c, ItemAddress& a, bool bare_bit_allowed) {
  char unit = c.peek();
  if (unit == 'X' || unit == 'B' || unit == 'W' || unit == 'D') {
    c.skip(1);
  } else if (bare_bit_allowed && std::isdigit(static_cast<unsigned char>(unit))) {
    unit = 'X';
  } else {
    return c.fail(bare_bit_allowed ? "a byte.bit (e.g. 0.1) or X, B, W, D" : "X, B, W or D");
  }
  auto off = c.number("a byte offset", kMaxByteOffset);
  if (!off) return make_error(off.error());
  a.start = *off;
  switch (unit) {
    case 'X': {
      if (!c.accept('.')) return c.fail("'.' and a bit number 0-7");
      auto bit = c.number("a bit number 0-7", 7);
      if (!bit) return make_error(bit.error());
      a.bit = static_cast<uint8_t>(*bit);
      a.type = DataType::kBool;
      break;
    }
    case 'B': a.type = DataType::kByte; break;
    case 'W': a.type = DataType::kWord; break;
    default: a.type = DataType::kDWord; break;
  }
  return {};
}

Result<DataType> parse_type_suffix(std::string_view name, DataType natural, std::string_view text) {
  std::string up;
  for (char ch : name) up.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(ch))));
  struct Entry {
    const char* name;
    DataType type;
  };
  static constexpr Entry kTypes[] = {
      {"BOOL", DataType::kBool}, {"BYTE", DataType::kByte},   {"CHAR", DataType::kChar}, {"SINT", DataType::kSInt},
      {"USINT", DataType::kByte}, {"WORD", DataType::kWord},  {"INT", DataType::kInt},   {"UINT", DataType::kWord},
      {"DWORD", DataType::kDWord}, {"UDINT", DataType::kDWord}, {"DINT", DataType::kDInt}, {"REAL", DataType::kReal},
  };
  for (const Entry& e : kTypes) {
    if (up != e.name) continue;
    if (type_size(e.type) != type_size(natural) || (e.type == DataType::kBool) != (natural == DataType::kBool) ||
        natural == DataType::kCounter || natural == DataType::kTimer) {
      return make_error(fmt::format("bad S7 address '{}': type {} does not fit a {} address", text, e.name,
                                    type_name(natural)));
    }
    return e.type;
  }
  return make_error(fmt::format(
      "bad S7 address '{}': unknown type '{}' (known: BOOL, BYTE, USINT, CHAR, SINT, WORD, UINT, INT, DWORD, UDINT, "
      "DINT, REAL)", text, name));
}

}  // namespace

size_t type_size(DataType t) {
  switch (t) {
    case DataType::kBool:
    case DataType::kByte:
    case DataType::kChar:
    case DataType::kSInt:
      return 1;
    case DataType::kWord:
    case DataType::kInt:
    case DataType::kCounter:
    case DataType::kTimer:
      return 2;
    case DataType::kDWord:
    case DataType::kDInt:
    case DataType::kReal:
      return 4;
  }
  return 1;
}

std::string_view type_name(DataType t) {
  switch (t) {
    case DataType::kBool: return "BOOL";
    case DataType::kByte: return "BYTE";
    case DataType::kChar: return "CHAR";
    case DataType::kSInt: return "SINT";
    case DataType::kWord: return "WORD";
    case DataType::kInt: return "INT";
    case DataType::kDWord: return "DWORD";
    case DataType::kDInt: return "DINT";
    case DataType::kReal: return "REAL";
    case DataType::kCounter: return "COUNTER";
    case DataType::kTimer: return "TIMER";
  }
  return "?";
}

Result<ItemAddress> parse_address(std::string_view text) {
  // Split off the type suffix first so the address part parses on its own.
  std::string_view addr = text;
  std::string_view suffix;
  if (size_t colon = text.find(':'); colon != std::string_view::npos) {
    addr = text.substr(0, colon);
    suffix = text.substr(colon + 1);
    if (suffix.empty()) return make_error(fmt::format("bad S7 address '{}': expected a type after ':'", text));
  }
  if (addr.empty()) return make_error("empty S7 address (examples: DB1.DBW4, MW2, I0.0, C0)");
  Cursor c(addr);
  ItemAddress a;
  const char first = c.peek();
  if (first == 'D') {
    c.skip(1);
    if (!c.accept('B')) return c.fail("'DB' and a DB number (e.g. DB1.DBW0)");
    auto db = c.number("a DB number 1-65535", 65535);
    if (!db) return make_error(db.error());
    if (*db == 0) return make_error(fmt::format("bad S7 address '{}': DB numbers start at 1", text));
    a.area = Area::kDB;
    a.db = static_cast<uint16_t>(*db);
    if (!c.accept('.')) return c.fail("'.DB' after the DB number (e.g. DB1.DBW0)");
    if (!c.accept('D') || !c.accept('B')) return c.fail("'DB' then X, B, W or D (e.g. DB1.DBX0.0)");
    if (auto r = parse_sized(c, a, false); !r) return make_error(r.error());
  } else if (first == 'I' || first == 'E' || first == 'Q' || first == 'A' || first == 'M') {
    c.skip(1);
    a.area = first == 'M' ? Area::kFlags : (first == 'I' || first == 'E') ? Area::kInputs : Area::kOutputs;
    if (auto r = parse_sized(c, a, true); !r) return make_error(r.error());
  } else if (first == 'C' || first == 'Z' || first == 'T') {
    c.skip(1);
    auto n = c.number(first == 'T' ? "a timer number" : "a counter number", 65535);
    if (!n) return make_error(n.error());
    a.area = first == 'T' ? Area::kTimers : Area::kCounters;
    a.start = *n;
    a.type = first == 'T' ? DataType::kTimer : DataType::kCounter;
  } else {
    return c.fail("an area: DB, I, Q, M, C or T (e.g. DB1.DBW4, MW2, I0.0, C0)");
  }
  if (!c.done()) return c.fail("the end of the address (or ':TYPE')");
  if (!suffix.empty()) {
    auto t = parse_type_suffix(suffix, a.type, text);
    if (!t) return make_error(t.error());
    a.type = *t;
  }
  return a;
}

std::string format_address(const ItemAddress& a) {
  if (a.area == Area::kCounters) return fmt::format("C{}", a.start);
  if (a.area == Area::kTimers) return fmt::format("T{}", a.start);
  const std::string_view area = a.area == Area::kDB        ? std::string_view("DB")
                                : a.area == Area::kInputs  ? std::string_view("I")
                                : a.area == Area::kOutputs ? std::string_view("Q")
                                                           : std::string_view("M");
  const std::string prefix = a.area == Area::kDB ? fmt::format("DB{}.{}", a.db, area) : std::string(area);
  if (a.type == DataType::kBool) {
    return fmt::format("{}{}{}.{}", prefix, a.area == Area::kDB ? "X" : "", a.start, a.bit);
  }
  const size_t size = type_size(a.type);
  const char unit = size == 1 ? 'B' : size == 2 ? 'W' : 'D';
  const bool natural = a.type == DataType::kByte || a.type == DataType::kWord || a.type == DataType::kDWord;
  if (natural) return fmt::format("{}{}{}", prefix, unit, a.start);
  return fmt::format("{}{}{}:{}", prefix, unit, a.start, type_name(a.type));
}

VarSpec var_spec_for(const ItemAddress& a) {
  VarSpec v;
  v.area = a.area;
  v.db = a.area == Area::kDB ? a.db : 0;
  if (a.area == Area::kCounters || a.area == Area::kTimers) {
    v.ts = a.area == Area::kCounters ? TransportSize::kCounter : TransportSize::kTimer;
    v.count = 1;
    v.address = a.start;
  } else if (a.type == DataType::kBool) {
    v.ts = TransportSize::kBit;
    v.count = 1;
    v.address = a.start * 8 + a.bit;
  } else {
    v.ts = TransportSize::kByte;
    v.count = static_cast<uint16_t>(type_size(a.type));
    v.address = a.start * 8;
  }
  return v;
}

uint64_t decode_raw(DataType t, uint8_t bit, ByteSpan b) {
  switch (type_size(t)) {
    case 1:
      return t == DataType::kBool ? (static_cast<unsigned>(b[0]) >> (bit & 7u)) & 1u : b[0];
    case 2:
      return static_cast<uint64_t>(b[0]) << 8 | b[1];
    default:
      return static_cast<uint64_t>(b[0]) << 24 | static_cast<uint64_t>(b[1]) << 16 | static_cast<uint64_t>(b[2]) << 8 |
             b[3];
  }
}

void encode_raw(DataType t, uint64_t raw, std::span<uint8_t> out) {
  const size_t n = type_size(t);
  if (t == DataType::kBool) raw = raw != 0 ? 1 : 0;
  for (size_t i = 0; i < n; ++i) out[i] = static_cast<uint8_t>((raw >> (8 * (n - 1 - i))) & 0xFF);
}

double raw_to_double(DataType t, uint64_t raw) {
  switch (t) {
    case DataType::kSInt: return static_cast<double>(static_cast<int8_t>(raw & 0xFF));
    case DataType::kInt: return static_cast<double>(static_cast<int16_t>(raw & 0xFFFF));
    case DataType::kDInt: return static_cast<double>(static_cast<int32_t>(raw & 0xFFFFFFFF));
    case DataType::kReal: return static_cast<double>(std::bit_cast<float>(static_cast<uint32_t>(raw)));
    default: return static_cast<double>(raw);
  }
}

TypeRange type_range(DataType t) {
  switch (t) {
    case DataType::kBool: return {0, 1};
    case DataType::kByte:
    case DataType::kChar: return {0, 255};
    case DataType::kSInt: return {-128, 127};
    case DataType::kWord:
    case DataType::kCounter:
    case DataType::kTimer: return {0, 65535};
    case DataType::kInt: return {-32768, 32767};
    case DataType::kDWord: return {0, 4294967295.0};
    case DataType::kDInt: return {-2147483648.0, 2147483647.0};
    case DataType::kReal: return {-std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
  }
  return {0, 0};
}

std::string range_text(DataType t) {
  const TypeRange r = type_range(t);
  if (t == DataType::kReal) return fmt::format("{}..{}", static_cast<float>(r.lo), static_cast<float>(r.hi));
  return fmt::format("{}..{}", static_cast<int64_t>(r.lo), static_cast<int64_t>(r.hi));
}

namespace {

// A double that converts to a finite float: below FLT_MAX plus half its ulp
// (2^128 - 2^103); from there on it rounds to infinity. So 3.4028235e38, the
// range as printed, is accepted and ends FLT_MAX.
bool fits_float(double d) { return std::fabs(d) < 0x1.ffffffp127; }

uint64_t width_mask(DataType t) {
  const size_t n = type_size(t);
  return n == 1 ? 0xFFu : n == 2 ? 0xFFFFu : 0xFFFFFFFFu;
}

Error out_of_range(DataType t, std::string_view text) {
  return make_error(fmt::format("{} is out of range for {} ({})", text, type_name(t), range_text(t)));
}

// CHAR: one character, or its code in hex. A lone digit is the digit: "7" is
// 0x37, never 7, so a single character always means itself.
Result<uint64_t> parse_char(std::string_view text) {
  if (text.size() == 1) return uint64_t{static_cast<unsigned char>(text[0])};
  const auto how = "a CHAR takes one character (MB0:CHAR=A) or its code in hex (MB0:CHAR=0x41)";
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    uint64_t code = 0;
    const std::string_view digits = text.substr(2);
    auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), code, 16);
    if (p != digits.data() + digits.size() || (ec != std::errc() && ec != std::errc::result_out_of_range)) {
      return make_error(fmt::format("'{}' is not a hex character code; {}", text, how));
    }
    if (ec == std::errc::result_out_of_range || code > 0xFF) {
      return make_error(fmt::format("{} is out of range for CHAR (one character, or a code 0x00..0xFF)", text));
    }
    return code;
  }
  if (text.empty()) return make_error(fmt::format("an empty value is not a CHAR; {}", how));
  const bool digits = std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (digits) {
    uint64_t code = 0;
    std::from_chars(text.data(), text.data() + text.size(), code);
    if (code <= 0xFF) {
      return make_error(fmt::format("'{}' is not one character; {}: for the code {} write 0x{:02X}", text, how, code, code));
    }
  }
  return make_error(fmt::format("'{}' is not one character; {}", text, how));
}

Result<uint64_t> parse_real(std::string_view text, const std::string& low) {
  double d = 0;
  auto [p, ec] = std::from_chars(low.data(), low.data() + low.size(), d);
  if (low.empty() || p != low.data() + low.size() ||
      (ec != std::errc() && ec != std::errc::result_out_of_range)) {
    return make_error(fmt::format("'{}' is not a REAL value (e.g. 3.25, -1e3)", text));
  }
  if (ec == std::errc() && (std::isnan(d) || std::isinf(d))) {
    return make_error(fmt::format("{} is not a finite number; REAL takes {}", text, range_text(DataType::kReal)));
  }
  // Too large or too small for a double (1e400, 1e-400; from_chars leaves no
  // value to look at), or too large for a float (1e39): never written as inf.
  if (ec == std::errc::result_out_of_range) return out_of_range(DataType::kReal, text);
  if (!fits_float(d)) return out_of_range(DataType::kReal, text);
  return uint64_t{std::bit_cast<uint32_t>(static_cast<float>(d))};
}

// Integer types: an optional sign, then decimal or 0x hex digits. Hex is a
// number like decimal (INT=0xFFFF is out of range, not -1).
Result<uint64_t> parse_integer(DataType t, std::string_view text, std::string_view low) {
  std::string_view s = low;
  const bool neg = !s.empty() && s[0] == '-';
  if (!s.empty() && (s[0] == '-' || s[0] == '+')) s.remove_prefix(1);
  int base = 10;
  if (s.size() > 2 && s[0] == '0' && s[1] == 'x') {
    s.remove_prefix(2);
    base = 16;
  }
  uint64_t magnitude = 0;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), magnitude, base);
  const bool whole = !s.empty() && p == s.data() + s.size();
  if (whole && ec == std::errc::result_out_of_range) return out_of_range(t, text);
  if (!whole || ec != std::errc()) {
    double d = 0;
    auto [q, dec] = std::from_chars(low.data(), low.data() + low.size(), d);
    if (!low.empty() && dec == std::errc() && q == low.data() + low.size() && std::isfinite(d)) {
      return make_error(fmt::format("{} is not a whole number; {} takes whole numbers {}", text, type_name(t),
                                    range_text(t)));
    }
    return make_error(fmt::format("'{}' is not a {} value (a whole number {}, decimal or hex as 0x1F)", text,
                                  type_name(t), range_text(t)));
  }
  // Every type's range lies within -2^31..2^32-1, so a larger magnitude is out.
  if (magnitude > 0xFFFFFFFFu) return out_of_range(t, text);
  const int64_t v = neg ? -static_cast<int64_t>(magnitude) : static_cast<int64_t>(magnitude);
  const TypeRange r = type_range(t);
  if (static_cast<double>(v) < r.lo || static_cast<double>(v) > r.hi) return out_of_range(t, text);
  return static_cast<uint64_t>(v) & width_mask(t);
}

}  // namespace

bool value_to_raw(DataType t, double v, uint64_t& raw) noexcept {
  if (std::isnan(v)) return false;
  if (t == DataType::kBool) {
    raw = v != 0.0 ? 1 : 0;
    return true;
  }
  if (t == DataType::kReal) {
    if (!fits_float(v)) return false;  // also +-inf
    raw = std::bit_cast<uint32_t>(static_cast<float>(v));
    return true;
  }
  const TypeRange r = type_range(t);
  const double whole = std::round(v);
  if (!(whole >= r.lo && whole <= r.hi)) return false;
  raw = static_cast<uint64_t>(static_cast<int64_t>(whole)) & width_mask(t);
  return true;
}

Result<uint64_t> parse_value(DataType t, std::string_view text) {
  if (t == DataType::kChar) return parse_char(text);
  std::string low;
  for (char ch : text) low.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(ch))));
  if (t == DataType::kBool) {
    if (low == "1" || low == "true" || low == "on") return uint64_t{1};
    if (low == "0" || low == "false" || low == "off") return uint64_t{0};
    return make_error(fmt::format("'{}' is not a BOOL value (use 1/0, true/false, on/off)", text));
  }
  if (t == DataType::kReal) return parse_real(text, low);
  return parse_integer(t, text, low);
}

Result<uint64_t> encode_value(const ItemAddress& a, std::string_view text) {
  auto v = parse_value(a.type, text);
  if (!v) return make_error(fmt::format("{}: {}", format_address(a), v.error()));
  return v;
}

std::string format_value(DataType t, uint64_t raw) {
  switch (t) {
    case DataType::kBool: return raw != 0 ? "true" : "false";
    case DataType::kChar: {
      const auto c = static_cast<unsigned char>(raw & 0xFF);
      if (c > 0x20 && c < 0x7F) return std::string(1, static_cast<char>(c));
      return fmt::format("0x{:02X}", c);
    }
    case DataType::kSInt:
    case DataType::kInt:
    case DataType::kDInt: return fmt::format("{}", static_cast<int64_t>(raw_to_double(t, raw)));
    case DataType::kReal: return fmt::format("{}", std::bit_cast<float>(static_cast<uint32_t>(raw)));
    default: return fmt::format("{}", raw);
  }
}

}  // namespace rtplc::s7
