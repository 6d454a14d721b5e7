// The S7 address syntax of the command line and the value conversions
// (issue 4, item 4).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "io/drivers/s7/address.h"

namespace rtplc::s7 {
namespace {

ItemAddress must_parse(const std::string& s) {
  auto a = parse_address(s);
  EXPECT_TRUE(a.ok()) << s << ": " << a.error();
  return a.ok() ? *a : ItemAddress{};
}

TEST(Address, parses_every_form_of_the_issue) {
  struct Case {
    const char* text;
    Area area;
    uint16_t db;
    uint32_t start;
    uint8_t bit;
    DataType type;
  };
  const Case cases[] = {
      {"DB1.DBX0.0", Area::kDB, 1, 0, 0, DataType::kBool},   {"DB1.DBB2", Area::kDB, 1, 2, 0, DataType::kByte},
      {"DB1.DBW4", Area::kDB, 1, 4, 0, DataType::kWord},     {"DB1.DBD8", Area::kDB, 1, 8, 0, DataType::kDWord},
      {"DB1.DBD8:REAL", Area::kDB, 1, 8, 0, DataType::kReal}, {"MB0", Area::kFlags, 0, 0, 0, DataType::kByte},
      {"MW2", Area::kFlags, 0, 2, 0, DataType::kWord},        {"M0.1", Area::kFlags, 0, 0, 1, DataType::kBool},
      {"IB0", Area::kInputs, 0, 0, 0, DataType::kByte},       {"IW0", Area::kInputs, 0, 0, 0, DataType::kWord},
      {"I0.0", Area::kInputs, 0, 0, 0, DataType::kBool},      {"QB0", Area::kOutputs, 0, 0, 0, DataType::kByte},
      {"Q0.1", Area::kOutputs, 0, 0, 1, DataType::kBool},     {"C0", Area::kCounters, 0, 0, 0, DataType::kCounter},
      {"T0", Area::kTimers, 0, 0, 0, DataType::kTimer},       {"db12.dbw100:int", Area::kDB, 12, 100, 0, DataType::kInt},
      {"EB3", Area::kInputs, 0, 3, 0, DataType::kByte},       {"A1.7", Area::kOutputs, 0, 1, 7, DataType::kBool},
      {"Z5", Area::kCounters, 0, 5, 0, DataType::kCounter},   {"MD4:DINT", Area::kFlags, 0, 4, 0, DataType::kDInt},
  };
  for (const Case& c : cases) {
    const ItemAddress a = must_parse(c.text);
    EXPECT_EQ(a.area, c.area) << c.text;
    EXPECT_EQ(a.db, c.db) << c.text;
    EXPECT_EQ(a.start, c.start) << c.text;
    EXPECT_EQ(a.bit, c.bit) << c.text;
    EXPECT_EQ(a.type, c.type) << c.text;
  }
}

TEST(Address, formats_back_to_what_it_parses) {
  for (const char* s : {"DB1.DBX0.0", "DB1.DBB2", "DB1.DBW4", "DB1.DBD8", "DB1.DBD8:REAL", "MB0", "MW2", "M0.1", "IB0",
                        "IW0", "I0.0", "QB0", "Q0.1", "C0", "T0", "DB3.DBW6:INT", "MD4:DINT", "QB2:CHAR"}) {
    EXPECT_EQ(format_address(must_parse(s)), s);
  }
}

TEST(Address, explains_what_was_expected_where) {
  struct Case {
    const char* text;
    const char* hint;
  };
  const Case cases[] = {
      {"DB1.DBQ4", "X, B, W or D"},   {"DB1.DBX0", "bit number"},    {"DB1.DBX0.8", "larger than 7"},
      {"DB0.DBW0", "start at 1"},     {"MW", "byte offset"},        {"XW2", "an area"},
      {"DB1.DBW4:REAL", "does not fit"}, {"DB1.DBD4:FLOAT", "unknown type"}, {"", "empty"},
      {"MW2x", "end of the address"}, {"DB70000.DBW0", "larger than 65535"}, {"DB1.DBW0:", "type after"},
  };
  for (const Case& c : cases) {
    auto a = parse_address(c.text);
    ASSERT_FALSE(a.ok()) << c.text;
    EXPECT_NE(a.error().find(c.hint), std::string::npos) << c.text << " -> " << a.error();
  }
  auto a = parse_address("DB1.DBQ4");
  EXPECT_NE(a.error().find("column 7"), std::string::npos) << a.error();
}

TEST(Address, builds_request_items_with_bit_addresses) {
  const VarSpec w = var_spec_for(must_parse("DB1.DBW4"));
  EXPECT_EQ(w.ts, TransportSize::kByte);
  EXPECT_EQ(w.count, 2);
  EXPECT_EQ(w.address, 32u);
  const VarSpec b = var_spec_for(must_parse("M3.5"));
  EXPECT_EQ(b.ts, TransportSize::kBit);
  EXPECT_EQ(b.address, 29u);
  const VarSpec c = var_spec_for(must_parse("C7"));
  EXPECT_EQ(c.ts, TransportSize::kCounter);
  EXPECT_EQ(c.address, 7u);
}

TEST(Address, converts_values_of_every_type) {
  const uint8_t bytes[] = {0xFF, 0xFE, 0x00, 0x00};
  EXPECT_EQ(raw_to_double(DataType::kInt, decode_raw(DataType::kInt, 0, bytes)), -2.0);
  EXPECT_EQ(raw_to_double(DataType::kWord, decode_raw(DataType::kWord, 0, bytes)), 65534.0);
  EXPECT_EQ(decode_raw(DataType::kBool, 1, bytes), 1u);
  const uint8_t real[] = {0x40, 0x49, 0x0F, 0xDB};
  EXPECT_FLOAT_EQ(static_cast<float>(raw_to_double(DataType::kReal, decode_raw(DataType::kReal, 0, real))), 3.14159274f);
  uint64_t raw = 0;
  ASSERT_TRUE(value_to_raw(DataType::kDInt, -5, raw));
  uint8_t out[4] = {};
  encode_raw(DataType::kDInt, raw, out);
  EXPECT_EQ(out[0], 0xFF);
  EXPECT_EQ(out[3], 0xFB);
  const uint8_t sint[] = {0xC8};
  EXPECT_EQ(raw_to_double(DataType::kSInt, decode_raw(DataType::kSInt, 0, sint)), -56.0);
  EXPECT_EQ(raw_to_double(DataType::kChar, decode_raw(DataType::kChar, 0, sint)), 200.0);  // a code, not signed
}

// A task's output written to an item: rounded to the type, never clamped or
// wrapped (40000 to an INT used to arrive as 32767).
TEST(Address, refuses_task_values_outside_the_type_instead_of_clamping) {
  uint64_t raw = 7;
  EXPECT_FALSE(value_to_raw(DataType::kInt, 40000, raw));
  EXPECT_FALSE(value_to_raw(DataType::kInt, -32769, raw));
  EXPECT_FALSE(value_to_raw(DataType::kByte, 300, raw));
  EXPECT_FALSE(value_to_raw(DataType::kByte, -1, raw));
  EXPECT_FALSE(value_to_raw(DataType::kWord, 65536, raw));
  EXPECT_FALSE(value_to_raw(DataType::kDWord, 4294967296.0, raw));
  EXPECT_FALSE(value_to_raw(DataType::kDInt, 2147483648.0, raw));
  EXPECT_FALSE(value_to_raw(DataType::kSInt, 128, raw));
  EXPECT_FALSE(value_to_raw(DataType::kReal, 1e39, raw));
  EXPECT_FALSE(value_to_raw(DataType::kReal, std::numeric_limits<double>::infinity(), raw));
  EXPECT_FALSE(value_to_raw(DataType::kReal, std::nan(""), raw));
  EXPECT_FALSE(value_to_raw(DataType::kInt, std::nan(""), raw));
  EXPECT_FALSE(value_to_raw(DataType::kBool, std::nan(""), raw));
  EXPECT_EQ(raw, 7u);  // untouched by every refusal
  ASSERT_TRUE(value_to_raw(DataType::kInt, 32767.4, raw));
  EXPECT_EQ(raw, 0x7FFFu);
  ASSERT_TRUE(value_to_raw(DataType::kInt, -32768, raw));
  EXPECT_EQ(raw, 0x8000u);
  ASSERT_TRUE(value_to_raw(DataType::kDWord, 4294967295.0, raw));
  EXPECT_EQ(raw, 0xFFFFFFFFu);
  ASSERT_TRUE(value_to_raw(DataType::kBool, 5, raw));
  EXPECT_EQ(raw, 1u);
  ASSERT_TRUE(value_to_raw(DataType::kReal, 3.4028235e38, raw));  // the range as printed
  EXPECT_EQ(raw, 0x7F7FFFFFu);
  ASSERT_TRUE(value_to_raw(DataType::kReal, -2.5, raw));
  EXPECT_EQ(raw, 0xC0200000u);
}

TEST(Address, parses_and_formats_command_line_values) {
  EXPECT_EQ(*parse_value(DataType::kBool, "true"), 1u);
  EXPECT_EQ(*parse_value(DataType::kBool, "0"), 0u);
  EXPECT_EQ(*parse_value(DataType::kInt, "-2"), 0xFFFEu);
  EXPECT_EQ(*parse_value(DataType::kWord, "0x1F"), 0x1Fu);
  EXPECT_EQ(format_value(DataType::kReal, *parse_value(DataType::kReal, "3.25")), "3.25");
  EXPECT_EQ(format_value(DataType::kInt, 0xFFFE), "-2");
  EXPECT_EQ(format_value(DataType::kBool, 1), "true");
  EXPECT_FALSE(parse_value(DataType::kByte, "256").ok());
  EXPECT_FALSE(parse_value(DataType::kBool, "yes").ok());
  EXPECT_FALSE(parse_value(DataType::kReal, "1.2.3").ok());
  EXPECT_FALSE(parse_value(DataType::kWord, "").ok());
}

std::string error_of(const char* address, const char* text) {
  const ItemAddress a = must_parse(address);
  auto v = encode_value(a, text);
  EXPECT_FALSE(v.ok()) << address << "=" << text << " was accepted as " << (v.ok() ? *v : 0);
  return v.ok() ? std::string() : v.error();
}

uint64_t raw_of(const char* address, const char* text) {
  auto v = encode_value(must_parse(address), text);
  EXPECT_TRUE(v.ok()) << address << "=" << text << ": " << v.error();
  return v.ok() ? *v : ~uint64_t{0};
}

// `rtplc s7 write DB1.DBW4:INT=32768` wrote -32768: every type's range is checked.
TEST(Address, refuses_command_line_values_outside_their_types_range) {
  EXPECT_EQ(error_of("DB1.DBW4:INT", "32768"), "DB1.DBW4:INT: 32768 is out of range for INT (-32768..32767)");
  EXPECT_EQ(error_of("DB1.DBW4:INT", "-32769"), "DB1.DBW4:INT: -32769 is out of range for INT (-32768..32767)");
  EXPECT_EQ(error_of("MD4:DINT", "2147483648"),
            "MD4:DINT: 2147483648 is out of range for DINT (-2147483648..2147483647)");
  EXPECT_EQ(error_of("MD4:DINT", "-2147483649"),
            "MD4:DINT: -2147483649 is out of range for DINT (-2147483648..2147483647)");
  EXPECT_EQ(error_of("MB0", "256"), "MB0: 256 is out of range for BYTE (0..255)");
  EXPECT_EQ(error_of("MB0", "-1"), "MB0: -1 is out of range for BYTE (0..255)");
  EXPECT_EQ(error_of("MB0:SINT", "128"), "MB0:SINT: 128 is out of range for SINT (-128..127)");
  EXPECT_EQ(error_of("MW2", "65536"), "MW2: 65536 is out of range for WORD (0..65535)");
  EXPECT_EQ(error_of("MW2", "-1"), "MW2: -1 is out of range for WORD (0..65535)");
  EXPECT_EQ(error_of("MD4", "4294967296"), "MD4: 4294967296 is out of range for DWORD (0..4294967295)");
  EXPECT_EQ(error_of("MD4", "-1"), "MD4: -1 is out of range for DWORD (0..4294967295)");
  EXPECT_EQ(error_of("C0", "65536"), "C0: 65536 is out of range for COUNTER (0..65535)");
  EXPECT_EQ(error_of("T0", "-1"), "T0: -1 is out of range for TIMER (0..65535)");
  // Hex is a number, not a bit pattern; huge numbers do not overflow into range.
  EXPECT_EQ(error_of("DB1.DBW4:INT", "0xFFFF"), "DB1.DBW4:INT: 0xFFFF is out of range for INT (-32768..32767)");
  EXPECT_EQ(error_of("MB0", "18446744073709551617"),
            "MB0: 18446744073709551617 is out of range for BYTE (0..255)");
  EXPECT_EQ(error_of("MD4:DINT", "0x100000000"),
            "MD4:DINT: 0x100000000 is out of range for DINT (-2147483648..2147483647)");
  // Integer types take whole numbers only.
  EXPECT_EQ(error_of("DB1.DBW4:INT", "12.5"), "DB1.DBW4:INT: 12.5 is not a whole number; INT takes whole numbers "
                                               "-32768..32767");
  EXPECT_NE(error_of("MW2", "1e3").find("not a whole number"), std::string::npos);
  EXPECT_NE(error_of("MW2", "--5").find("is not a WORD value"), std::string::npos);
  EXPECT_NE(error_of("MW2", "5x").find("is not a WORD value"), std::string::npos);
  EXPECT_EQ(error_of("M0.1", "2"), "M0.1: '2' is not a BOOL value (use 1/0, true/false, on/off)");
  // REAL: finite, within float range.
  EXPECT_EQ(error_of("DB1.DBD8:REAL", "1e39"),
            "DB1.DBD8:REAL: 1e39 is out of range for REAL (-3.4028235e+38..3.4028235e+38)");
  EXPECT_NE(error_of("DB1.DBD8:REAL", "1e400").find("out of range for REAL"), std::string::npos);
  EXPECT_NE(error_of("DB1.DBD8:REAL", "nan").find("not a finite number"), std::string::npos);
  EXPECT_NE(error_of("DB1.DBD8:REAL", "-inf").find("not a finite number"), std::string::npos);

  // The edges themselves are accepted.
  EXPECT_EQ(raw_of("DB1.DBW4:INT", "32767"), 0x7FFFu);
  EXPECT_EQ(raw_of("DB1.DBW4:INT", "-32768"), 0x8000u);
  EXPECT_EQ(raw_of("DB1.DBW4:INT", "-0x8000"), 0x8000u);
  EXPECT_EQ(raw_of("MD4:DINT", "-2147483648"), 0x80000000u);
  EXPECT_EQ(raw_of("MD4:DINT", "+2147483647"), 0x7FFFFFFFu);
  EXPECT_EQ(raw_of("MD4", "4294967295"), 0xFFFFFFFFu);
  EXPECT_EQ(raw_of("MB0", "255"), 0xFFu);
  EXPECT_EQ(raw_of("MB0:SINT", "-128"), 0x80u);
  EXPECT_EQ(raw_of("MW2", "0xFFFF"), 0xFFFFu);
  EXPECT_EQ(raw_of("DB1.DBD8:REAL", "3.4028235e38"), 0x7F7FFFFFu);
  EXPECT_EQ(raw_of("DB1.DBD8:REAL", "-1.5"), 0xBFC00000u);
}

// `:CHAR` takes a character: MB0:CHAR=A. A lone digit is that digit; a code
// goes in hex. CHAR 200 used to be written as SINT -56.
TEST(Address, char_takes_one_character_or_a_hex_code) {
  EXPECT_EQ(raw_of("MB0:CHAR", "A"), 0x41u);
  EXPECT_EQ(raw_of("MB0:CHAR", "7"), 0x37u);
  EXPECT_EQ(raw_of("MB0:CHAR", " "), 0x20u);
  EXPECT_EQ(raw_of("MB0:CHAR", "0x0D"), 0x0Du);
  EXPECT_EQ(raw_of("MB0:CHAR", "0xC8"), 0xC8u);
  EXPECT_EQ(error_of("MB0:CHAR", "AB"), "MB0:CHAR: 'AB' is not one character; a CHAR takes one character "
                                        "(MB0:CHAR=A) or its code in hex (MB0:CHAR=0x41)");
  EXPECT_EQ(error_of("MB0:CHAR", "200"), "MB0:CHAR: '200' is not one character; a CHAR takes one character "
                                         "(MB0:CHAR=A) or its code in hex (MB0:CHAR=0x41): for the code 200 "
                                         "write 0xC8");
  EXPECT_EQ(error_of("MB0:CHAR", "0x100"),
            "MB0:CHAR: 0x100 is out of range for CHAR (one character, or a code 0x00..0xFF)");
  EXPECT_NE(error_of("MB0:CHAR", "").find("empty"), std::string::npos);
  EXPECT_NE(error_of("MB0:CHAR", "\xC3\xA9").find("not one character"), std::string::npos);  // UTF-8 e-acute
  // Read back in the same syntax.
  EXPECT_EQ(format_value(DataType::kChar, 0x41), "A");
  EXPECT_EQ(format_value(DataType::kChar, 0x20), "0x20");
  EXPECT_EQ(format_value(DataType::kChar, 0xC8), "0xC8");
  EXPECT_EQ(format_value(DataType::kSInt, 0xC8), "-56");
  // CHAR and SINT are two types now.
  EXPECT_EQ(must_parse("MB0:CHAR").type, DataType::kChar);
  EXPECT_EQ(must_parse("MB0:SINT").type, DataType::kSInt);
  EXPECT_EQ(format_address(must_parse("mb0:sint")), "MB0:SINT");
}

}  // namespace
}  // namespace rtplc::s7
