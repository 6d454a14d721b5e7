// HMI variables on a running runtime (docs/st.md, "HMI variables"): a
// Beremiz SVGHMI HMI_* variable of an ST program is a channel labelled with
// its path, marked for the web console and `monitor`: one the program never
// writes is an operator set-point (`rtplc set`), one it writes shows what the
// task computed, with the task's own quality; a swap keeps both channels.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/wait.h>

#include <string>

#include "sched/control.h"
#include "tests/support/eventually.h"
#include "tests/support/run_tool.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::eventually;
using rtplc::testing::RuntimeFixture;

std::string program(const char* gain) {
  return std::string("PROGRAM Main\nVAR\n  level : HMI_INT := 42;\n  on : HMI_BOOL;\n  shown : HMI_REAL;\n"
                     "  plain : INT;\nEND_VAR\n"
                     "  IF on THEN shown := level * ") + gain + "; ELSE shown := -1.0; END_IF;\n  plain := level;\nEND_PROGRAM\n";
}

const char* kConfig = "tasks:\n  - name: hmi\n    program: hmi.st\n    period: 10ms\n";

io::ChannelValue read_label(Runtime& rt, const std::string& label) {
  const int c = rt.image().find_channel(label);
  EXPECT_GE(c, 0) << label;
  return c < 0 ? io::ChannelValue{} : rt.image().read_channel(static_cast<uint32_t>(c));
}

const io::ChannelDesc& desc(Runtime& rt, const std::string& label) {
  return rt.image().channel(static_cast<uint32_t>(rt.image().find_channel(label)));
}

TEST(Hmi, hmi_variables_are_marked_channels_an_operator_sets_and_reads) {
  RuntimeFixture fx;
  fx.write("hmi.st", program("1.5"));
  std::unique_ptr<Runtime> rt = fx.start(kConfig);
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(eventually([&] { return read_label(*rt, "Main.shown").value == -1.0; }));
  EXPECT_EQ(read_label(*rt, "Main.shown").quality, Quality::kGood);
  EXPECT_EQ(rt->image().find_channel("Main.plain"), -1);  // not an HMI variable: no channel
  const io::ChannelDesc& level = desc(*rt, "Main.level");
  EXPECT_EQ(level.dir, static_cast<uint8_t>(io::ChannelDir::kSetpoint));
  EXPECT_EQ(level.hmi, 1);
  EXPECT_EQ(level.init, 42);
  EXPECT_EQ(desc(*rt, "Main.on").hmi, 1);
  EXPECT_EQ(desc(*rt, "Main.shown").dir, static_cast<uint8_t>(io::ChannelDir::kOutput));
  EXPECT_EQ(desc(*rt, "Main.shown").hmi, 1);
  const std::string shown_key = desc(*rt, "Main.shown").key;

  // The operator's set-points, through the one operator API.
  ASSERT_TRUE(rt->set_value("Main.on", 1).ok());
  ASSERT_TRUE(rt->set_value("Main.level", 10).ok());
  EXPECT_TRUE(eventually([&] { return read_label(*rt, "Main.shown").value == 15.0; }))
      << read_label(*rt, "Main.shown").value;

  // The monitor, as the web console reads it: marked, and good (no "unsent").
  const test::ToolRun mj = test::run_tool("monitor --json --name " + rt->name() + " --filter Main.");
  ASSERT_EQ(mj.status, 0) << mj.out;
  const nlohmann::json m = nlohmann::json::parse(mj.out, nullptr, false);
  ASSERT_TRUE(m.is_object() && m["channels"].is_array()) << mj.out;
  int marked = 0;
  for (const nlohmann::json& c : m["channels"]) {
    EXPECT_EQ(c.value("hmi", false), true) << c.dump();
    marked += c.value("hmi", false) ? 1 : 0;
    if (c["label"] == "Main.shown") {
      EXPECT_EQ(c["quality"], "good") << c.dump();
    }
  }
  EXPECT_EQ(marked, 3) << mj.out;
  const test::ToolRun mon = test::run_tool("monitor --once --name " + rt->name() + " --filter Main.shown");
  EXPECT_NE(mon.out.find("(HMI)"), std::string::npos) << mon.out;
  EXPECT_EQ(mon.out.find("unsent"), std::string::npos) << mon.out;

  // A swap keeps the channels (their addresses come from their paths).
  ASSERT_TRUE(rt->swap("hmi", program("2.0"), "hmi_v2.st").ok());
  EXPECT_TRUE(eventually([&] { return read_label(*rt, "Main.shown").value == 20.0; }));
  EXPECT_EQ(std::string(desc(*rt, "Main.shown").key), shown_key);
  rt->stop();
}

// A running task's program variables, a STRING as its text: `monitor
// --variables TASK` over the task's watch (docs/st.md, "Strings").
TEST(Hmi, monitor_shows_a_tasks_variables_and_strings_as_text) {
  RuntimeFixture fx;
  fx.write("s.st",
           "PROGRAM Main\nVAR\n  n : INT;\n  msg : STRING[20];\n  odd : STRING := 'a$FFb';\nEND_VAR\n"
           "  n := n + 1;\n  msg := CONCAT('cycle ', INT_TO_STRING(n MOD 1000));\nEND_PROGRAM\n");
  const std::string name = fx.unique_name(), sock = fx.dir() + "/s.sock";
  const std::string cfg = fx.write("s.yaml", "runtime:\n  name: " + name + "\n  socket: " + sock +
                                                 "\ntasks:\n  - {name: strs, program: s.st, period: 10ms}\n");
  const pid_t pid = rtplc::testing::launch_rtplc_run(cfg, sock);
  test::ToolRun mon;
  EXPECT_TRUE(eventually([&] {
    mon = test::run_tool("monitor --once --name " + name + " --variables strs");
    return mon.out.find("'cycle ") != std::string::npos;
  })) << mon.out;
  EXPECT_EQ(mon.status, 0) << mon.out;
  EXPECT_NE(mon.out.find("variables of task strs"), std::string::npos) << mon.out;
  EXPECT_NE(mon.out.find("Main.msg"), std::string::npos) << mon.out;
  EXPECT_NE(mon.out.find("'a\\xffb'"), std::string::npos) << mon.out;  // not UTF-8: escaped, the answer stays JSON
  EXPECT_EQ(mon.out.find("$"), std::string::npos) << mon.out;           // no temporaries
  const test::ToolRun bad = test::run_tool("monitor --once --name " + name + " --variables nope");
  EXPECT_NE(bad.out.find("variables of task nope: "), std::string::npos) << bad.out;
  (void)control_request(sock, "stop");
  waitpid(pid, nullptr, 0);
}

}  // namespace
}  // namespace rtplc::sched
