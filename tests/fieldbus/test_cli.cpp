// `rtplc fieldbus plan` as a user runs it: the examples, their output and exit codes.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace {

struct CliRun {
  int rc = -1;
  std::string out;
};

// Runs the built binary with `args`, stdout and stderr together.
CliRun rtplc(const std::string& args) {
  const std::string cmd = std::string(RTPLC_BINARY_DIR) + "/rtplc " + args + " 2>&1";
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = pclose(p);
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string example(const char* name) {
  return std::string(RTPLC_SOURCE_DIR) + "/examples/" + name;
}

TEST(FieldbusCli, plans_the_generic_example) {
  const CliRun r = rtplc("fieldbus plan " + example("fieldbus.yaml"));
  EXPECT_EQ(r.rc, 0) << r.out;
  EXPECT_NE(r.out.find("FEASIBLE"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("= 4.1ms / 7 = 585.714us"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("L2            20ms*       0"), std::string::npos) << r.out;
}

TEST(FieldbusCli, json_carries_the_fields_scripts_need) {
  const CliRun r = rtplc("fieldbus plan " + example("fieldbus.yaml") + " --json");
  EXPECT_EQ(r.rc, 0) << r.out;
  for (const char* field :
       {"\"feasible\": true", "\"T1\": 0.005", "\"gamma\": 4", "\"periodic_part\": 0.0009",
        "\"Ln_max\": 0.000585714", "{\"name\": \"L2\", \"period\": 0.02, \"offset\": 0"}) {
    EXPECT_NE(r.out.find(field), std::string::npos) << field << "\n" << r.out;
  }
}

TEST(FieldbusCli, infeasible_design_exits_3_with_the_shortfall) {
  CliRun r = rtplc("fieldbus plan " + example("fieldbus-infeasible.yaml"));
  EXPECT_EQ(r.rc, 3) << r.out;
  EXPECT_NE(r.out.find("stability:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("exceeds T_1 = 2ms by 2.8ms"), std::string::npos) << r.out;
  r = rtplc("fieldbus plan " + example("fieldbus-infeasible.yaml") + " --json");
  EXPECT_EQ(r.rc, 3);
  EXPECT_NE(r.out.find("\"feasible\": false"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"shortfall\": 0.0028"), std::string::npos) << r.out;
}

TEST(FieldbusCli, can_example_is_feasible) {
  const CliRun r = rtplc("fieldbus plan " + example("fieldbus-can.yaml"));
  EXPECT_EQ(r.rc, 0) << r.out;
  EXPECT_NE(r.out.find("CAN 11-bit id at 500kbit/s"), std::string::npos) << r.out;
}

TEST(FieldbusCli, a_broken_file_exits_1_with_a_positioned_error) {
  const std::string path = ::testing::TempDir() + "/broken-plan.yaml";
  FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs(
      "link: {nodes: 10, server_overhead: 20us}\nperiodic: {packet: 100us}\n"
      "loops:\n  - {name: L1, perod: 5ms}\n",
      f);
  std::fclose(f);
  const CliRun r = rtplc("fieldbus plan " + path);
  EXPECT_EQ(r.rc, 1) << r.out;
  EXPECT_NE(r.out.find("broken-plan.yaml:4:16: error: unknown key 'perod' in a loop; did you "
                       "mean 'period'?"),
            std::string::npos)
      << r.out;
}

}  // namespace
