// The gpio driver's config: lines by offset and by name, defaults, claims on
// the DIO channels (dpi under device letter P), and every bad line refused
// with its line and column.
#include <gtest/gtest.h>

#include "config/config.h"
#include "config/driver_kinds.h"
#include "io/drivers/gpio/config.h"
#include "tests/support/driver_test.h"

namespace rtplc::gpio {
namespace {

config::LoadResult parse(const std::string& driver) { return test::parse_driver("gpio", "dio", driver); }
using test::first_error;

TEST(GpioConfig, reads_inputs_counters_outputs_and_defaults) {
  auto r = parse(
      "    chip: gpiochip0\n"
      "    inputs:\n"
      "      - {channel: p0.d0.c0, line: 3}\n"
      "      - {channel: p0.d0.c1, line: START_BTN, active_low: true, bias: pull-up, debounce: 5ms}\n"
      "    counters:\n"
      "      - {channel: p0.d0.c0, line: 5, chip: gpiochip1, edge: both, debounce: 100us}\n"
      "      - {channel: p0.d0.c1, line: 6}\n"
      "    outputs:\n"
      "      - {channel: p0.d0.c0, line: 7, safe: 1}\n");
  ASSERT_TRUE(r.ok()) << r.render();
  const GpioSettings& s = settings_of(r.config->drivers[0]);
  ASSERT_EQ(s.lines.size(), 5u);
  EXPECT_EQ(s.lines[0].role, Role::kInput);
  EXPECT_EQ(s.lines[0].offset, 3u);
  EXPECT_EQ(s.lines[0].chip, "gpiochip0");
  EXPECT_EQ(s.lines[0].bias, Bias::kAsIs);
  EXPECT_EQ(s.lines[0].debounce_ns, 0);
  EXPECT_EQ(s.lines[1].line_name, "START_BTN");
  EXPECT_TRUE(s.lines[1].active_low);
  EXPECT_EQ(s.lines[1].bias, Bias::kPullUp);
  EXPECT_EQ(s.lines[1].debounce_ns, 5000000);
  EXPECT_EQ(s.lines[2].role, Role::kCounter);
  EXPECT_EQ(s.lines[2].chip, "gpiochip1");
  EXPECT_EQ(s.lines[2].edge, Edge::kBoth);
  EXPECT_EQ(s.lines[2].debounce_ns, 100000);
  EXPECT_EQ(s.lines[3].edge, Edge::kRising);  // the default edge of a counter
  EXPECT_EQ(s.lines[4].role, Role::kOutput);
  EXPECT_EQ(s.lines[4].safe, 1);
}

TEST(GpioConfig, claims_ddi_dpi_and_ddo_channels_and_one_link_per_chip) {
  auto r = parse(
      "    chip: gpiochip0\n"
      "    inputs: [{channel: p0.d0.c0, line: 3}]\n"
      "    counters: [{channel: p0.d0.c0, line: 5, chip: gpiochip1}]\n"
      "    outputs: [{channel: p0.d0.c2, line: 7}]\n");
  ASSERT_TRUE(r.ok()) << r.render();
  const config::DriverKind* k = config::find_driver_kind("gpio");
  ASSERT_NE(k, nullptr);
  const config::DriverClaims c = k->claims(r.config->drivers[0]);
  ASSERT_EQ(c.provides.size(), 2u);
  EXPECT_EQ(c.provides[0].key, "in/DIO/p0.d0.c0");
  EXPECT_EQ(c.provides[1].key, "in/DIOP/p0.d0.c0");
  ASSERT_EQ(c.consumes.size(), 1u);
  EXPECT_EQ(c.consumes[0].key, "out/DIO/p0.d0.c2");
  EXPECT_EQ(c.links, 2u);
}

TEST(GpioConfig, refuses_bad_lines_with_their_position) {
  auto r = parse("    chip: gpiochip0\n    inputs: [{channel: p0.d0.c0, line: -3}]\n");
  EXPECT_NE(first_error(r).find("c.yaml:7:40: error: 'line' expects an offset (0..65535) or a line name, got '-3'"),
            std::string::npos)
      << r.render();
  r = parse("    chip: gpiochip0\n    inputs: [{channel: p0.d0.c0, line: 12345678}]\n");
  EXPECT_NE(first_error(r).find("7:40: error: 'line' expects an offset"), std::string::npos) << r.render();
  r = parse("    inputs: [{channel: p0.d0.c0, line: 3}]\n");
  EXPECT_NE(first_error(r).find("6:40: error: which chip?"), std::string::npos) << r.render();
  r = parse("    chip: gpio chip\n    inputs: [{channel: p0.d0.c0, line: 3}]\n");
  EXPECT_NE(first_error(r).find("6:11: error: 'chip' expects a chip"), std::string::npos) << r.render();
}

TEST(GpioConfig, refuses_a_line_used_twice_and_an_output_on_two_lines) {
  auto r = parse(
      "    chip: gpiochip0\n"
      "    inputs: [{channel: p0.d0.c0, line: 3}]\n"
      "    counters: [{channel: p0.d0.c0, line: 3}]\n");
  EXPECT_NE(first_error(r).find("8:42: error: line 3 of chip gpiochip0 is already used by the entry at line 7"),
            std::string::npos)
      << r.render();
  r = parse(
      "    chip: gpiochip0\n"
      "    outputs:\n"
      "      - {channel: p0.d0.c0, line: 3}\n"
      "      - {channel: p0.d0.c0, line: 4}\n");
  EXPECT_NE(first_error(r).find("9:9: error: output p0.d0.c0 drives two lines (first at line 8)"), std::string::npos)
      << r.render();
}

TEST(GpioConfig, refuses_keys_of_the_wrong_role) {
  auto r = parse("    chip: c\n    inputs: [{channel: p0.d0.c0, line: 3, edge: both}]\n");
  EXPECT_NE(first_error(r).find("'edge' applies to counters only"), std::string::npos) << r.render();
  r = parse("    chip: c\n    outputs: [{channel: p0.d0.c0, line: 3, bias: pull-up}]\n");
  EXPECT_NE(first_error(r).find("'bias' applies to inputs and counters only"), std::string::npos) << r.render();
  r = parse("    chip: c\n    outputs: [{channel: p0.d0.c0, line: 3, debounce: 1ms}]\n");
  EXPECT_NE(first_error(r).find("'debounce' applies to inputs and counters only"), std::string::npos) << r.render();
  r = parse("    chip: c\n    counters: [{channel: p0.d0.c0, line: 3, safe: 1}]\n");
  EXPECT_NE(first_error(r).find("'safe' applies to outputs only"), std::string::npos) << r.render();
  r = parse("    chip: c\n    outputs: [{channel: p0.d0.c0, line: 3, safe: 2}]\n");
  EXPECT_FALSE(r.ok());
  r = parse("    chip: c\n    counters: [{channel: p0.d0.c0, line: 3, edge: up}]\n");
  EXPECT_FALSE(r.ok());
}

TEST(GpioConfig, refuses_more_event_lines_than_one_thread_waits_on) {
  std::string counters = "    chip: gpiochip0\n    counters:\n";
  for (int i = 0; i <= 64; ++i) counters += "      - {channel: p0.d0.c" + std::to_string(i) + ", line: " + std::to_string(i) + "}\n";
  auto r = parse(counters);
  EXPECT_NE(first_error(r).find("72:36: error: a gpio driver follows the edges of at most 64 lines"),
            std::string::npos)
      << r.render();
}

TEST(GpioConfig, needs_some_lines) {
  auto r = parse("    chip: gpiochip0\n");
  EXPECT_NE(first_error(r).find("6:11: error: a gpio driver needs 'inputs', 'outputs' or 'counters'"),
            std::string::npos)
      << r.render();
}

TEST(GpioConfig, the_shipped_example_loads_with_its_program) {
  auto r = config::load_config(std::string(RTPLC_SOURCE_DIR) + "/examples/gpio.yaml");
  ASSERT_TRUE(r.ok()) << r.render();
  ASSERT_EQ(r.config->drivers.size(), 1u);
  const GpioSettings& s = settings_of(r.config->drivers[0]);
  ASSERT_EQ(s.lines.size(), 4u);
  EXPECT_EQ(s.lines[0].line_name, "BTN");
  EXPECT_EQ(s.lines[3].safe, 1);
}

}  // namespace
}  // namespace rtplc::gpio
