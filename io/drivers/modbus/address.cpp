// Modbus item addresses, value encoding and range checks (see address.h).
#include "io/drivers/modbus/address.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

namespace rtplc::modbus {
namespace {

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> parts;
  size_t start = 0;
  for (;;) {
    const size_t at = s.find(sep, start);
    parts.push_back(s.substr(start, at == std::string_view::npos ? std::string_view::npos : at - start));
    if (at == std::string_view::npos) return parts;
    start = at + 1;
  }
}

bool parse_u32(std::string_view s, uint32_t& out) {
  if (s.empty()) return false;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size();
}

struct Range {
  double lo, hi;
};

Range range_of(ItemType t) {
  switch (t) {
    case ItemType::kBit: return {0, 1};
    case ItemType::kU16: return {0, 65535};
    case ItemType::kI16: return {-32768, 32767};
    case ItemType::kU32: return {0, 4294967295.0};
    case ItemType::kI32: return {-2147483648.0, 2147483647.0};
    case ItemType::kF32:
      return {-static_cast<double>(std::numeric_limits<float>::max()),
              static_cast<double>(std::numeric_limits<float>::max())};
  }
  return {0, 0};
}

}  // namespace

bool is_bit_table(Table t) { return t == Table::kCoil || t == Table::kDiscreteInput; }
bool is_writable(Table t) { return t == Table::kCoil || t == Table::kHoldingRegister; }

uint16_t width(const Address& a) {
  switch (a.type) {
    case ItemType::kU32:
    case ItemType::kI32:
    case ItemType::kF32: return 2;
    default: return 1;
  }
}

const char* table_name(Table t) {
  switch (t) {
    case Table::kCoil: return "coil";
    case Table::kDiscreteInput: return "di";
    case Table::kInputRegister: return "ir";
    case Table::kHoldingRegister: return "hr";
  }
  return "?";
}

const char* type_name(ItemType t) {
  switch (t) {
    case ItemType::kBit: return "bit";
    case ItemType::kU16: return "u16";
    case ItemType::kI16: return "i16";
    case ItemType::kU32: return "u32";
    case ItemType::kI32: return "i32";
    case ItemType::kF32: return "f32";
  }
  return "?";
}

Result<Address> parse_address(std::string_view text) {
  const std::vector<std::string_view> parts = split(text, ':');
  Address a;
  const std::string_view t = parts[0];
  if (t == "coil") a.table = Table::kCoil;
  else if (t == "di") a.table = Table::kDiscreteInput;
  else if (t == "ir") a.table = Table::kInputRegister;
  else if (t == "hr") a.table = Table::kHoldingRegister;
  else {
    return make_error(fmt::format("'{}': unknown table '{}' (expected coil, di, ir or hr)", text, t));
  }
  if (parts.size() < 2) return make_error(fmt::format("'{}': missing address (e.g. {}:0)", text, t));
  uint32_t n = 0;
  if (!parse_u32(parts[1], n) || n > 65535) {
    return make_error(fmt::format("'{}': address must be 0..65535, got '{}'", text, parts[1]));
  }
  a.address = static_cast<uint16_t>(n);
  const bool bits = is_bit_table(a.table);
  a.type = bits ? ItemType::kBit : ItemType::kU16;
  size_t next = 2;
  if (next < parts.size()) {
    if (bits) return make_error(fmt::format("'{}': a {} is one bit and takes no type", text, t));
    const std::string_view ty = parts[next++];
    if (ty == "u16") a.type = ItemType::kU16;
    else if (ty == "i16") a.type = ItemType::kI16;
    else if (ty == "u32") a.type = ItemType::kU32;
    else if (ty == "i32") a.type = ItemType::kI32;
    else if (ty == "f32") a.type = ItemType::kF32;
    else return make_error(fmt::format("'{}': unknown type '{}' (expected u16, i16, u32, i32 or f32)", text, ty));
  }
  if (next < parts.size()) {
    if (parts[next] != "swapped" || width(a) != 2) {
      return make_error(fmt::format("'{}': only a two-register type (u32, i32, f32) takes ':swapped'", text));
    }
    a.swapped = true;
    ++next;
  }
  if (next < parts.size()) return make_error(fmt::format("'{}': unexpected ':{}'", text, parts[next]));
  if (uint32_t{a.address} + width(a) > 65536) {
    return make_error(fmt::format("'{}': a two-register value needs address + 1 <= 65535", text));
  }
  return a;
}

Result<Assignment> parse_assignment(std::string_view text) {
  const size_t eq = text.find('=');
  if (eq == std::string_view::npos) {
    return make_error(fmt::format("'{}': expected ADDRESS=VALUE, e.g. hr:20=513", text));
  }
  auto a = parse_address(text.substr(0, eq));
  if (!a) return make_error(a.error());
  if (!is_writable(a->table)) {
    return make_error(fmt::format("'{}': {} is read-only (write coil or hr)", text, table_name(a->table)));
  }
  const std::string v(text.substr(eq + 1));
  char* end = nullptr;
  const double value = v.empty() ? 0 : std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0') return make_error(fmt::format("'{}': '{}' is not a number", text, v));
  if (auto r = check_value(*a, value); !r) return make_error(fmt::format("'{}': {}", text, r.error()));
  return Assignment{*a, value};
}

bool fits(const Address& a, double raw) {
  if (!std::isfinite(raw)) return false;
  const Range r = range_of(a.type);
  if (raw < r.lo || raw > r.hi) return false;
  return a.type == ItemType::kF32 || raw == std::trunc(raw);
}

Result<void> check_value(const Address& a, double value) {
  if (!std::isfinite(value)) return make_error(fmt::format("{} is not a finite number", value));
  const Range r = range_of(a.type);
  if (value < r.lo || value > r.hi) {
    if (a.type == ItemType::kF32) return make_error(fmt::format("{} is out of range for f32", value));
    return make_error(fmt::format("{} is out of range for {} ({:.0f}..{:.0f})", value, type_name(a.type), r.lo, r.hi));
  }
  if (a.type != ItemType::kF32 && value != std::trunc(value)) {
    return make_error(fmt::format("{} is not a whole number, as {} needs", value, type_name(a.type)));
  }
  return {};
}

void encode(const Address& a, double value, uint16_t* words) {
  uint32_t raw = 0;
  switch (a.type) {
    case ItemType::kBit: words[0] = value != 0 ? 1 : 0; return;
    case ItemType::kU16: words[0] = static_cast<uint16_t>(value); return;
    case ItemType::kI16: words[0] = static_cast<uint16_t>(static_cast<int16_t>(value)); return;
    case ItemType::kU32: raw = static_cast<uint32_t>(value); break;
    case ItemType::kI32: raw = static_cast<uint32_t>(static_cast<int32_t>(value)); break;
    case ItemType::kF32: {
      const auto f = static_cast<float>(value);
      std::memcpy(&raw, &f, sizeof raw);
      break;
    }
  }
  const auto hi = static_cast<uint16_t>(raw >> 16);
  const auto lo = static_cast<uint16_t>(raw & 0xFFFF);
  words[0] = a.swapped ? lo : hi;
  words[1] = a.swapped ? hi : lo;
}

double decode(const Address& a, const uint16_t* words) {
  switch (a.type) {
    case ItemType::kBit: return words[0] != 0 ? 1.0 : 0.0;
    case ItemType::kU16: return words[0];
    case ItemType::kI16: return static_cast<int16_t>(words[0]);
    default: break;
  }
  const uint32_t hi = a.swapped ? words[1] : words[0];
  const uint32_t lo = a.swapped ? words[0] : words[1];
  const uint32_t raw = hi << 16 | lo;
  if (a.type == ItemType::kU32) return raw;
  if (a.type == ItemType::kI32) return static_cast<int32_t>(raw);
  float f;
  std::memcpy(&f, &raw, sizeof f);
  return f;
}

std::string to_string(const Address& a) {
  std::string s = fmt::format("{}:{}", table_name(a.table), a.address);
  if (!is_bit_table(a.table) && a.type != ItemType::kU16) s += fmt::format(":{}", type_name(a.type));
  if (a.swapped) s += ":swapped";
  return s;
}

std::string format_value(const Address& a, double value) {
  if (a.type == ItemType::kF32) return fmt::format("{}", static_cast<float>(value));
  return fmt::format("{:.0f}", value);
}

const char* exception_name(int code) {
  switch (code) {
    case 1: return "illegal function";
    case 2: return "illegal data address";
    case 3: return "illegal data value";
    case 4: return "slave device failure";
    case 5: return "acknowledge";
    case 6: return "slave device busy";
    case 7: return "negative acknowledge";
    case 8: return "memory parity error";
    case 10: return "gateway path unavailable";
    case 11: return "gateway target device failed to respond";
    default: return "unknown exception";
  }
}

std::string exception_text(int code) { return fmt::format("{} (exception {})", exception_name(code), code); }

}  // namespace rtplc::modbus
