// `rtplc can dump` (cli.cpp) as a user meets it without a bus: a config with
// errors is refused with its positions before anything is opened, a config
// without a can driver is a usage error, and a host without PF_CAN gets a
// clear failure, never a silent exit 0.
#include <gtest/gtest.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "common/exit_codes.h"
#include "io/drivers/can/cli.h"
#include "io/drivers/can/transport.h"
#include "tests/support/cli_app.h"

namespace rtplc::can {
namespace {

// Runs `rtplc ARGS...` in process; its exit code (0 when the callback returned).
int run(const std::vector<std::string>& args) {
  return test::run_cli([](CLI::App& app) { add_commands(app); }, args);
}

std::string write_config(const std::string& name, const std::string& text) {
  const std::string path = "/tmp/rtplc-can-cli-" + std::to_string(getpid()) + "-" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(CanCli, refuses_a_config_with_errors_before_opening_anything) {
  const std::string path = write_config(
      "bad.yaml",
      "tasks:\n  - {name: t, program: p.fbd}\ndrivers:\n  - kind: can\n    interface: vcan0\n"
      "    receive:\n      - id: 0x181\n        signals: [{channel: p0.d0.c0, byte: 7, length: 2}]\n");
  testing::internal::CaptureStderr();
  EXPECT_EQ(run({"can", "dump", "vcan0", "--config", path}), kExitFailure);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("bad.yaml:8:56: error: bytes 7..8 run past the 8 data bytes"), std::string::npos) << err;
  std::remove(path.c_str());
}

TEST(CanCli, says_when_the_config_has_no_can_driver) {
  const std::string path = write_config("nocan.yaml", "tasks:\n  - {name: t, program: p.fbd}\ndrivers:\n  - kind: sim\n");
  testing::internal::CaptureStderr();
  EXPECT_EQ(run({"can", "dump", "vcan0", "--config", path}), kExitUsage);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("has no driver of kind can"), std::string::npos) << err;
  std::remove(path.c_str());
}

TEST(CanCli, fails_clearly_without_pf_can) {
  if (socketcan_available().ok()) GTEST_SKIP() << "this kernel has PF_CAN (the VM test covers dump on a bus)";
  testing::internal::CaptureStderr();
  EXPECT_EQ(run({"can", "dump", "vcan0", "-n", "1"}), kExitFailure);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("rtplc can: this kernel offers no SocketCAN raw sockets"), std::string::npos) << err;
}

TEST(CanCli, needs_an_interface) {
  EXPECT_NE(run({"can", "dump"}), 0);
  EXPECT_NE(run({"can"}), 0);
}

}  // namespace
}  // namespace rtplc::can
