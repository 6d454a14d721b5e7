// The S7 address syntax of the command line and the value conversions
// (issue 4, item 4).
#include <gtest/gtest.h>

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
  uint8_t out[4] = {};
  encode_raw(DataType::kDInt, double_to_raw(DataType::kDInt, -5), out);
  EXPECT_EQ(out[0], 0xFF);
  EXPECT_EQ(out[3], 0xFB);
  EXPECT_EQ(double_to_raw(DataType::kByte, 300), 255u);  // clamped
  EXPECT_EQ(double_to_raw(DataType::kInt, -40000), 0x8000u);
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

}  // namespace
}  // namespace rtplc::s7
