// A runaway loop under `rtplc run`'s runtime: the loop budget cuts the cycle
// short, the task stops into its safe outputs (never publishing what the cut
// cycle wrote), the log names the loop's file:line:col, the other task and
// the runtime go on, and a swap restarts the task.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "lang/compiler.h"
#include "lang/program_checks.h"
#include "tests/support/eventually.h"
#include "tests/support/flow_program.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::Builder;
using rtplc::testing::eventually;
using rtplc::testing::RuntimeFixture;

// x := 0; REPEAT x := x + 1; UNTIL x >= 5 AND Spin = 0; Count := x.
// Count is 5 while the set-point Spin is 0; Spin = 1 never ends the loop.
std::string spin_image(uint32_t* loop_line) {
  Builder b;
  const uint32_t spin = b.setpoint(0, 0, "Spin");
  const uint32_t x = b.var("x");
  const uint32_t zero = b.k("zero", 0), one = b.k("one", 1), five = b.k("five", 5);
  b.set(x, zero);
  const uint32_t head = b.add("add", "x1", {x, one});
  b.set(x, head);
  const uint32_t more = b.add("lt", "more", {x, five});
  const uint32_t spinning = b.add("gt", "spinning", {spin, zero});
  const uint32_t again = b.add("or", "again", {more, spinning});
  const uint32_t leave = b.branch("jz", {again}, 0);
  const uint32_t back = b.branch("loop", {}, head);
  *loop_line = back + 1;  // the builder's positions: block k at line k + 1
  b.aim(leave, b.next());
  b.out(x, 0, "Count");
  DiagnosticList d;
  lang::check_flat_program(b.p, d);
  EXPECT_FALSE(d.has_errors());
  lang::CompileOptions opt;
  opt.period_override = 0.01;
  Result<TaskImage> img = lang::build_image(b.p, opt, 0);
  EXPECT_TRUE(img);
  if (!img) return {};
  const auto bytes = img->bytes();
  return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

// The runtime's log line about the runaway loop, once the control thread has
// logged it (empty if it never does).
std::string runaway_line(Runtime& rt) {
  std::string said;
  (void)eventually([&] {
    rt.tick([&](bool, const std::string& l) {
      if (l.find("RUNAWAY LOOP") != std::string::npos) said = l;
    });
    return !said.empty();
  });
  return said;
}

const char* kCalm = "%%\nF1 = asp(d0, c1, 2, \"Gain\")\nF2 = intg(F1, 1)\ndao(F2, p0, d0, c1, \"Calm\")\nEND\n";

TEST(RunawayLoop, stops_its_task_into_the_safe_outputs_and_names_the_loop) {
  RuntimeFixture fx;
  uint32_t loop_line = 0;
  const std::string bytes = spin_image(&loop_line);
  const std::string img = fx.write("spin.img", bytes);
  fx.write("calm.fbd", kCalm);
  auto rt = fx.start(
      "tasks:\n"
      "  - {name: spin, program: spin.img, period: 10ms, loop_budget: 5000, safe_outputs: {Count: -3}}\n"
      "  - {name: calm, program: calm.fbd, period: 10ms}\n"
      "drivers:\n  - kind: sim\n");
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(eventually([&] { return rtplc::testing::channel_value(*rt, "Count") == 5.0; }));
  EXPECT_EQ(static_cast<io::TaskState>(rt->image().task_info(0).state.load()), io::TaskState::kRunning);

  ASSERT_TRUE(rt->set_value("Spin", 1));
  ASSERT_TRUE(eventually([&] {
    return rt->image().task_info(0).state.load() == static_cast<uint8_t>(io::TaskState::kStoppedLoop);
  }));
  // The cut cycle's partial outputs were never published: the safe value is.
  EXPECT_EQ(rtplc::testing::channel_value(*rt, "Count"), -3.0);

  const std::string said = runaway_line(*rt);
  ASSERT_FALSE(said.empty()) << "no RUNAWAY LOOP line was logged";
  EXPECT_NE(said.find("task spin STOPPED"), std::string::npos) << said;
  EXPECT_NE(said.find(img + ":" + std::to_string(loop_line) + ":1"), std::string::npos) << said;
  EXPECT_NE(said.find("loop_budget of 5000"), std::string::npos) << said;
  EXPECT_NE(rt->status().find("STOPPED (runaway loop)"), std::string::npos) << rt->status();

  // The other task goes on.
  const double calm = rtplc::testing::channel_value(*rt, "Calm");
  EXPECT_TRUE(eventually([&] { return rtplc::testing::channel_value(*rt, "Calm") > calm + 0.05; }));
  // Stopped means stopped: the output stays safe.
  EXPECT_EQ(rtplc::testing::channel_value(*rt, "Count"), -3.0);

  // New code restarts it (here: the same code with Spin back at 0).
  ASSERT_TRUE(rt->set_value("Spin", 0));
  auto swapped = rt->swap("spin", bytes, img);
  ASSERT_TRUE(swapped) << swapped.error();
  ASSERT_TRUE(eventually([&] { return rtplc::testing::channel_value(*rt, "Count") == 5.0; }));
  EXPECT_EQ(static_cast<io::TaskState>(rt->image().task_info(0).state.load()), io::TaskState::kRunning);
  rt->stop();
}

// The same under an ST program as a user writes it: the operator's set-point
// `spin` keeps the WHILE going; the fixed program swapped in keeps `total`,
// the count of completed cycles, by its instance path.
const char* kSpinSt = R"(PROGRAM Main
  VAR
    spin AT %MX0.0 : BOOL;
    count AT %QW0 : INT;
    x : INT;
    total : DINT;
  END_VAR
  x := 0;
  WHILE x < 5 OR spin DO
    x := x + 1;
  END_WHILE;
  total := total + 1;
  count := x;
END_PROGRAM
)";
const char* kFixedSt = R"(PROGRAM Main
  VAR
    spin AT %MX0.0 : BOOL;
    count AT %QW0 : INT;
    x : INT;
    total : DINT;
  END_VAR
  x := 0;
  WHILE x < 5 OR (spin AND x < 1000) DO
    x := x + 1;
  END_WHILE;
  total := total + 1;
  count := x;
END_PROGRAM
)";

// `native`: the task's `native` key (blocks/native.h): the same loop, budget,
// fault and swap as native code.
void st_while_that_never_ends(bool native) {
  RuntimeFixture fx;
  const std::string file = fx.write("spin.st", kSpinSt);
  auto rt = fx.start(std::string("tasks:\n"
                                 "  - {name: spin, program: spin.st, period: 10ms, safe_outputs: {count: -1}") +
                     (native ? ", native: true" : "") + "}\n"
                     "drivers:\n  - kind: sim\n");
  ASSERT_NE(rt, nullptr);
  EXPECT_EQ(rt->status().find("native code") != std::string::npos, native) << rt->status();
  ASSERT_TRUE(eventually([&] { return rtplc::testing::channel_value(*rt, "count") == 5.0; }));
  ASSERT_TRUE(rt->set_value("spin", 1));
  ASSERT_TRUE(eventually([&] {
    return rt->image().task_info(0).state.load() == static_cast<uint8_t>(io::TaskState::kStoppedLoop);
  }));
  EXPECT_EQ(rtplc::testing::channel_value(*rt, "count"), -1.0);
  const std::string said = runaway_line(*rt);
  ASSERT_FALSE(said.empty()) << "no RUNAWAY LOOP line was logged";
  EXPECT_NE(said.find("the loop at " + file + ":9:3"), std::string::npos) << said;  // the WHILE

  auto swapped = rt->swap("spin", kFixedSt, fx.write("fixed.st", kFixedSt));
  ASSERT_TRUE(swapped) << swapped.error();
  // The completed-cycle count goes on from where the stopped program left it.
  const size_t kept = swapped->find("kept state:");
  ASSERT_NE(kept, std::string::npos) << *swapped;
  EXPECT_NE(swapped->find("Main.total", kept), std::string::npos) << *swapped;
  EXPECT_LT(swapped->find("Main.total", kept), swapped->find("reset:")) << *swapped;
  ASSERT_TRUE(eventually([&] { return rtplc::testing::channel_value(*rt, "count") == 1000.0; }));
  EXPECT_EQ(static_cast<io::TaskState>(rt->image().task_info(0).state.load()), io::TaskState::kRunning);
  // The swapped-in program runs as native code too, swap after swap.
  EXPECT_EQ(rt->status().find("native code") != std::string::npos, native) << rt->status();
  for (int k = 0; k < 2; ++k) {
    auto again = rt->swap("spin", kFixedSt, fx.write("fixed.st", kFixedSt));
    ASSERT_TRUE(again) << "swap " << k + 2 << ": " << again.error();
  }
  EXPECT_TRUE(eventually([&] { return rtplc::testing::channel_value(*rt, "count") == 1000.0; }));
  rt->stop();
}

TEST(RunawayLoop, an_st_while_that_never_ends_stops_its_task_and_a_swap_restarts_it_keeping_state) {
  st_while_that_never_ends(false);
}

TEST(RunawayLoop, the_same_as_native_code) { st_while_that_never_ends(true); }

}  // namespace
}  // namespace rtplc::sched
