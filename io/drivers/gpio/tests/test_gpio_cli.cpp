// `rtplc gpio info|get|set` (cli.cpp) over the fake chips: the chip's lines
// listed, a level read, a line driven, and a config whose lines the chip does
// not have reported at file:line:col with a failing exit.
#include <gtest/gtest.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "common/exit_codes.h"
#include "io/drivers/gpio/cli.h"
#include "io/drivers/gpio/fake_chip.h"
#include "tests/support/cli_app.h"

namespace rtplc::gpio {
namespace {

int run(FakeChips& chips, const std::vector<std::string>& args) {
  return test::run_cli([&](CLI::App& app) { add_commands_with(app, chips.ops()); }, args);
}

struct Chips {
  FakeChips f;
  Chips() { f.add_chip("gpiochip0", "gpio-fake.0", 4, {"", "BTN", "LAMP"}); }
};

TEST(GpioCli, info_lists_the_lines_of_a_chip) {
  Chips c;
  testing::internal::CaptureStdout();
  EXPECT_EQ(run(c.f, {"gpio", "info", "gpiochip0"}), 0);
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("gpiochip0  [gpio-fake.0]  4 lines"), std::string::npos) << out;
  EXPECT_NE(out.find("line   1  BTN"), std::string::npos) << out;
}

TEST(GpioCli, get_reads_and_set_drives_by_offset_or_name) {
  Chips c;
  c.f.pull("gpiochip0", 1, 1, 0);
  testing::internal::CaptureStdout();
  EXPECT_EQ(run(c.f, {"gpio", "get", "gpiochip0", "BTN", "0"}), 0);
  EXPECT_EQ(run(c.f, {"gpio", "set", "gpiochip0", "LAMP=1"}), 0);
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("gpiochip0 line 1 = 1\ngpiochip0 line 0 = 0\n"), std::string::npos) << out;
  EXPECT_EQ(c.f.level("gpiochip0", 2), 1);
  EXPECT_FALSE(c.f.requested("gpiochip0", 2));
}

TEST(GpioCli, refuses_nonsense_lines_and_values) {
  Chips c;
  testing::internal::CaptureStderr();
  EXPECT_EQ(run(c.f, {"gpio", "get", "gpiochip0", "NOPE"}), kExitUsage);
  EXPECT_EQ(run(c.f, {"gpio", "get", "gpiochip0", "9"}), kExitUsage);
  EXPECT_EQ(run(c.f, {"gpio", "set", "gpiochip0", "2=on"}), kExitUsage);
  EXPECT_EQ(run(c.f, {"gpio", "get", "gpiochip5", "0"}), kExitFailure);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("gpiochip0 has no line named 'NOPE'"), std::string::npos) << err;
  EXPECT_NE(err.find("gpiochip0 has 4 lines (0..3), not line 9"), std::string::npos) << err;
  EXPECT_NE(err.find("'2=on': say LINE=0 or LINE=1"), std::string::npos) << err;
}

TEST(GpioCli, info_config_reports_bad_lines_at_their_position) {
  Chips c;
  const std::string path = "/tmp/rtplc-gpio-cli-" + std::to_string(getpid()) + ".yaml";
  std::ofstream(path) << "tasks:\n  - {name: t, program: p.fbd}\n"
                         "drivers:\n  - kind: gpio\n    name: dio\n    chip: gpiochip0\n"
                         "    inputs:\n      - {channel: p0.d0.c0, line: BTN}\n"
                         "      - {channel: p0.d0.c1, line: START}\n"
                         "    outputs:\n      - {channel: p0.d0.c0, line: 7}\n";
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(run(c.f, {"gpio", "info", "--config", path}), kExitFailure);
  const std::string err = testing::internal::GetCapturedStderr();
  const std::string out = testing::internal::GetCapturedStdout();
  std::remove(path.c_str());
  EXPECT_NE(out.find("dio.p0.d0.c0  input line 'BTN' = gpiochip0 line 1"), std::string::npos) << out;
  EXPECT_NE(err.find(path + ":9:35: error: chip gpiochip0 has no line named 'START'"), std::string::npos) << err;
  EXPECT_NE(err.find(path + ":11:35: error: chip gpiochip0 has 4 lines (0..3), not line 7"), std::string::npos) << err;
  EXPECT_NE(err.find("2 line(s) of"), std::string::npos) << err;
}

}  // namespace
}  // namespace rtplc::gpio
