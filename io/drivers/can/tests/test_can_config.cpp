// The can driver's config: defaults, claims on the EPC channels, and every bad
// id, byte range and encoding refused with its line and column.
#include <gtest/gtest.h>

#include "config/config.h"
#include "config/driver_kinds.h"
#include "io/drivers/can/config.h"
#include "tests/support/driver_test.h"

namespace rtplc::can {
namespace {

config::LoadResult parse(const std::string& driver) { return test::parse_driver("can", "epc", driver); }
using test::first_error;

TEST(CanConfig, reads_frames_signals_and_defaults) {
  auto r = parse(
      "    interface: vcan0\n"
      "    receive:\n"
      "      - id: 0x181\n"
      "        timeout: 50ms\n"
      "        signals:\n"
      "          - {channel: p0.d1.c0, byte: 0, length: 2, type: signed, order: big, scale: 0.1, offset: -5}\n"
      "          - {channel: p0.d1.c1, byte: 2}\n"
      "      - id: 0x18FF50E5\n"
      "        signals: [{channel: p0.d2.c0, byte: 4, type: float}]\n"
      "    transmit:\n"
      "      - id: 513\n"
      "        period: 20ms\n"
      "        on_change: false\n"
      "        length: 4\n"
      "        signals: [{channel: p0.d1.c0, byte: 0, length: 2}]\n");
  ASSERT_TRUE(r.ok()) << r.render();
  const CanSettings& s = settings_of(r.config->drivers[0]);
  EXPECT_EQ(s.interface, "vcan0");
  EXPECT_TRUE(s.error_frames);
  ASSERT_EQ(s.receive.size(), 2u);
  EXPECT_EQ(s.receive[0].id, 0x181u);
  EXPECT_FALSE(s.receive[0].extended);
  EXPECT_DOUBLE_EQ(s.receive[0].timeout_s, 0.05);
  EXPECT_EQ(s.receive[0].length, 3);  // the signals' end: a shorter frame is refused
  const SignalLayout& a = s.receive[0].signals[0].layout;
  EXPECT_EQ(a.encoding, Encoding::kSigned);
  EXPECT_EQ(a.order, ByteOrder::kBig);
  EXPECT_EQ(a.length, 2);
  EXPECT_DOUBLE_EQ(a.scale, 0.1);
  EXPECT_DOUBLE_EQ(a.offset, -5);
  EXPECT_EQ(s.receive[0].signals[1].layout.length, 1);
  EXPECT_TRUE(s.receive[1].extended);  // beyond 11 bits
  EXPECT_EQ(s.receive[1].signals[0].layout.length, 4);
  EXPECT_DOUBLE_EQ(s.receive[1].timeout_s, 0.5);
  ASSERT_EQ(s.transmit.size(), 1u);
  EXPECT_EQ(s.transmit[0].id, 513u);
  EXPECT_DOUBLE_EQ(s.transmit[0].period_s, 0.02);
  EXPECT_FALSE(s.transmit[0].on_change);
  EXPECT_EQ(s.transmit[0].length, 4);

  const config::DriverKind* k = config::find_driver_kind("can");
  ASSERT_NE(k, nullptr);
  const config::DriverClaims c = k->claims(r.config->drivers[0]);
  ASSERT_EQ(c.provides.size(), 3u);
  EXPECT_EQ(c.provides[0].key, "in/EPC/p0.d1.c0");
  EXPECT_EQ(c.provides[2].key, "in/EPC/p0.d2.c0");
  ASSERT_EQ(c.consumes.size(), 1u);
  EXPECT_EQ(c.consumes[0].key, "out/EPC/p0.d1.c0");
  EXPECT_EQ(c.links, 1u);
}

TEST(CanConfig, refuses_bad_ids_with_their_position) {
  auto r = parse("    interface: vcan0\n    receive:\n      - id: 0x800\n        extended: false\n"
                 "        signals: [{channel: p0.d0.c0, byte: 0}]\n");
  EXPECT_FALSE(r.ok());
  EXPECT_NE(first_error(r).find("c.yaml:8:13: error: CAN id 0x800 does not fit 11 bits"), std::string::npos)
      << r.render();
  r = parse("    interface: vcan0\n    receive:\n      - id: 0x20000000\n        signals: [{channel: p0.d0.c0, byte: 0}]\n");
  EXPECT_NE(first_error(r).find("8:13: error: CAN id 0x20000000 is beyond 29 bits"), std::string::npos) << r.render();
  r = parse("    interface: vcan0\n    receive:\n      - id: 12g\n        signals: [{channel: p0.d0.c0, byte: 0}]\n");
  EXPECT_NE(first_error(r).find("8:13: error: 'id' expects a CAN identifier"), std::string::npos) << r.render();
  r = parse("    interface: vcan0\n    receive:\n      - id: 0x10\n        signals: [{channel: p0.d0.c0, byte: 0}]\n"
            "      - id: 16\n        signals: [{channel: p0.d0.c1, byte: 0}]\n");
  EXPECT_NE(first_error(r).find("10:13: error: CAN id 0x10 is listed twice (first at line 8)"), std::string::npos)
      << r.render();
}

TEST(CanConfig, refuses_signals_outside_the_frame_or_overlapping) {
  auto r = parse("    interface: vcan0\n    receive:\n      - id: 0x10\n"
                 "        signals: [{channel: p0.d0.c0, byte: 6, length: 4}]\n");
  EXPECT_NE(first_error(r).find("9:56: error: bytes 6..9 run past the 8 data bytes"), std::string::npos)
      << r.render();
  r = parse("    interface: vcan0\n    receive:\n      - id: 0x10\n"
            "        signals: [{channel: p0.d0.c0, byte: 8}]\n");
  EXPECT_NE(first_error(r).find("9:45: error: 'byte' must be"), std::string::npos) << r.render();
  r = parse("    interface: vcan0\n    receive:\n      - id: 0x10\n"
            "        signals: [{channel: p0.d0.c0, byte: 0, type: float, length: 2}]\n");
  EXPECT_NE(first_error(r).find("error: a float is 4 bytes (float32) or 8 (float64), got 2"), std::string::npos)
      << r.render();
  r = parse("    interface: vcan0\n    transmit:\n      - id: 0x10\n        signals:\n"
            "          - {channel: p0.d0.c0, byte: 0, length: 2}\n          - {channel: p0.d0.c1, byte: 1}\n");
  EXPECT_NE(first_error(r).find("11:13: error: bytes 1..1 overlap the signal of p0.d0.c0 (line 10)"),
            std::string::npos)
      << r.render();
  r = parse("    interface: vcan0\n    receive:\n      - id: 0x10\n"
            "        signals: [{channel: p0.d0.c0, byte: 0, scale: 0}]\n");
  EXPECT_NE(first_error(r).find("9:55: error: 'scale' must not be 0"), std::string::npos) << r.render();
  r = parse("    interface: vcan0\n    transmit:\n      - id: 0x10\n        length: 2\n"
            "        signals: [{channel: p0.d0.c0, byte: 1, length: 2}]\n");
  EXPECT_NE(first_error(r).find("9:17: error: the signals need 3 data bytes, the frame's length is 2"),
            std::string::npos)
      << r.render();
}

TEST(CanConfig, refuses_keys_of_the_other_direction_and_double_channels) {
  auto r = parse("    interface: vcan0\n    receive:\n      - id: 0x10\n        period: 10ms\n"
                 "        signals: [{channel: p0.d0.c0, byte: 0}]\n");
  EXPECT_NE(first_error(r).find("9:17: error: 'period' applies to transmit frames only"), std::string::npos)
      << r.render();
  r = parse("    interface: vcan0\n    transmit:\n      - id: 0x10\n        timeout: 10ms\n"
            "        signals: [{channel: p0.d0.c0, byte: 0}]\n");
  EXPECT_NE(first_error(r).find("'timeout' applies to receive frames only"), std::string::npos) << r.render();
  r = parse("    interface: vcan0\n    transmit:\n      - id: 0x10\n        signals: [{channel: p0.d0.c0, byte: 0}]\n"
            "      - id: 0x11\n        signals: [{channel: p0.d0.c0, byte: 0}]\n");
  EXPECT_NE(first_error(r).find("11:29: error: output p0.d0.c0 is sent in two frames (first at line 9)"), std::string::npos)
      << r.render();
  r = parse("    interface: vcan0\n");
  EXPECT_NE(first_error(r).find("a can driver needs a 'receive' or a 'transmit' list"), std::string::npos)
      << r.render();
  r = parse("    interface: bad/name\n    transmit:\n      - id: 0x10\n        signals: [{channel: p0.d0.c0, byte: 0}]\n");
  EXPECT_NE(first_error(r).find("'interface' expects a network interface name"), std::string::npos) << r.render();
}

TEST(CanConfig, parses_ids_in_hex_and_decimal) {
  EXPECT_EQ(parse_id("0x181"), 0x181u);
  EXPECT_EQ(parse_id("0X7ff"), 0x7FFu);
  EXPECT_EQ(parse_id("385"), 385u);
  EXPECT_FALSE(parse_id("0x"));
  EXPECT_FALSE(parse_id("-1"));
  EXPECT_FALSE(parse_id("18 1"));
  EXPECT_FALSE(parse_id(""));
}

}  // namespace
}  // namespace rtplc::can
