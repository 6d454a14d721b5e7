// Time and bit-rate spellings, and the CAN / Modbus RTU frame times.
#include <gtest/gtest.h>

#include "fieldbus/link_timing.h"
#include "fieldbus/units.h"

namespace rtplc::fieldbus {
namespace {

TEST(FieldbusUnits, parses_the_time_spellings_of_the_plan_file) {
  EXPECT_EQ(parse_time("20us"), 20'000);
  EXPECT_EQ(parse_time("5ms"), 5'000'000);
  EXPECT_EQ(parse_time("0.1s"), 100'000'000);
  EXPECT_EQ(parse_time("1.5ms"), 1'500'000);
  EXPECT_EQ(parse_time("0.002"), 2'000'000);  // plain numbers are seconds
  EXPECT_EQ(parse_time("250ns"), 250);
  EXPECT_EQ(parse_time(" 3 ms "), 3'000'000);
}

TEST(FieldbusUnits, rejects_malformed_times) {
  for (const char* bad : {"", "ms", "-1ms", "5 m", "1e-3", "0.5ns", "1.2.3s", "2h", "7200s"}) {
    EXPECT_FALSE(parse_time(bad).has_value()) << bad;
  }
}

TEST(FieldbusUnits, parses_bit_rates) {
  EXPECT_EQ(parse_bit_rate("500kbit/s"), 500e3);
  EXPECT_EQ(parse_bit_rate("1Mbit/s"), 1e6);
  EXPECT_EQ(parse_bit_rate("19200"), 19200);
  EXPECT_EQ(parse_bit_rate("9.6kbit/s"), 9600);
  EXPECT_EQ(parse_bit_rate("125kbps"), 125e3);
  EXPECT_FALSE(parse_bit_rate("0").has_value());
  EXPECT_FALSE(parse_bit_rate("fast").has_value());
  EXPECT_FALSE(parse_bit_rate("500kB/s").has_value());
}

TEST(FieldbusUnits, formats_times_exactly) {
  EXPECT_EQ(format_time(585'714), "585.714us");
  EXPECT_EQ(format_time(5'000'000), "5ms");
  EXPECT_EQ(format_time(1'485'714), "1.485714ms");
  EXPECT_EQ(format_time(1'500), "1.5us");
  EXPECT_EQ(format_time(0), "0s");
  EXPECT_EQ(format_time(-2'800'000), "-2.8ms");
  EXPECT_EQ(format_time(12), "12ns");
}

TEST(FieldbusUnits, rounds_bit_times_up_to_the_next_nanosecond) {
  EXPECT_EQ(bits_time(1, 500e3), 2000);
  EXPECT_EQ(bits_time(11, 19200), 572917);  // 572916.67 ns
}

TEST(FieldbusLinkTiming, can_frames_count_every_possible_stuff_bit) {
  // 11-bit id: 47 + 8n bits and floor((34 + 8n - 1) / 4) stuff bits.
  EXPECT_EQ(can_frame_bits(FrameLayout::kCan11, 0), 47 + 8);
  EXPECT_EQ(can_frame_bits(FrameLayout::kCan11, 8), 111 + 24);
  EXPECT_EQ(can_frame_bits(FrameLayout::kCan11, 2), 63 + 12);
  // 29-bit id: 67 + 8n bits and floor((54 + 8n - 1) / 4).
  EXPECT_EQ(can_frame_bits(FrameLayout::kCan29, 0), 67 + 13);
  EXPECT_EQ(can_frame_bits(FrameLayout::kCan29, 8), 131 + 29);
  const LinkTiming can{FrameLayout::kCan11, 500e3};
  EXPECT_EQ(can.packet(8), 270'000);
  EXPECT_EQ(can.server_overhead(0), 110'000);
}

TEST(FieldbusLinkTiming, modbus_rtu_counts_characters_and_silent_intervals) {
  const LinkTiming rtu{FrameLayout::kModbusRtu, 19200};
  // 4 data bytes = 4 characters of 11 bits.
  EXPECT_EQ(rtu.packet(4), bits_time(44, 19200));
  // Request of 8 characters + 3.5 silent + empty reply of 5 + 3.5 = 20 characters.
  EXPECT_EQ(rtu.server_overhead(8), bits_time(220, 19200));
  EXPECT_EQ(rtu.describe(), "Modbus RTU at 19.2kbit/s");
}

}  // namespace
}  // namespace rtplc::fieldbus
