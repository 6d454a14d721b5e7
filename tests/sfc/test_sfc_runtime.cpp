// An SFC task in the real runtime (docs/sfc.md, "Running"): beside an FBD task,
// driven by a set-point, its steps visible as channels, hot-swapped with its
// active step and its timer kept by name.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>

#include "sched/jitter.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc {
namespace {

using testing::channel_value;
using testing::RuntimeFixture;

void sleep_s(double s) {
  std::this_thread::sleep_for(std::chrono::duration<double>(s));
}

// Waits up to 2 s for a channel to take a value (the tasks run on their own threads).
bool wait_for(sched::Runtime& rt, const std::string& label, double v) {
  for (int i = 0; i < 400; ++i) {
    if (channel_value(rt, label) == v) return true;
    sleep_s(0.005);
  }
  return false;
}

std::string chart(bool edited) {
  return std::string(
             "SFC seq STEPS d0\nstime(0.002)\n"
             "INPUT GO = dsp(d0, c5, 0, \"GO\")\n"
             "OUTPUT Q = ddo(p0, d1, c0, \"Q\")\nOUTPUT R = ddo(p0, d1, c1, \"R\")\n"
             "INITIAL STEP A\n  N Q\nEND_STEP\n"
             "STEP B\n  D R 60s\nEND_STEP\n") +
         (edited ? "STEP C\n  P Q\nEND_STEP\n"
                   "TRANSITION t1 FROM A TO B WHEN GO\nTRANSITION t2 FROM B TO C WHEN NOT GO\n"
                   "TRANSITION t3 FROM C TO A WHEN TRUE\n"
                 : "TRANSITION t1 FROM A TO B WHEN GO\nTRANSITION t2 FROM B TO A WHEN NOT GO\n");
}

const char* kFbd =
    "%%\nF1 = asp(d0, c0, 1, \"ONE\")\nF2 = intg(F1, 1)\ndao(F2, p0, d0, c0, \"RAMP\")\nEND\n";

const sched::CycleStats& stats_of(sched::Runtime& rt) {
  return *static_cast<const sched::CycleStats*>(rt.image().task_stats(0));
}

double state_of(const sched::LoadedProgram& p, const std::string& block) {
  const auto blocks = p.image.blocks();
  for (size_t i = 0; i < blocks.size(); ++i) {
    if (block == p.image.str(blocks[i].name)) return p.arena.state[p.image.code()[i].state];
  }
  ADD_FAILURE() << "no block " << block;
  return -1;
}

TEST(SfcRuntime, runs_beside_an_fbd_task_and_a_swap_keeps_its_active_step_and_timer) {
  RuntimeFixture fx;
  fx.write("seq.sfc", chart(false));
  fx.write("ramp.fbd", kFbd);
  auto rt = fx.start(
      "tasks:\n"
      "  - {name: ramp, program: ramp.fbd, period: 2ms}\n"
      "  - {name: seq, program: seq.sfc, period: 2ms}\n");
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(wait_for(*rt, "seq.A", 1));
  EXPECT_EQ(channel_value(*rt, "Q"), 1);
  EXPECT_EQ(channel_value(*rt, "seq.B"), 0);
  const std::string status = rt->status();
  EXPECT_NE(status.find("block errors, active steps: A\n"), std::string::npos) << status;
  const size_t ramp_line = status.find("task ramp:");
  ASSERT_NE(ramp_line, std::string::npos) << status;
  EXPECT_EQ(status.substr(ramp_line, status.find('\n', ramp_line) - ramp_line).find("active steps"),
            std::string::npos)
      << "an FBD task has no steps";

  ASSERT_TRUE(rt->set_value("GO", 1).ok());
  ASSERT_TRUE(wait_for(*rt, "seq.B", 1));
  EXPECT_EQ(channel_value(*rt, "seq.A"), 0);
  EXPECT_EQ(channel_value(*rt, "Q"), 0);
  sleep_s(0.05);  // the D timer of B counts

  auto r = rt->swap("seq", chart(true), "seq2.sfc");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NE(r->find("active steps kept: 1 (B)"), std::string::npos) << *r;
  EXPECT_EQ(channel_value(*rt, "seq.B"), 1) << "the active step survives the swap";
  EXPECT_EQ(channel_value(*rt, "seq.A"), 0) << "and the initial step is not re-entered";

  // The edited chart runs: B -> C (a pulse of Q) -> A.
  ASSERT_TRUE(rt->set_value("GO", 0).ok());
  ASSERT_TRUE(wait_for(*rt, "seq.A", 1));
  ASSERT_TRUE(rt->set_value("GO", 1).ok());
  ASSERT_TRUE(wait_for(*rt, "seq.B", 1));
  const double ramp = channel_value(*rt, "RAMP");
  EXPECT_GT(ramp, 0.0) << "the FBD task runs beside";
  rt->stop();
}

TEST(SfcRuntime, the_timer_of_the_active_step_is_carried_over) {
  RuntimeFixture fx;
  fx.write("seq.sfc", chart(false));
  auto rt = fx.start("tasks:\n  - {name: seq, program: seq.sfc, period: 2ms}\n");
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(rt->set_value("GO", 1).ok());
  ASSERT_TRUE(wait_for(*rt, "seq.B", 1));
  sleep_s(0.1);  // about 50 cycles in B
  const uint64_t before_swap = stats_of(*rt).cycles();
  ASSERT_TRUE(rt->swap("seq", chart(true), "seq2.sfc").ok());
  sleep_s(0.02);
  rt->stop();
  // Had the timer restarted at the swap, it could have counted at most the
  // cycles run since `before_swap`; it counted those plus B's earlier cycles.
  const double at_most_since_swap = static_cast<double>(stats_of(*rt).cycles() - before_swap);
  const double counted = state_of(rt->task(0).active(), "act.B.D.R");
  EXPECT_GT(counted, at_most_since_swap + 10) << "the timer went on from its count before the swap";
}

}  // namespace
}  // namespace rtplc
