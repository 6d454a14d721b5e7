// Modbus item addresses, value encoding and range checks (address.h).
#include <gtest/gtest.h>

#include "io/drivers/modbus/address.h"

namespace rtplc::modbus {
namespace {

TEST(ModbusAddress, parses_every_table_and_type) {
  auto a = parse_address("hr:4:f32");
  ASSERT_TRUE(a.ok()) << a.error();
  EXPECT_EQ(a->table, Table::kHoldingRegister);
  EXPECT_EQ(a->address, 4);
  EXPECT_EQ(a->type, ItemType::kF32);
  EXPECT_FALSE(a->swapped);
  EXPECT_EQ(width(*a), 2);
  EXPECT_EQ(parse_address("coil:5")->table, Table::kCoil);
  EXPECT_EQ(parse_address("di:3")->type, ItemType::kBit);
  EXPECT_EQ(parse_address("ir:7:i16")->type, ItemType::kI16);
  EXPECT_EQ(parse_address("hr:0")->type, ItemType::kU16);
  EXPECT_TRUE(parse_address("hr:10:u32:swapped")->swapped);
  EXPECT_EQ(to_string(*parse_address("hr:10:i32:swapped")), "hr:10:i32:swapped");
  EXPECT_EQ(to_string(*parse_address("hr:3:u16")), "hr:3");
}

TEST(ModbusAddress, refuses_bad_addresses_with_the_reason) {
  EXPECT_NE(parse_address("xx:1").error().find("unknown table 'xx'"), std::string::npos);
  EXPECT_NE(parse_address("hr").error().find("missing address"), std::string::npos);
  EXPECT_NE(parse_address("hr:65536").error().find("0..65535"), std::string::npos);
  EXPECT_NE(parse_address("hr:-1").error().find("0..65535"), std::string::npos);
  EXPECT_NE(parse_address("coil:1:u16").error().find("takes no type"), std::string::npos);
  EXPECT_NE(parse_address("hr:1:f64").error().find("unknown type"), std::string::npos);
  EXPECT_NE(parse_address("hr:1:u16:swapped").error().find("two-register"), std::string::npos);
  EXPECT_NE(parse_address("hr:65535:f32").error().find("address + 1"), std::string::npos);
  EXPECT_FALSE(parse_address("hr:1:f32:swapped:x").ok());
}

TEST(ModbusAddress, refuses_values_out_of_range_before_sending) {
  EXPECT_TRUE(parse_assignment("hr:20=513").ok());
  EXPECT_TRUE(parse_assignment("coil:21=1").ok());
  EXPECT_EQ(parse_assignment("hr:22:f32=1.5")->value, 1.5);
  EXPECT_NE(parse_assignment("hr:20=65536").error().find("out of range for u16 (0..65535)"), std::string::npos);
  EXPECT_NE(parse_assignment("hr:20:i16=-32769").error().find("out of range for i16"), std::string::npos);
  EXPECT_NE(parse_assignment("coil:1=2").error().find("out of range"), std::string::npos);
  EXPECT_NE(parse_assignment("hr:1=1.5").error().find("whole number"), std::string::npos);
  EXPECT_NE(parse_assignment("di:1=1").error().find("read-only"), std::string::npos);
  EXPECT_NE(parse_assignment("hr:1=abc").error().find("not a number"), std::string::npos);
  EXPECT_NE(parse_assignment("hr:1").error().find("ADDRESS=VALUE"), std::string::npos);
  EXPECT_FALSE(fits(*parse_address("hr:0:f32"), 1e39));
  EXPECT_TRUE(fits(*parse_address("hr:0:i32"), -2147483648.0));
}

TEST(ModbusAddress, encodes_high_word_first_unless_swapped) {
  uint16_t w[2] = {};
  encode(*parse_address("hr:0:u32"), 0x12345678, w);
  EXPECT_EQ(w[0], 0x1234);
  EXPECT_EQ(w[1], 0x5678);
  encode(*parse_address("hr:0:u32:swapped"), 0x12345678, w);
  EXPECT_EQ(w[0], 0x5678);
  EXPECT_EQ(w[1], 0x1234);
  encode(*parse_address("hr:0:f32"), 1.5, w);
  EXPECT_EQ(w[0], 0x3FC0);  // 1.5f = 0x3FC00000
  EXPECT_EQ(w[1], 0x0000);
  encode(*parse_address("hr:0:i16"), -2, w);
  EXPECT_EQ(w[0], 0xFFFE);
}

TEST(ModbusAddress, decode_inverts_encode_for_every_type) {
  for (const char* spec : {"hr:0:u16", "hr:0:i16", "hr:0:u32", "hr:0:i32", "hr:0:f32", "hr:0:i32:swapped",
                           "hr:0:f32:swapped", "coil:0"}) {
    const Address a = *parse_address(spec);
    for (double v : {0.0, 1.0, -1.0, 100.0, 65535.0, -32768.0, 2.5}) {
      if (!fits(a, v)) continue;
      uint16_t w[2] = {};
      encode(a, v, w);
      EXPECT_EQ(decode(a, w), v) << spec << " " << v;
    }
  }
}

TEST(ModbusAddress, names_exceptions) {
  EXPECT_EQ(exception_text(2), "illegal data address (exception 2)");
  EXPECT_STREQ(exception_name(11), "gateway target device failed to respond");
  EXPECT_STREQ(exception_name(99), "unknown exception");
}

}  // namespace
}  // namespace rtplc::modbus
