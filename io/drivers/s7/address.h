// S7 item addresses in the syntax S7 users already write (DB1.DBX0.0, DB1.DBW4,
// MW2, I0.0, QB0, C0, T0, ... with an optional :TYPE), the data types they carry,
// and the conversions between the bytes on the wire, raw values and engineering
// values (spec: s7-client.md, "Read var"; issue 4, item 4).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "common/result.h"
#include "io/drivers/s7/protocol.h"

namespace rtplc::s7 {

enum class DataType : uint8_t {
  kBool,     // one bit
  kByte,     // 8 bits unsigned
  kChar,     // one character (CHAR): its code 0..255
  kSInt,     // 8 bits signed (SINT)
  kWord,     // 16 bits unsigned
  kInt,      // 16 bits signed
  kDWord,    // 32 bits unsigned
  kDInt,     // 32 bits signed
  kReal,     // IEEE 754 single
  kCounter,  // one counter word, raw
  kTimer,    // one timer word (S5TIME), raw
};

// Bytes one value of `t` takes in the PLC (a bool takes its byte).
size_t type_size(DataType t);
std::string_view type_name(DataType t);

// One scalar variable in a PLC.
struct ItemAddress {
  Area area = Area::kDB;
  uint16_t db = 0;      // DB number, 0 outside DBs
  uint32_t start = 0;   // byte offset; counters/timers: the element index
  uint8_t bit = 0;      // kBool only
  DataType type = DataType::kByte;

  bool operator==(const ItemAddress&) const = default;
};

// Parses "DB1.DBX0.0", "DB1.DBD8:REAL", "MW2", "I0.0", "C0", ... (case-insensitive;
// German E/A/Z accepted for I/Q/C). The error says what was expected and where.
Result<ItemAddress> parse_address(std::string_view text);
// The canonical spelling of an address (what parse_address reads back).
std::string format_address(const ItemAddress& a);

// The request item that reads or writes exactly this variable.
VarSpec var_spec_for(const ItemAddress& a);

// A raw value: the item's bit pattern, zero-extended to 64 bits.
uint64_t decode_raw(DataType t, uint8_t bit, ByteSpan bytes);  // bytes.size() >= type_size
// Writes type_size(t) bytes big-endian (a bool as 0x00/0x01).
void encode_raw(DataType t, uint64_t raw, std::span<uint8_t> out);

// Raw -> number: signed types sign-extend, REAL reinterprets the bits, CHAR is
// its character code 0..255.
double raw_to_double(DataType t, uint64_t raw);

// The values an item of type `t` holds: BOOL 0..1, BYTE 0..255, INT
// -32768..32767, REAL -FLT_MAX..FLT_MAX, ... (COUNTER and TIMER: the raw word).
struct TypeRange {
  double lo = 0;
  double hi = 0;
};
TypeRange type_range(DataType t);
std::string range_text(DataType t);  // "-32768..32767"

// A number (a task's output, after scaling) -> raw, for writes. Integer types
// round to the nearest integer; a BOOL is "not zero". False, `raw` untouched,
// when the value is not a number or falls outside type_range(t): a write never
// clamps or wraps, since a wrong value would look delivered. Never allocates.
bool value_to_raw(DataType t, double v, uint64_t& raw) noexcept;

// Text -> raw for the command line, strictly: every value is checked against
// its type's range, integer types take whole numbers only (decimal, or hex as
// 0x1F, both with an optional sign: hex is a number, not a bit pattern, so an
// INT takes -0x8000..0x7FFF), REAL a finite number that fits a float, BOOL
// 1/0/true/false/on/off, CHAR exactly one character (`A`, `7` is the digit)
// or its code in hex (0x00..0xFF). The error says why and gives the range.
Result<uint64_t> parse_value(DataType t, std::string_view text);
// The same, the error starting with the item ("DB1.DBW4:INT: 32768 is out of
// range for INT (-32768..32767)").
Result<uint64_t> encode_value(const ItemAddress& a, std::string_view text);
// Raw -> text in the syntax parse_value reads (CHAR: the character when it is
// printable, otherwise its code as 0x0D).
std::string format_value(DataType t, uint64_t raw);

}  // namespace rtplc::s7
