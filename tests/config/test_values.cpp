// The value syntaxes of the runtime configuration (config/values.h): durations,
// channel addresses, names, labels and the strict number readers.
#include <gtest/gtest.h>

#include "config/values.h"

namespace rtplc::config {
namespace {

TEST(Duration, reads_every_unit_and_plain_seconds) {
  EXPECT_EQ(parse_duration_s("10ms"), 0.01);
  EXPECT_EQ(parse_duration_s("250us"), 0.00025);
  EXPECT_EQ(parse_duration_s("0.5s"), 0.5);
  EXPECT_EQ(parse_duration_s("2"), 2.0);
  EXPECT_EQ(parse_duration_s("0.1"), 0.1);
  EXPECT_EQ(parse_duration_s("500000ns"), 0.0005);
  EXPECT_EQ(parse_duration_s("1e-3"), 0.001);
  EXPECT_EQ(parse_duration_s("1e-3s"), 0.001);
  EXPECT_EQ(parse_duration_s(" 10 ms "), 0.01);
  EXPECT_EQ(parse_duration_s("0"), 0.0);
}

TEST(Duration, gives_the_double_nearest_to_what_was_written) {
  // 10 * 1e-3 would be one ulp away from 0.01; periods are compared exactly.
  EXPECT_EQ(*parse_duration_s("10ms"), 0.01);
  EXPECT_EQ(*parse_duration_s("3ms"), 0.003);
  EXPECT_EQ(*parse_duration_s("7us"), 7e-6);
}

TEST(Duration, refuses_malformed_negative_and_non_finite_text) {
  for (const char* bad : {"", "ms", "10 m s", "10min", "10MS", "-1ms", "-5", "fast", "1e400", "inf",
                          "nan", "10ms5", "0x10", "1,5ms", "10 sec", "e5"}) {
    EXPECT_FALSE(parse_duration_s(bad).has_value()) << bad;
  }
}

TEST(Duration, formats_with_the_largest_unit_below_the_value) {
  EXPECT_EQ(format_duration(0.01), "10ms");
  EXPECT_EQ(format_duration(0.00025), "250us");
  EXPECT_EQ(format_duration(10e-6), "10us");
  EXPECT_EQ(format_duration(2), "2s");
  EXPECT_EQ(format_duration(3600), "3600s");
  EXPECT_EQ(format_duration(0.0105), "10.5ms");
  EXPECT_EQ(format_duration(5e-9), "5ns");
  EXPECT_EQ(format_duration(0), "0s");
}

TEST(Duration, format_and_parse_round_trip) {
  for (double s : {1e-5, 0.001, 0.0025, 0.01, 0.1, 0.5, 1.0, 42.0, 3600.0}) {
    EXPECT_EQ(parse_duration_s(format_duration(s)), s) << s;
  }
}

TEST(Channel, reads_the_fbd_address_shape) {
  auto a = parse_channel("p0.d1.c12");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->p, 0);
  EXPECT_EQ(a->d, 1);
  EXPECT_EQ(a->c, 12);
  auto b = parse_channel("p255.d255.c65535");
  ASSERT_TRUE(b);
  EXPECT_EQ(b->p, 255);
  EXPECT_EQ(b->c, 65535);
}

TEST(Channel, spells_leading_zeros_canonically) {
  auto a = parse_channel("p00.d01.c007");
  ASSERT_TRUE(a);
  EXPECT_EQ(to_string(*a), "p0.d1.c7");
}

TEST(Channel, refuses_other_shapes_and_out_of_range_parts) {
  for (const char* bad : {"", "p0.d0", "p0.d0.c0.x", "P0.D0.C0", "p256.d0.c0", "p0.d256.c0",
                          "p0.d0.c65536", "p-1.d0.c0", "p.d0.c0", "d0.p0.c0", "p0 .d0.c0",
                          "p0.d0.c999999", "p+1.d0.c0", "p0.d0.c0 "}) {
    EXPECT_FALSE(parse_channel(bad).has_value()) << bad;
  }
}

TEST(Names, allow_letters_digits_underscore_and_dash_up_to_31) {
  EXPECT_TRUE(is_valid_name("loop1"));
  EXPECT_TRUE(is_valid_name("fast-plant_2"));
  EXPECT_TRUE(is_valid_name(std::string(31, 'a')));
  EXPECT_FALSE(is_valid_name(std::string(32, 'a')));
  EXPECT_FALSE(is_valid_name(""));
  EXPECT_FALSE(is_valid_name("a.b"));
  EXPECT_FALSE(is_valid_name("a b"));
  EXPECT_FALSE(is_valid_name("a/b"));
}

TEST(Labels, also_allow_dots_as_the_fbd_language_does) {
  EXPECT_TRUE(is_valid_label("FT_101.PV"));
  EXPECT_FALSE(is_valid_label("FT 101"));
  EXPECT_FALSE(is_valid_label(std::string(32, 'x')));
}

TEST(Numbers, integers_are_whole_decimal_text) {
  EXPECT_EQ(parse_integer("40"), 40);
  EXPECT_EQ(parse_integer("-3"), -3);
  EXPECT_EQ(parse_integer("+7"), 7);
  EXPECT_FALSE(parse_integer("4.0"));
  EXPECT_FALSE(parse_integer("0x10"));
  EXPECT_FALSE(parse_integer("99999999999999999999"));
  EXPECT_FALSE(parse_integer(""));
  EXPECT_FALSE(parse_integer("+"));
}

TEST(Numbers, reals_are_finite_and_whole_text) {
  EXPECT_EQ(parse_real("1.5"), 1.5);
  EXPECT_EQ(parse_real(".5"), 0.5);
  EXPECT_EQ(parse_real("-2e3"), -2000.0);
  EXPECT_FALSE(parse_real("inf"));
  EXPECT_FALSE(parse_real(".inf"));
  EXPECT_FALSE(parse_real("nan"));
  EXPECT_FALSE(parse_real("1e999"));
  EXPECT_FALSE(parse_real("1.5x"));
  EXPECT_FALSE(parse_real("true"));
}

}  // namespace
}  // namespace rtplc::config
