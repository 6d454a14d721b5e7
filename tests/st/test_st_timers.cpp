// Timers (TON, TOF, TP) called inside real loops and lists a JMP goes back in
// (docs/st.md, "Loops"): a timer's time is the task's cycle number, so every
// call in one cycle reads one time, and a timer not called for some cycles ran
// on meanwhile with the inputs of its last call, as one called under an IF in
// straight-line code does. Values are worked by hand, or checked against that
// straight-line twin over long random runs.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "lang/compiler.h"
#include "tests/support/fbd_harness.h"

namespace rtplc::lang {
namespace {

using testing::FbdHarness;

// n calls of t in one cycle (a WHILE); et_first and et_last are ET at the first
// and the last of them.
constexpr const char* kLooped = R"(PROGRAM Main
VAR
  n AT %IW0 : INT;
  go AT %IX0.0 : BOOL;
  i : INT;
  t : TON;
  et_first, et_last : TIME;
  q : BOOL;
END_VAR
  i := 0;
  WHILE i < n DO
    t(IN := go, PT := T#50ms);
    IF i = 0 THEN et_first := t.ET; END_IF;
    et_last := t.ET;
    i := i + 1;
  END_WHILE;
  q := t.Q;
END_PROGRAM
)";

TEST(StTimers, calls_of_a_timer_in_one_cycle_read_one_time) {
  FbdHarness h(kLooped, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", kLooped);
  h.set("go", 1);
  h.set("n", 3);
  // Cycle k since IN rose: ET = k * 10 ms at each of the three calls, Q from 50 ms.
  for (int k = 0; k <= 6; ++k) {
    h.step();
    const double want = std::min(k * 0.01, 0.05);
    EXPECT_NEAR(h.value("Main.et_first"), want, 1e-12) << "cycle " << k;
    EXPECT_NEAR(h.value("Main.et_last"), want, 1e-12) << "cycle " << k;
    EXPECT_EQ(h.value("Main.q"), k >= 5 ? 1 : 0) << "cycle " << k;
  }
}

TEST(StTimers, a_timer_not_called_for_some_cycles_ran_on_meanwhile) {
  FbdHarness h(kLooped, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", kLooped);
  h.set("go", 1);
  h.set("n", 1);
  h.step();  // IN rises: ET 0
  h.step();  // 10 ms
  EXPECT_NEAR(h.value("Main.et_last"), 0.01, 1e-12);
  h.set("n", 0);
  h.step(2);  // no call: ET shows the last call's value
  EXPECT_NEAR(h.value("Main.et_last"), 0.01, 1e-12);
  h.set("n", 2);
  h.step();  // four cycles after the rise
  EXPECT_NEAR(h.value("Main.et_first"), 0.04, 1e-12);
  EXPECT_NEAR(h.value("Main.et_last"), 0.04, 1e-12);
  // IN low at the call resets at once; high again at the next cycle's call starts anew.
  h.set("go", 0);
  h.step();
  EXPECT_EQ(h.value("Main.et_last"), 0);
  h.set("go", 1);
  h.step();
  EXPECT_EQ(h.value("Main.et_last"), 0);
  h.step();
  EXPECT_NEAR(h.value("Main.et_last"), 0.01, 1e-12);
}

// A timer that falls and rises between two calls of one cycle starts anew at
// that time (MatIEC's TON: the rising call sets the start time to now).
TEST(StTimers, a_timer_reset_between_two_calls_of_one_cycle_starts_anew) {
  const char* src = R"(PROGRAM Main
VAR
  go AT %IX0.0 : BOOL;
  t : TON;
  first, mid, last : TIME;
  i : INT;
END_VAR
  i := 0;
  REPEAT
    t(IN := go AND i <> 1, PT := T#1s);
    IF i = 0 THEN first := t.ET; END_IF;
    IF i = 1 THEN mid := t.ET; END_IF;
    last := t.ET;
    i := i + 1;
  UNTIL i >= 3 END_REPEAT;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", src);
  h.set("go", 1);
  for (int k = 0; k < 4; ++k) {
    h.step();
    // The first call of a cycle sees the cycle the last one started it in, 10 ms ago.
    EXPECT_NEAR(h.value("Main.first"), k == 0 ? 0 : 0.01, 1e-12) << "cycle " << k;
    EXPECT_EQ(h.value("Main.mid"), 0) << "cycle " << k;
    EXPECT_EQ(h.value("Main.last"), 0) << "cycle " << k << ": restarted by the call with IN low";
  }
}

// Each of TON, TOF and TP in a loop called 0..3 times per cycle against its
// twin called under an IF in straight-line code (which runs on while not
// called, its inputs held): the same Q and ET in every cycle.
void expect_loop_matches_straight_line(const std::string& type, uint32_t seed) {
  const std::string src = "PROGRAM Main\nVAR\n  n AT %IW0 : INT;\n  ptm AT %IW1 : INT;\n  go AT %IX0.0 : BOOL;\n"
                          "  i : INT;\n  a, b : " + type + ";\n  qa, qb : BOOL;\n  pt, eta, etb : TIME;\nEND_VAR\n"
                          "  CASE ptm OF 0: pt := T#0s; 1: pt := T#30ms; 2: pt := T#55ms; 3: pt := T#100ms;\n"
                          "    ELSE pt := T#250ms; END_CASE;\n"
                          "  i := 0;\n  WHILE i < n DO\n    a(IN := go, PT := pt);\n    i := i + 1;\n"
                          "  END_WHILE;\n  IF n > 0 THEN\n    b(IN := go, PT := pt);\n  END_IF;\n"
                          "  qa := a.Q; eta := a.ET; qb := b.Q; etb := b.ET;\nEND_PROGRAM\n";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", src);
  std::mt19937 rng(seed);
  int go = 0, pt = 3, n = 1;  // pt: 0, 30, 55, 100, 250 ms
  for (int k = 0; k < 20000; ++k) {
    if (rng() % 3 == 0) go = 1 - go;
    if (rng() % 40 == 0) pt = static_cast<int>(rng() % 5);
    // Runs of cycles without a call (of every length up to past a pulse or a
    // delay), and cycles of one to three calls.
    if (rng() % 3 == 0) n = rng() % 2 == 0 ? 0 : 1 + static_cast<int>(rng() % 3);
    h.set("go", go);
    h.set("ptm", pt);
    h.set("n", n);
    h.step();
    ASSERT_EQ(h.value("Main.qa"), h.value("Main.qb")) << type << " cycle " << k;
    ASSERT_NEAR(h.value("Main.eta"), h.value("Main.etb"), 1e-12) << type << " cycle " << k;
  }
}

TEST(StTimers, ton_in_a_loop_matches_its_straight_line_twin) { expect_loop_matches_straight_line("TON", 1); }
TEST(StTimers, tof_in_a_loop_matches_its_straight_line_twin) { expect_loop_matches_straight_line("TOF", 2); }
TEST(StTimers, tp_in_a_loop_matches_its_straight_line_twin) {
  expect_loop_matches_straight_line("TP", 3);
}

// TP's pulse ends while it is not called: a long gap with IN low ends it, and
// the next rising call starts a new pulse (hand-worked: PT 30 ms, dt 10 ms).
TEST(StTimers, a_pulse_that_ended_while_not_called_lets_the_next_rise_start_one) {
  const char* src = R"(PROGRAM Main
VAR
  n AT %IW0 : INT;
  go AT %IX0.0 : BOOL;
  i : INT;
  p : TP;
  q : BOOL;
  et : TIME;
END_VAR
  i := 0;
  WHILE i < n DO p(IN := go, PT := T#30ms); i := i + 1; END_WHILE;
  q := p.Q; et := p.ET;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", src);
  h.set("n", 1);
  h.set("go", 1);
  h.step();  // the pulse starts: Q, ET 0
  EXPECT_EQ(h.value("Main.q"), 1);
  h.set("go", 0);
  h.step();  // IN falls, the pulse runs on: 10 ms
  EXPECT_EQ(h.value("Main.q"), 1);
  EXPECT_NEAR(h.value("Main.et"), 0.01, 1e-12);
  h.set("n", 0);
  h.step(5);  // not called: the pulse ended at 30 ms
  h.set("n", 1);
  h.step();  // IN still low: no pulse, ET 0
  EXPECT_EQ(h.value("Main.q"), 0);
  EXPECT_EQ(h.value("Main.et"), 0);
  h.set("go", 1);
  h.step();  // a new rise starts a new pulse
  EXPECT_EQ(h.value("Main.q"), 1);
  EXPECT_EQ(h.value("Main.et"), 0);
  // The gap that ends exactly where the pulse ended: 10 ms at the last call,
  // then cycles at 20 and 30 ms without a call (the one at 30 ms saw the end).
  h.set("go", 0);
  h.step();
  EXPECT_NEAR(h.value("Main.et"), 0.01, 1e-12);
  h.set("n", 0);
  h.step(2);
  h.set("n", 1);
  h.set("go", 1);
  h.step();
  EXPECT_EQ(h.value("Main.q"), 1) << "the pulse had ended: this rise starts a new one";
  EXPECT_EQ(h.value("Main.et"), 0);
}

// A user function block holding a timer, called in a FOR with variable bounds,
// and a timer in a list a JMP goes back in: both read the cycle's time.
TEST(StTimers, a_timer_inside_a_user_fb_in_a_loop_and_behind_a_backward_jump) {
  const char* src = R"(FUNCTION_BLOCK W
VAR_INPUT go : BOOL; END_VAR
VAR_OUTPUT et : TIME; END_VAR
VAR t : TON; END_VAR
  t(IN := go, PT := T#1s);
  et := t.ET;
END_FUNCTION_BLOCK
PROGRAM Main
VAR
  n AT %IW0 : INT;
  i, j : INT;
  w : W;
  t2 : TON;
  s1, s2 : TIME;
END_VAR
  s1 := T#0s;
  FOR i := 1 TO n DO
    w(go := TRUE);
    s1 := s1 + w.et;
  END_FOR;
  j := 0; s2 := T#0s;
again:
  t2(IN := TRUE, PT := T#1s);
  s2 := s2 + t2.ET;
  j := j + 1;
  IF j < n THEN JMP again; END_IF;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", src);
  h.set("n", 4);
  h.step(3);  // third cycle: ET 20 ms at each of the four calls
  EXPECT_NEAR(h.value("Main.s1"), 0.08, 1e-12);
  EXPECT_NEAR(h.value("Main.s2"), 0.08, 1e-12);
}

// The state-machine idiom: one timer called in several CASE branches and read
// in the branch that called it (docs/st.md, "Calls in several branches"). The
// CASE is lowered in two passes, so `t.Q` after `t(...)` in branch 1 is this
// cycle's call's Q, as MatIEC runs it. Worked by hand at 100 ms a cycle.
TEST(StTimers, a_timer_called_in_several_case_branches_is_read_in_each) {
  const char* src = R"(PROGRAM P
VAR
  state : INT;
  t : TON;
  start : BOOL := TRUE;
  n, m : INT;
  et : TIME;
END_VAR
CASE state OF
  0:
    t(IN := FALSE);
    IF start THEN state := 1; END_IF;
  1:
    t(IN := TRUE, PT := T#300ms);
    et := t.ET;
    IF t.Q THEN state := 2; n := n + 1; END_IF;
  2:
    t(IN := FALSE);
    m := m + 1;
    IF NOT t.Q THEN state := 0; END_IF;
END_CASE;
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("sm.st", src);
  // Cycle 0: state 0 -> 1. Cycles 1-4: IN rose in cycle 1, ET 0, 0.1, 0.2,
  // 0.3 s: Q in cycle 4, read at once: state 2, n 1. Cycle 5: IN falls, Q
  // falls: state 0, m 1. Cycle 6: state 1 again; cycle 7 IN rises anew.
  const double state[] = {1, 1, 1, 1, 2, 0, 1, 1, 1, 1, 2};
  const double et[] = {0, 0, 0.1, 0.2, 0.3, 0.3, 0.3, 0, 0.1, 0.2, 0.3};
  const double n[] = {0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 2};
  const double m[] = {0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1};
  for (size_t k = 0; k < 11; ++k) {
    h.step();
    EXPECT_EQ(h.value("P.state"), state[k]) << "cycle " << k;
    EXPECT_NEAR(h.value("P.et"), et[k], 1e-9) << "cycle " << k;
    EXPECT_EQ(h.value("P.n"), n[k]) << "cycle " << k;
    EXPECT_EQ(h.value("P.m"), m[k]) << "cycle " << k;
  }
}

// A branch may read the instance before its own call: the last call's
// outputs, whatever another branch called.
TEST(StTimers, a_branch_reads_the_last_call_before_its_own) {
  const char* src = R"(PROGRAM P
VAR s : INT := 1; t : TON; x : INT; END_VAR
CASE s OF
1: t(IN := TRUE, PT := T#200ms); IF t.Q THEN s := 2; END_IF;
2: IF t.Q THEN x := x + 1; END_IF; t(IN := FALSE); IF NOT t.Q THEN s := 1; END_IF;
END_CASE;
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("br.st", src);
  // Cycles 0-2 in state 1 (Q in cycle 2); cycle 3 in state 2 reads Q = 1
  // before its call: x 1; its call drops Q: state 1.
  const double s_want[] = {1, 1, 2, 1, 1, 1, 2, 1};
  const double x_want[] = {0, 0, 0, 1, 1, 1, 1, 2};
  for (size_t k = 0; k < 8; ++k) {
    h.step();
    EXPECT_EQ(h.value("P.s"), s_want[k]) << k;
    EXPECT_EQ(h.value("P.x"), x_want[k]) << k;
  }
}

// Each branch's statements before its call feed that call's inputs, and the
// variables they assign are merged with the rest of the branch as one IF.
TEST(StTimers, statements_before_the_call_in_each_branch_feed_its_inputs) {
  const char* src = R"(PROGRAM P
VAR
  mode AT %IW0 : INT;
  c : CTU;
  x, seen, after : INT;
END_VAR
IF mode = 1 THEN
  x := 5;
  c(CU := TRUE, PV := x, R := FALSE);
  seen := c.CV;
ELSIF mode = 2 THEN
  x := 7;
  c(CU := FALSE, PV := x, R := TRUE);
  seen := c.CV + 100;
ELSE
  x := 0;
END_IF;
after := c.CV;
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("c.st", src);
  h.set("mode", 1);
  h.step();  // CU rises: CV 1, seen at once
  EXPECT_EQ(h.value("P.seen"), 1);
  EXPECT_EQ(h.value("P.x"), 5);
  h.set("mode", 3);
  h.step();  // not called: CV kept, CU held TRUE (no edge)
  EXPECT_EQ(h.value("P.after"), 1);
  EXPECT_EQ(h.value("P.x"), 0);
  EXPECT_EQ(h.value("P.seen"), 1);
  h.set("mode", 1);
  h.step();  // CU was held TRUE: no new edge
  EXPECT_EQ(h.value("P.seen"), 1);
  h.set("mode", 2);
  h.step();  // RESET: CV 0, read in the branch
  EXPECT_EQ(h.value("P.seen"), 100);
  EXPECT_EQ(h.value("P.x"), 7);
  h.set("mode", 1);
  h.step();  // CU rises again
  EXPECT_EQ(h.value("P.seen"), 1);
  EXPECT_EQ(h.value("P.after"), 1);
}

}  // namespace
}  // namespace rtplc::lang
