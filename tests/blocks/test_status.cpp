// The status lane (blocks/status.h) through the real compiler and executor:
// an output computed from a bad input is bad, from a stale one uncertain; a
// selector carries the status of the branch it took; a `good`-guarded
// fallback yields a good output while the fallback is good; a block that
// erred holds an uncertain value; a delayed reference reads last cycle's status.
#include <gtest/gtest.h>
#include <fstream>
#include <sstream>

#include "blocks/status.h"
#include "tests/support/fbd_harness.h"

namespace rtplc {
namespace {

using testing::FbdHarness;

class Lane_ {
 public:
  explicit Lane_(const std::string& body) : Lane_(FbdHarness(body)) {}
  explicit Lane_(FbdHarness&& h) : h_(std::move(h)) {
    if (!h_.ok()) return;
    lane_.resize_for(h_.image());
    for (const Binding& b : h_.image().bindings()) {
      if (b.dir == BindingDir::kQuality) lane_.in[b.io_index] = 0;
    }
    set_all(Lane::kGood);
  }
  bool ok() const { return h_.ok(); }
  void set_all(Lane s) {
    for (const Binding& b : h_.image().bindings()) {
      if (b.dir == BindingDir::kInput || b.dir == BindingDir::kSetpoint) lane_.set_in(b.io_index, static_cast<uint8_t>(s));
    }
  }
  void status(std::string_view label, Lane s) {
    for (const Binding& b : h_.image().bindings()) {
      if ((b.dir == BindingDir::kInput || b.dir == BindingDir::kSetpoint) && label == h_.image().str(b.label)) {
        lane_.set_in(b.io_index, static_cast<uint8_t>(s));
        // The `good` block of the same channel sees what the task would load.
        for (const Binding& q : h_.image().bindings()) {
          if (q.dir == BindingDir::kQuality && binding_key(q) == binding_key(b)) {
            h_.arena().io_in[q.io_index] = s == Lane::kGood ? 1.0 : 0.0;
          }
        }
        return;
      }
    }
    ADD_FAILURE() << "no input " << label;
  }
  void set(std::string_view label, double v) { h_.set(label, v); }
  // One cycle as the task runs it: values, then the lane when it needs a pass.
  void step() {
    h_.step();
    if (lane_.needs_pass(h_.arena().total_errors)) {
      ++passes_;
      propagate_status(h_.image(), h_.arena(), lane_);
    }
  }
  Lane out(std::string_view label) const {
    for (const Binding& b : h_.image().bindings()) {
      if (b.dir == BindingDir::kOutput && label == h_.image().str(b.label)) return static_cast<Lane>(lane_.out[b.io_index]);
    }
    ADD_FAILURE() << "no output " << label;
    return Lane::kBad;
  }
  double value(std::string_view label) const { return h_.out(label); }
  int passes() const { return passes_; }

 private:
  FbdHarness h_;
  StatusLane lane_;
  int passes_ = 0;
};

// ProcVal -> error -> PI -> ManiVal, the seed loop.
const char* kLoop =
    "F1 = dai(p0, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 50, \"Setpoint\")\n"
    "F3 = sub(F2, F1, 1)\nF4 = epi(F3, 4, 3)\n"
    "dao(F4, p0, d0, c0, \"ManiVal\")\ndao(F2, p0, d0, c1, \"SpOut\")\n";

TEST(StatusLane, an_output_computed_from_a_bad_input_is_bad) {
  Lane_ l(kLoop);
  ASSERT_TRUE(l.ok());
  l.step();
  EXPECT_EQ(l.out("ManiVal"), Lane::kGood);
  l.status("ProcVal", Lane::kBad);
  l.step();
  EXPECT_EQ(l.out("ManiVal"), Lane::kBad);
  EXPECT_EQ(l.out("SpOut"), Lane::kGood) << "a value that does not depend on ProcVal stays good";
  l.status("ProcVal", Lane::kUncertain);
  l.step();
  EXPECT_EQ(l.out("ManiVal"), Lane::kUncertain);
  l.status("ProcVal", Lane::kGood);
  l.step();
  EXPECT_EQ(l.out("ManiVal"), Lane::kGood) << "no memory of a bad past in the PI's state";
}

TEST(StatusLane, nothing_is_good_before_the_inputs_are_read) {
  FbdHarness h(kLoop);
  ASSERT_TRUE(h.ok());
  StatusLane lane(h.image());
  h.step();
  propagate_status(h.image(), h.arena(), lane);
  for (uint8_t s : lane.out) EXPECT_EQ(s, static_cast<uint8_t>(Lane::kBad));
}

TEST(StatusLane, a_good_guarded_fallback_is_good_while_the_fallback_is) {
  Lane_ l("F1 = dai(p0, d0, c0, \"Level\")\nD2 = good(F1)\nF3 = asp(d0, c0, -5, \"Fallback\")\n"
          "F4 = amux(F3, F1, D2)\ndao(F4, p0, d0, c9, \"Safe\")\nddo(D2, p0, d0, c8, \"LevelOk\")\n"
          "F5 = sub(F1, F3, 1)\ndao(F5, p0, d0, c7, \"Raw\")\n");
  ASSERT_TRUE(l.ok());
  l.set("Level", 2.5);
  l.step();
  EXPECT_EQ(l.out("Safe"), Lane::kGood);
  l.status("Level", Lane::kBad);
  l.step();
  EXPECT_EQ(l.value("Safe"), -5);
  EXPECT_EQ(l.out("Safe"), Lane::kGood) << "the branch taken is the good fallback";
  EXPECT_EQ(l.out("LevelOk"), Lane::kGood) << "good(x) is known even when x is not";
  EXPECT_EQ(l.out("Raw"), Lane::kBad);
  l.status("Fallback", Lane::kBad);
  l.step();
  EXPECT_EQ(l.out("Safe"), Lane::kBad) << "a bad fallback is bad";
}

TEST(StatusLane, a_selector_carries_the_status_of_the_branch_it_took) {
  Lane_ l("F1 = asp(d0, c0, 1, \"A\")\nF2 = asp(d0, c1, 2, \"B\")\nD3 = dsp(d0, c2, 0, \"Sel\")\n"
          "F4 = amux(F1, F2, D3)\ndao(F4, p0, d0, c0, \"Y\")\n");
  ASSERT_TRUE(l.ok());
  l.status("B", Lane::kBad);
  l.step();
  EXPECT_EQ(l.value("Y"), 1);
  EXPECT_EQ(l.out("Y"), Lane::kGood);
  l.set("Sel", 1);
  l.step();
  EXPECT_EQ(l.value("Y"), 2);
  EXPECT_EQ(l.out("Y"), Lane::kBad);
  l.status("B", Lane::kGood);
  l.status("Sel", Lane::kUncertain);
  l.step();
  EXPECT_EQ(l.out("Y"), Lane::kUncertain) << "an uncertain selector makes its choice uncertain";
}

TEST(StatusLane, a_good_input_that_decides_an_and_or_an_or_makes_it_good) {
  // examples/drive.fbd: Enable = and(Ready, good(Speed), Run). With the drive
  // silent Ready is stale, but good(Speed) is a good 0: Enable is a good 0,
  // which a drive must be sent, not a held 1.
  Lane_ l("D1 = ddi(p0, d0, c0, \"Ready\")\nF2 = dai(p0, d0, c1, \"Speed\")\nD3 = good(F2)\n"
          "D4 = ddi(p0, d0, c2, \"Run\")\nD5 = and(D1, D3, D4)\nddo(D5, p0, d0, c0, \"Enable\")\n"
          "D6 = or(D1, D4)\nddo(D6, p0, d0, c1, \"Any\")\n");
  ASSERT_TRUE(l.ok());
  l.set("Ready", 1);
  l.set("Run", 1);
  l.status("Speed", Lane::kGood);
  l.step();
  EXPECT_EQ(l.value("Enable"), 1);
  EXPECT_EQ(l.out("Enable"), Lane::kGood);
  l.status("Ready", Lane::kUncertain);
  l.status("Speed", Lane::kUncertain);
  l.step();
  EXPECT_EQ(l.value("Enable"), 0);
  EXPECT_EQ(l.out("Enable"), Lane::kGood) << "a good 0 decides an and";
  EXPECT_EQ(l.out("Any"), Lane::kGood) << "a good 1 decides an or";
  l.status("Speed", Lane::kGood);
  l.step();
  EXPECT_EQ(l.out("Enable"), Lane::kUncertain) << "every good input is 1: the stale Ready decides";
  l.set("Run", 0);
  l.step();
  EXPECT_EQ(l.out("Any"), Lane::kUncertain) << "no good 1 into the or";
  EXPECT_EQ(l.out("Enable"), Lane::kGood);
}

// examples/drive.fbd as shipped: with the drive silent, Enable is a good 0
// (sent) and Torque, from the stale speed, is not good (held).
TEST(StatusLane, the_drive_example_drops_enable_as_a_good_0_when_its_speed_goes_stale) {
  std::ifstream f(std::string(RTPLC_SOURCE_DIR) + "/examples/drive.fbd");
  std::stringstream ss;
  ss << f.rdbuf();
  Lane_ l(FbdHarness(ss.str(), 0.02, true, true));
  ASSERT_TRUE(l.ok());
  l.set("Ready", 1);
  l.set("Run", 1);
  l.set("Speed", 300);
  l.status("Speed", Lane::kGood);
  l.step();
  l.step();
  EXPECT_EQ(l.out("Enable"), Lane::kGood);
  EXPECT_EQ(l.out("Torque"), Lane::kGood);
  l.status("Speed", Lane::kUncertain);
  l.status("Ready", Lane::kUncertain);
  l.step();
  l.step();
  EXPECT_EQ(l.value("Enable"), 0);
  EXPECT_EQ(l.out("Enable"), Lane::kGood);
  EXPECT_EQ(l.out("Torque"), Lane::kUncertain);
}

TEST(StatusLane, a_block_that_erred_holds_an_uncertain_value) {
  Lane_ l("F1 = asp(d0, c0, 6, \"A\")\nF2 = asp(d0, c1, 2, \"B\")\nF3 = div(F1, F2)\n"
          "dao(F3, p0, d0, c0, \"Q\")\n");
  ASSERT_TRUE(l.ok());
  l.step();
  EXPECT_EQ(l.value("Q"), 3);
  EXPECT_EQ(l.out("Q"), Lane::kGood);
  l.set("B", 0);
  l.step();
  EXPECT_EQ(l.value("Q"), 3) << "held";
  EXPECT_EQ(l.out("Q"), Lane::kUncertain);
  l.set("B", 3);
  l.step();
  EXPECT_EQ(l.value("Q"), 2);
  EXPECT_EQ(l.out("Q"), Lane::kGood);
}

TEST(StatusLane, a_delayed_reference_reads_last_cycles_status) {
  // F3 reads F4 before F4 runs: last cycle's value, so last cycle's status.
  Lane_ l("F1 = dai(p0, d0, c0, \"In\")\nF3 = add(F4, F1)\nF4 = scale(F1, 1, 0)\n"
          "dao(F3, p0, d0, c0, \"Sum\")\n");
  ASSERT_TRUE(l.ok());
  l.step();
  l.step();
  EXPECT_EQ(l.out("Sum"), Lane::kGood);
  l.status("In", Lane::kBad);
  l.step();
  EXPECT_EQ(l.out("Sum"), Lane::kBad);
  l.status("In", Lane::kGood);
  l.step();
  EXPECT_EQ(l.out("Sum"), Lane::kBad) << "F4's bad status of the last cycle is still read";
  l.step();
  EXPECT_EQ(l.out("Sum"), Lane::kGood);
}

TEST(StatusLane, a_task_whose_inputs_stay_good_skips_the_pass) {
  Lane_ l(kLoop);
  ASSERT_TRUE(l.ok());
  for (int i = 0; i < 10; ++i) l.step();
  EXPECT_EQ(l.passes(), 1) << "only the first cycle needs a pass";
  l.status("ProcVal", Lane::kBad);
  l.step();
  l.status("ProcVal", Lane::kGood);
  for (int i = 0; i < 10; ++i) l.step();
  EXPECT_EQ(l.passes(), 3) << "the bad cycle, then the one that found every value good again";
  EXPECT_EQ(l.out("ManiVal"), Lane::kGood);
}

}  // namespace
}  // namespace rtplc
