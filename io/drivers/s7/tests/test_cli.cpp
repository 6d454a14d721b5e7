// `rtplc s7 write` against the fake PLC (cli.cpp): values are checked against
// their item's type before anything is sent, and a refusal exits with the usage
// code (issue: `s7 write DB1.DBW4:INT=32768` wrote -32768 and exited 0).
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "common/exit_codes.h"
#include "io/drivers/s7/cli.h"
#include "io/drivers/s7/fake_plc.h"
#include "tests/support/cli_app.h"

namespace rtplc::s7 {
namespace {

class S7Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    auto ep = fake_.add_endpoint({"127.0.0.1", 0, {}});
    ASSERT_TRUE(ep.ok()) << ep.error();
    ASSERT_TRUE(fake_.start().ok());
    const uint8_t marker[] = {0x12, 0x34, 0x56, 0x78, 0x9A};
    fake_.write_memory(0, Area::kDB, 1, 4, marker);
  }
  void TearDown() override { fake_.stop(); }

  // Runs `rtplc s7 write 127.0.0.1 --port P ASSIGNMENTS...`; its exit code.
  int write(const std::vector<std::string>& assignments) {
    std::vector<std::string> args = {"s7", "write", "127.0.0.1", "--port", std::to_string(fake_.port(0))};
    args.insert(args.end(), assignments.begin(), assignments.end());
    return test::run_cli([](CLI::App& app) { add_commands(app); }, args);
  }
  Bytes memory() const { return fake_.read_memory(0, Area::kDB, 1, 4, 5); }

  FakePlc fake_;
};

TEST_F(S7Cli, write_refuses_out_of_range_values_before_connecting) {
  const Bytes before = memory();
  for (const char* bad :
       {"DB1.DBW4:INT=32768", "DB1.DBD4:DINT=2147483648", "DB1.DBB4:CHAR=200", "DB1.DBB4=256",
        "DB1.DBW4=-1", "DB1.DBW4:INT=1.5", "DB1.DBD4:REAL=1e39", "DB1.DBD4:REAL=nan"}) {
    EXPECT_EQ(write({bad}), kExitUsage) << bad;
  }
  // One bad value among good ones: nothing at all is written.
  EXPECT_EQ(write({"DB1.DBB9=1", "DB1.DBW4:INT=32768"}), kExitUsage);
  EXPECT_EQ(memory(), before);
  EXPECT_EQ(fake_.read_memory(0, Area::kDB, 1, 9, 1), Bytes{0});
  EXPECT_EQ(fake_.stats(0).accepted, 0u);  // never even connected
}

TEST_F(S7Cli, write_sends_values_that_fit_and_chars_as_characters) {
  EXPECT_EQ(write({"DB1.DBW4:INT=-32768"}), 0);
  EXPECT_EQ(fake_.read_memory(0, Area::kDB, 1, 4, 2), (Bytes{0x80, 0x00}));
  EXPECT_EQ(write({"DB1.DBB6:CHAR=A", "DB1.DBB7:CHAR=0x0D"}), 0);
  EXPECT_EQ(fake_.read_memory(0, Area::kDB, 1, 6, 2), (Bytes{0x41, 0x0D}));
}

}  // namespace
}  // namespace rtplc::s7
