// The codec: every length, both byte orders, signed and float, scale and
// offset, bit for bit; values that do not fit are refused without touching
// the frame; error frames decoded.
#include <gtest/gtest.h>
#include <linux/can/error.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "io/drivers/can/codec.h"

namespace rtplc::can {
namespace {

SignalLayout layout(uint8_t byte, uint8_t length, Encoding e = Encoding::kUnsigned, ByteOrder o = ByteOrder::kLittle) {
  SignalLayout s;
  s.byte = byte;
  s.length = length;
  s.encoding = e;
  s.order = o;
  return s;
}

TEST(Codec, reads_little_and_big_endian_integers_of_every_length) {
  const uint8_t d[8] = {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08};
  EXPECT_EQ(unpack(layout(0, 1), d), 0x01);
  EXPECT_EQ(unpack(layout(1, 2), d), 0x0302);
  EXPECT_EQ(unpack(layout(1, 2, Encoding::kUnsigned, ByteOrder::kBig), d), 0x0203);
  EXPECT_EQ(unpack(layout(0, 3), d), 0x030201);
  EXPECT_EQ(unpack(layout(4, 4, Encoding::kUnsigned, ByteOrder::kBig), d), 0x05060708);
  EXPECT_EQ(unpack(layout(2, 5), d), static_cast<double>(0x0706050403ull));
  EXPECT_EQ(unpack(layout(0, 7, Encoding::kUnsigned, ByteOrder::kBig), d), static_cast<double>(0x01020304050607ull));
  EXPECT_EQ(unpack(layout(0, 8, Encoding::kUnsigned, ByteOrder::kBig), d), static_cast<double>(0x0102030405060708ull));
}

TEST(Codec, sign_extends_twos_complement) {
  const uint8_t d[8] = {0xFF, 0xFE, 0x80, 0x00, 0x7F, 0, 0, 0};
  EXPECT_EQ(unpack(layout(0, 1, Encoding::kSigned), d), -1);
  EXPECT_EQ(unpack(layout(0, 2, Encoding::kSigned), d), static_cast<int16_t>(0xFEFF));
  EXPECT_EQ(unpack(layout(2, 2, Encoding::kSigned, ByteOrder::kBig), d), -32768);
  EXPECT_EQ(unpack(layout(3, 2, Encoding::kSigned), d), 0x7F00);
  const uint8_t all[8] = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};
  EXPECT_EQ(unpack(layout(0, 8, Encoding::kSigned), all), -1);
  EXPECT_EQ(unpack(layout(0, 3, Encoding::kSigned), all), -1);
}

TEST(Codec, reads_float32_and_float64) {
  uint8_t d[8] = {};
  const float f = 1.5f;
  std::memcpy(d, &f, 4);  // this host is little-endian
  EXPECT_EQ(unpack(layout(0, 4, Encoding::kFloat), d), 1.5);
  uint8_t b[8] = {0x3F, 0xC0, 0x00, 0x00};  // 1.5f big-endian
  EXPECT_EQ(unpack(layout(0, 4, Encoding::kFloat, ByteOrder::kBig), b), 1.5);
  const double x = -2.25;
  std::memcpy(d, &x, 8);
  EXPECT_EQ(unpack(layout(0, 8, Encoding::kFloat), d), -2.25);
}

TEST(Codec, applies_scale_and_offset_both_ways) {
  SignalLayout s = layout(0, 2, Encoding::kSigned);
  s.scale = 0.1;
  s.offset = -40;
  uint8_t d[8] = {};
  ASSERT_TRUE(pack(s, 25.3, d));  // raw = (25.3 + 40) / 0.1 = 653
  EXPECT_EQ(d[0], 0x8D);
  EXPECT_EQ(d[1], 0x02);
  EXPECT_NEAR(unpack(s, d), 25.3, 1e-9);
}

TEST(Codec, packs_only_its_own_bytes_in_either_order) {
  uint8_t d[8] = {0xAA, 0xAA, 0xAA, 0xAA, 0xAA, 0xAA, 0xAA, 0xAA};
  ASSERT_TRUE(pack(layout(2, 3, Encoding::kUnsigned, ByteOrder::kBig), 0x123456, d));
  const uint8_t want[8] = {0xAA, 0xAA, 0x12, 0x34, 0x56, 0xAA, 0xAA, 0xAA};
  EXPECT_EQ(std::memcmp(d, want, 8), 0);
  ASSERT_TRUE(pack(layout(5, 3), 0x123456, d));
  EXPECT_EQ(d[5], 0x56);
  EXPECT_EQ(d[7], 0x12);
  ASSERT_TRUE(pack(layout(0, 2, Encoding::kSigned), -2, d));
  EXPECT_EQ(d[0], 0xFE);
  EXPECT_EQ(d[1], 0xFF);
  ASSERT_TRUE(pack(layout(0, 8, Encoding::kSigned, ByteOrder::kBig), -1, d));
  for (uint8_t b : d) EXPECT_EQ(b, 0xFF);
}

TEST(Codec, round_trips_every_length_and_encoding) {
  for (uint8_t len = 1; len <= 8; ++len) {
    for (auto order : {ByteOrder::kLittle, ByteOrder::kBig}) {
      uint8_t d[8] = {};
      // The largest raw value a double holds exactly (2^56 - 1 and up do not).
      const double umax = len >= 7 ? 9007199254740992.0 : std::ldexp(1.0, 8 * len) - 1;
      ASSERT_TRUE(pack(layout(static_cast<uint8_t>(8 - len), len, Encoding::kUnsigned, order), umax, d));
      EXPECT_EQ(unpack(layout(static_cast<uint8_t>(8 - len), len, Encoding::kUnsigned, order), d), umax) << int{len};
      const double smin = -std::ldexp(1.0, 8 * len - 1);
      ASSERT_TRUE(pack(layout(0, len, Encoding::kSigned, order), smin, d));
      EXPECT_EQ(unpack(layout(0, len, Encoding::kSigned, order), d), smin) << int{len};
    }
  }
}

TEST(Codec, refuses_values_that_do_not_fit_and_leaves_the_frame) {
  uint8_t d[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  const uint8_t before[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  EXPECT_FALSE(pack(layout(0, 1), 256, d));
  EXPECT_FALSE(pack(layout(0, 1), -1, d));
  EXPECT_FALSE(pack(layout(0, 1, Encoding::kSigned), 128, d));
  EXPECT_FALSE(pack(layout(0, 1, Encoding::kSigned), -129, d));
  EXPECT_FALSE(pack(layout(0, 2), std::numeric_limits<double>::quiet_NaN(), d));
  EXPECT_FALSE(pack(layout(0, 4, Encoding::kFloat), 1e300, d));
  EXPECT_FALSE(pack(layout(0, 8), 1.9e19, d));
  EXPECT_EQ(std::memcmp(d, before, 8), 0);
  EXPECT_TRUE(pack(layout(0, 1), 255.4, d));  // rounds to 255
  EXPECT_EQ(d[0], 255);
  EXPECT_TRUE(pack(layout(0, 1, Encoding::kSigned), -128, d));
  EXPECT_EQ(d[0], 0x80);
}

TEST(Codec, decodes_bus_off_restart_and_controller_states) {
  Frame f;
  f.error = true;
  f.id = CAN_ERR_BUSOFF;
  EXPECT_TRUE(decode_error(f).bus_off);
  EXPECT_EQ(error_text(decode_error(f)), "bus-off");
  f.id = CAN_ERR_RESTARTED;
  EXPECT_TRUE(decode_error(f).restarted);
  f.id = CAN_ERR_CRTL | CAN_ERR_ACK;
  f.len = 8;
  f.data[1] = CAN_ERR_CRTL_TX_PASSIVE;
  const ErrorReport e = decode_error(f);
  EXPECT_TRUE(e.error_passive);
  EXPECT_TRUE(e.no_ack);
  EXPECT_FALSE(e.bus_off);
  EXPECT_EQ(error_text(e), "error-passive, no-ack");
  Frame data;
  data.id = CAN_ERR_BUSOFF;  // a data frame with that id is no error
  EXPECT_FALSE(decode_error(data).bus_off);
}

TEST(Codec, names_ids_and_frames_as_can_utils_write_them) {
  EXPECT_EQ(id_text(0x181, false), "181");
  EXPECT_EQ(id_text(0x18FF50E5, true), "18FF50E5x");
  Frame f;
  f.id = 0x201;
  f.len = 3;
  f.data[0] = 0x11;
  f.data[1] = 0xAB;
  EXPECT_EQ(frame_text(f), "201#11AB00");
}

}  // namespace
}  // namespace rtplc::can
