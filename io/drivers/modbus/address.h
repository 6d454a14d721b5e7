// Modbus item addresses as the commissioning commands and the config take them
// (issue 9: `coil:N`, `di:N`, `ir:N[:TYPE]`, `hr:N[:TYPE]`, N the 0-based
// protocol address), the encoding of engineering values into registers and
// back, and the range checks that refuse a value before anything is sent.
// Two-register types are high word first unless suffixed `:swapped`.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "common/result.h"

namespace rtplc::modbus {

enum class Table : uint8_t {
  kCoil,             // read/write bits (FC 1, 5, 15)
  kDiscreteInput,    // read-only bits (FC 2)
  kInputRegister,    // read-only 16-bit words (FC 4)
  kHoldingRegister,  // read/write 16-bit words (FC 3, 6, 16)
};

enum class ItemType : uint8_t { kBit, kU16, kI16, kU32, kI32, kF32 };

struct Address {
  Table table = Table::kHoldingRegister;
  uint16_t address = 0;
  ItemType type = ItemType::kU16;
  bool swapped = false;  // 32-bit types: low word first
  friend bool operator==(const Address&, const Address&) = default;
};

bool is_bit_table(Table t);
bool is_writable(Table t);
// Registers (or bits) the item occupies: 1 or 2.
uint16_t width(const Address& a);
const char* table_name(Table t);      // "hr"
const char* type_name(ItemType t);   // "f32"

// "hr:4:f32", "hr:4:f32:swapped", "coil:5", "di:3", "ir:7:i16".
Result<Address> parse_address(std::string_view text);
// The same, then "=VALUE": "hr:20=513", "coil:21=1", "hr:22:f32=1.5".
struct Assignment {
  Address address;
  double value = 0;
};
Result<Assignment> parse_assignment(std::string_view text);

// Whether `raw` fits the item (finite, in range, whole for integer types);
// never allocates (the bridge thread checks writes with it).
bool fits(const Address& a, double raw);
// Empty when `value` fits the item; else why not ("300000 is out of range for
// u16 (0..65535)").
Result<void> check_value(const Address& a, double value);
// Writes width(a) words (registers; a bit as 0/1 in word 0). check_value first.
void encode(const Address& a, double value, uint16_t* words);
// The engineering value of width(a) words read from the slave.
double decode(const Address& a, const uint16_t* words);

// "hr:4:f32" (the canonical spelling parse_address takes back).
std::string to_string(const Address& a);
// "1.5", "513", "1": a value as `read` prints it.
std::string format_value(const Address& a, double value);

// Modbus exception code by name: 2 -> "illegal data address".
const char* exception_name(int code);
// "illegal data address (exception 2)".
std::string exception_text(int code);

}  // namespace rtplc::modbus
