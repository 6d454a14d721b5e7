// Labels and JMP in ST (docs/st.md, "Jumps"): forward and backward jumps,
// jumps out of loops and IF branches, RETURN/EXIT/CONTINUE beside labels, the
// loop budget on a backward jump, and every refusal at its line:col. Values
// are worked by hand from the text.
#include <gtest/gtest.h>

#include <string>

#include "lang/compiler.h"
#include "lang/front_end.h"
#include "tests/st/first_error.h"
#include "tests/support/fbd_harness.h"

namespace rtplc::lang {
namespace {

using testing::FbdHarness;

using testing::first_error;

TEST(StJumps, a_backward_jump_repeats_and_a_forward_one_skips) {
  const char* src = R"(PROGRAM Main
VAR
  n AT %IW0 : INT;
  limit AT %IW1 : INT;
  i, s, skipped, runs : INT;
END_VAR
  i := 0; s := 0;
again:
  i := i + 1;
  s := s + i;
  IF i < n THEN JMP again; END_IF;
  IF s > limit THEN JMP done; END_IF;
  skipped := skipped + 1;
done:
  runs := runs + 1;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("j.st", src);
  h.set("n", 10);
  h.set("limit", 50);
  h.step();  // 1 + ... + 10 = 55 > 50: `skipped` is jumped over
  EXPECT_EQ(h.value("Main.i"), 10);
  EXPECT_EQ(h.value("Main.s"), 55);
  EXPECT_EQ(h.value("Main.skipped"), 0);
  EXPECT_EQ(h.value("Main.runs"), 1);
  h.set("n", 4);  // 1 + 2 + 3 + 4 = 10: not over the limit
  h.step();
  EXPECT_EQ(h.value("Main.s"), 10);
  EXPECT_EQ(h.value("Main.skipped"), 1);
  EXPECT_EQ(h.value("Main.runs"), 2);
  h.set("n", 0);  // the body runs once before the test, as the text says
  h.step();
  EXPECT_EQ(h.value("Main.i"), 1);
  EXPECT_EQ(h.value("Main.s"), 1);
  EXPECT_EQ(h.value("Main.skipped"), 2);
  EXPECT_EQ(h.arena().loop_fault, 0u);
}

TEST(StJumps, a_jump_leaves_a_while_loop_and_an_if_branch_not_taken_jumps_nowhere) {
  const char* src = R"(PROGRAM Main
VAR
  want AT %IW0 : INT;
  go AT %IX0.0 : BOOL;
  a : ARRAY [0..9] OF INT := [3, 7, 1, 9, 4, 9, 2, 0, 5, 6];
  i, found, x, r : INT;
END_VAR
  found := -1; i := 0;
  WHILE i < 10 DO
    IF a[i] = want THEN found := i; JMP out; END_IF;
    i := i + 1;
  END_WHILE;
  found := -2;
out:
  x := 0;
  IF go THEN
    x := 100;
    JMP late;
  END_IF;
  x := x + 1;
late:
  r := x;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("j.st", src);
  struct Case {
    double want, found, i;
  };
  // The first 9 is at 3; 6 at the end; 8 is nowhere: the loop ends, found := -2.
  for (const Case& c : {Case{9, 3, 3}, Case{6, 9, 9}, Case{8, -2, 10}, Case{3, 0, 0}}) {
    h.set("want", c.want);
    h.set("go", 0);
    h.step();
    EXPECT_EQ(h.value("Main.found"), c.found) << "want " << c.want;
    EXPECT_EQ(h.value("Main.i"), c.i) << "want " << c.want;
    EXPECT_EQ(h.value("Main.r"), 1) << "want " << c.want;  // go is FALSE: no jump, x + 1
  }
  h.set("go", 1);
  h.step();
  EXPECT_EQ(h.value("Main.x"), 100);
  EXPECT_EQ(h.value("Main.r"), 100);
}

TEST(StJumps, return_exit_and_continue_beside_labels_leave_as_they_say) {
  const char* src = R"(PROGRAM Main
VAR
  stop AT %IW0 : INT;
  i, j, cnt, after : INT;
END_VAR
  j := 0; cnt := 0; after := 0;
  FOR i := 1 TO 10 DO
    IF i = 2 THEN CONTINUE; END_IF;
  again:
    j := j + 1;
    IF j MOD 3 <> 0 THEN JMP again; END_IF;
    IF i = stop THEN EXIT; END_IF;
    IF i = stop + 1 THEN RETURN; END_IF;
    cnt := cnt + 1;
  END_FOR;
  after := 1;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("j.st", src);
  struct Case {
    double stop, i, j, cnt, after;
  };
  for (const Case& c : {
           // i = 1: j 1..3, cnt 1. i = 2: CONTINUE. i = 3: j 4..6, cnt 2. i = 4:
           // j 7..9, cnt 3. i = 5: j 10..12, EXIT before counting.
           Case{5, 5, 12, 3, 1},
           // i = 2 is skipped by CONTINUE before the tests; at i = 3 (= stop + 1),
           // after j 4..6, RETURN: only i = 1 counted, `after` not reached.
           Case{2, 3, 6, 1, 0},
           // Neither: nine iterations count (all but i = 2), j = 27.
           Case{20, 11, 27, 9, 1},
       }) {
    h.set("stop", c.stop);
    h.step();
    EXPECT_EQ(h.value("Main.i"), c.i) << "stop " << c.stop;
    EXPECT_EQ(h.value("Main.j"), c.j) << "stop " << c.stop;
    EXPECT_EQ(h.value("Main.cnt"), c.cnt) << "stop " << c.stop;
    EXPECT_EQ(h.value("Main.after"), c.after) << "stop " << c.stop;
  }
}

TEST(StJumps, a_standard_block_after_a_forward_jump_is_called_only_when_not_jumped_over) {
  const char* src = R"(PROGRAM Main
VAR
  skip AT %IX0.0 : BOOL;
  pulse AT %IX0.1 : BOOL;
  c : CTU;
  v : INT;
END_VAR
  IF skip THEN JMP over; END_IF;
  c(CU := pulse, PV := 100);
over:
  v := c.CV;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("j.st", src);
  const int pulses[] = {1, 0, 1, 0, 1, 0, 1, 0};
  const int skips[] = {0, 0, 1, 1, 0, 0, 1, 0};
  // CTU counts a rising CU against CU at its last call. Cycle 0 counts (1);
  // cycles 2, 3 and 6 jump over the call, so the rise at 2 is never seen; the
  // call at 4 sees TRUE after FALSE (cycle 1) and counts (2); the one at 7
  // sees FALSE.
  const double cv[] = {1, 1, 1, 1, 2, 2, 2, 2};
  for (int k = 0; k < 8; ++k) {
    h.set("pulse", pulses[k]);
    h.set("skip", skips[k]);
    h.step();
    EXPECT_EQ(h.value("Main.v"), cv[k]) << "cycle " << k;
  }
}

TEST(StJumps, a_backward_jump_that_never_ends_is_cut_at_the_budget_and_named) {
  const char* src = "PROGRAM Main\nVAR x : DINT; END_VAR\n  x := 0;\nspin:\n  x := x + 1;\n  JMP spin;\nEND_PROGRAM\n";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("spin.st", src);
  const BlockInfo* b = testing::runaway_loop_in(h);
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(b->line, 6u);  // the JMP
  EXPECT_EQ(b->col, 3u);
}

TEST(StJumps, refuses_a_jump_it_cannot_take_at_its_position_naming_it) {
  EXPECT_EQ(first_error("PROGRAM P VAR x : INT; END_VAR\nJMP nowhere;\nEND_PROGRAM").substr(0, 45),
            "2:1: JMP NOWHERE: no label 'NOWHERE' in this ");
  // Into an IF: the label is in a list the jump is not inside.
  EXPECT_EQ(first_error("PROGRAM P VAR x : INT; END_VAR\nJMP inside;\nIF x > 0 THEN\ninside: x := 1;\nEND_IF;\n"
                        "END_PROGRAM")
                .substr(0, 20),
            "2:1: JMP INSIDE: no ");
  EXPECT_EQ(first_error("PROGRAM P VAR x : INT; END_VAR\na: x := 1;\na: x := 2;\nEND_PROGRAM"),
            "3:1: label 'A' is already defined at line 2");
  EXPECT_EQ(first_error("PROGRAM P VAR x : INT; END_VAR\nGOTO a;\nEND_PROGRAM"), "2:1: GOTO is not ST: a jump is JMP label");
  EXPECT_EQ(first_error("PROGRAM P VAR x : INT; END_VAR\nJMP ;\nEND_PROGRAM"), "2:5: expected a label after JMP, found ';'");
}

// Edge and counter FBs in real loops: each call is one step of the FB's machine,
// as the standard's bodies run (timers: tests/st/test_st_timers.cpp).
TEST(StLoopCalls, edges_and_counters_step_once_per_call_in_a_while_loop_and_a_backward_jump) {
  const char* src = R"(PROGRAM Main
VAR
  n AT %IW0 : INT;
  bits : ARRAY [0..7] OF BOOL := [TRUE, FALSE, TRUE, TRUE, FALSE, TRUE, FALSE, FALSE];
  r : R_TRIG;
  c, g, k : CTU;
  edges, i, j, counted : INT;
END_VAR
  i := 0; edges := 0;
  WHILE i < n DO
    r(CLK := bits[i]);
    IF r.Q THEN edges := edges + 1; END_IF;
    c(CU := bits[i], R := FALSE, PV := 100);
    IF bits[i] THEN g(CU := TRUE, PV := 4); ELSE g(CU := FALSE, PV := 4); END_IF;
    i := i + 1;
  END_WHILE;
  j := 0;
again:
  k(CU := j MOD 2 = 0, R := FALSE, PV := 100);
  j := j + 1;
  IF j < n THEN JMP again; END_IF;
  counted := k.CV;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("calls.st", src);
  h.set("n", 8);
  h.step();
  // T F T T F T F F: rising at 0, 2 and 5 (R_TRIG's memory starts FALSE).
  EXPECT_EQ(h.value("Main.edges"), 3);
  EXPECT_EQ(h.value("Main.c.CV"), 3);
  EXPECT_EQ(h.value("Main.g.CV"), 3);  // the same edges, called from either branch
  EXPECT_EQ(h.value("Main.counted"), 4);  // CU = T F T F T F T F over the jumps
  h.step();  // the last bit was FALSE: bit 0 rises again
  EXPECT_EQ(h.value("Main.edges"), 3);
  EXPECT_EQ(h.value("Main.c.CV"), 6);
  EXPECT_EQ(h.value("Main.g.CV"), 4);  // stopped at PV = 4
  EXPECT_EQ(h.value("Main.counted"), 8);
  h.set("n", 0);  // the WHILE runs no call; the JMP list runs once (CU TRUE after FALSE)
  h.step();
  EXPECT_EQ(h.value("Main.edges"), 0);
  EXPECT_EQ(h.value("Main.c.CV"), 6);
  EXPECT_EQ(h.value("Main.counted"), 9);
}

}  // namespace
}  // namespace rtplc::lang
