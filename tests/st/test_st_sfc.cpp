// Textual SFC in a .st file (docs/st.md, "Textual SFC"): INITIAL_STEP, STEP,
// TRANSITION and ACTION as IEC 61131-3 writes them (and Beremiz writes an SFC
// POU into the file it gives MatIEC), run by the one SFC lowering PLCopen's
// drawn charts use. Expected values are worked by hand, scan by scan, from
// MatIEC's order (conditions, then steps, then the actions of the steps active
// now) and CODESYS's (actions of the steps active at the start, then the
// conditions for the next scan).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "blocks/image.h"
#include "lang/compiler.h"
#include "sched/program.h"
#include "tests/st/first_error.h"
#include "tests/support/block_value.h"

namespace rtplc::lang {
namespace {

using testing::first_error;

// Runs `src` for `scans` cycles and gives the values of `names` after each.
std::vector<std::vector<double>> run(const std::string& src, const std::vector<std::string>& names, int scans,
                                     EditorSemantics sem = EditorSemantics::kMatiec) {
  CompileOptions o;
  o.semantics = sem;
  o.period_override = 0.1;
  CompileResult r = compile_source(src, o);
  EXPECT_TRUE(r.ok()) << r.diags.render("sfc.st", src);
  std::vector<std::vector<double>> out;
  if (!r.ok()) return out;
  TaskArena arena(*r.image);
  for (int k = 0; k < scans; ++k) {
    execute_cycle(*r.image, arena);
    std::vector<double> row;
    for (const std::string& n : names) row.push_back(testing::block_value(r, arena, n));
    out.push_back(row);
  }
  return out;
}

const char* const kFill = R"(PROGRAM P
VAR
  go : BOOL := TRUE;
  n, back : INT;
  red, green : BOOL;
END_VAR
  INITIAL_STEP Idle:
    red(N);
  END_STEP

  STEP Fill:
    green(N);
    Count(N);
  END_STEP

  STEP Drain:
    Back_Once(P);
  END_STEP

  ACTION Count:
    n := n + 1;
  END_ACTION

  ACTION Back_Once:
    back := back + 1;
  END_ACTION

  TRANSITION FROM Idle TO Fill
    := go;
  END_TRANSITION

  TRANSITION Full FROM Fill TO Drain := n >= 3;
  END_TRANSITION

  TRANSITION FROM Drain TO Idle := Drain.X; END_TRANSITION
END_PROGRAM
)";

TEST(StSfc, a_chart_runs_scan_by_scan_as_matiec_runs_it) {
  // MatIEC: scan 0 fires Idle -> Fill (go) and runs Fill's actions at once
  // (n = 1); n counts while Fill is active; at n >= 3 Drain is entered, its
  // P action runs once; Drain.X read by a condition is the flag the scan
  // started with, so Drain is left one scan later.
  const auto v = run(kFill, {"P.n", "P.back", "P.step.Idle.X", "P.step.Fill.X", "P.step.Drain.X", "P.red", "P.green"}, 7);
  ASSERT_EQ(v.size(), 7u);
  const std::vector<std::vector<double>> want = {
      {1, 0, 0, 1, 0, 0, 1},  // 0: Idle -> Fill, Count
      {2, 0, 0, 1, 0, 0, 1},  // 1
      {3, 0, 0, 1, 0, 0, 1},  // 2: n reaches 3 after the conditions
      {3, 1, 0, 0, 1, 0, 0},  // 3: Fill -> Drain, Back_Once
      {3, 1, 1, 0, 0, 1, 0},  // 4: Drain.X was TRUE: Drain -> Idle, red
      {4, 1, 0, 1, 0, 0, 1},  // 5: go: Idle -> Fill, Count again
      {4, 2, 0, 0, 1, 0, 0},  // 6: n >= 3 still holds: Fill -> Drain at once
  };
  for (size_t k = 0; k < want.size(); ++k) EXPECT_EQ(v[k], want[k]) << "scan " << k;
}

TEST(StSfc, codesys_runs_the_actions_of_the_steps_active_at_the_start) {
  // CODESYS: scan 0 runs Idle's action and switches to Fill for scan 1; an
  // action runs once more in the scan after its step is left (scan 4: Count
  // makes n 4 after Fill was left at the end of scan 3).
  const auto v = run(kFill, {"P.n", "P.back", "P.step.Fill.X", "P.step.Drain.X"}, 6, EditorSemantics::kCodesys);
  ASSERT_EQ(v.size(), 6u);
  EXPECT_EQ(v[0][0], 0);  // Idle's scan
  EXPECT_EQ(v[1][0], 1);
  EXPECT_EQ(v[2][0], 2);
  EXPECT_EQ(v[3][0], 3);  // n >= 3 seen after Count: Drain next
  EXPECT_EQ(v[3][3], 1);
  EXPECT_EQ(v[4][0], 4);  // Count's last call
  EXPECT_EQ(v[4][1], 1);  // Back_Once in Drain's first scan
}

TEST(StSfc, a_step_time_counts_as_matiec_counts_it) {
  // MatIEC adds the scan's time to an active step's T before the conditions,
  // sets it to 0 when the step is entered and keeps it when the step is left.
  const char* src = R"(PROGRAM P
VAR seen : TIME; n : INT; END_VAR
  INITIAL_STEP Stop: END_STEP
  STEP Run: Look(N); END_STEP
  ACTION Look:
    seen := Run.T;
    n := n + 1;
  END_ACTION
  TRANSITION FROM Stop TO Run := TRUE; END_TRANSITION
  TRANSITION FROM Run TO Stop := Run.T >= T#300ms; END_TRANSITION
END_PROGRAM
)";
  const auto v = run(src, {"P.step.Run.T", "P.seen", "P.step.Run.X", "P.n"}, 6);
  ASSERT_EQ(v.size(), 6u);
  const std::vector<std::vector<double>> want = {
      {0, 0, 1, 1},      // 0: Run entered: T = 0 for its action
      {0.1, 0.1, 1, 2},  // 1
      {0.2, 0.2, 1, 3},  // 2
      {0.3, 0.2, 0, 3},  // 3: T reached 300 ms before the conditions: left, T kept
      {0, 0, 1, 4},      // 4: entered again: 0
      {0.1, 0.1, 1, 5},  // 5
  };
  for (size_t k = 0; k < want.size(); ++k) {
    ASSERT_EQ(v[k].size(), 4u);
    for (size_t j = 0; j < 4; ++j) EXPECT_NEAR(v[k][j], want[k][j], 1e-12) << "scan " << k << " column " << j;
  }
}

// T is built from the scan's time (a timer that restarts every hour), so it
// stays exact across that restart and over long runs: 3,700 s at 100 ms is
// scan 37,000, neither one early nor one late.
TEST(StSfc, a_step_time_stays_exact_past_an_hour) {
  const char* src = R"(PROGRAM P
  INITIAL_STEP Wait: END_STEP
  STEP Run: END_STEP
  STEP Done: END_STEP
  TRANSITION FROM Wait TO Run := TRUE; END_TRANSITION
  TRANSITION FROM Run TO Done := Run.T >= T#3700s; END_TRANSITION
END_PROGRAM
)";
  CompileOptions o;
  o.semantics = EditorSemantics::kMatiec;
  o.period_override = 0.1;
  CompileResult r = compile_source(src, o);
  ASSERT_TRUE(r.ok()) << r.diags.render("long.st", src);
  TaskArena arena(*r.image);
  int64_t entered_done = -1;
  for (int64_t scan = 0; scan < 37005 && entered_done < 0; ++scan) {
    execute_cycle(*r.image, arena);
    if (testing::block_value(r, arena, "P.step.Done.X") == 1) entered_done = scan;
  }
  // Run entered in scan 0; its T is 0.1 s in scan 1, ..., 3,700 s in scan 37,000.
  EXPECT_EQ(entered_done, 37000);
}

TEST(StSfc, simultaneous_branches_priorities_timed_actions_and_an_il_condition) {
  const char* src = R"(PROGRAM P
VAR
  a, b, c : INT;
  lamp : BOOL;
  pick : INT := 1;
END_VAR
  INITIAL_STEP Start:
  END_STEP
  STEP A: Inc_A(N); END_STEP
  STEP B: Inc_B(N); lamp(L, T#200ms); END_STEP
  STEP Join: Inc_C(N); END_STEP
  ACTION Inc_A: a := a + 1; END_ACTION
  ACTION Inc_B: b := b + 1; END_ACTION
  ACTION Inc_C: c := c + 1; END_ACTION
  TRANSITION FROM Start TO (A, B) := TRUE; END_TRANSITION
  TRANSITION FROM (A, B) TO Join
  :
    LD a
    GE 4
  END_TRANSITION
  (* both true from Join: the lower PRIORITY number is taken, as MatIEC orders them *)
  TRANSITION (PRIORITY := 2) FROM Join TO A := TRUE; END_TRANSITION
  TRANSITION (PRIORITY := 1) FROM Join TO Start := pick = 1; END_TRANSITION
END_PROGRAM
)";
  const auto v = run(src, {"P.a", "P.b", "P.c", "P.lamp", "P.step.Start.X", "P.step.Join.X"}, 7);
  ASSERT_EQ(v.size(), 7u);
  // Scans 0-3: A and B both active; a and b count 1..4; lamp (L, 200 ms at
  // 100 ms a scan) is on for the first two scans of B.
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(v[k][0], static_cast<double>(k + 1)) << k;
    EXPECT_EQ(v[k][1], static_cast<double>(k + 1)) << k;
    EXPECT_EQ(v[k][3], k < 2 ? 1 : 0) << k;
  }
  // Scan 4: a >= 4 (the IL condition's current result): both leave, Join runs.
  EXPECT_EQ(v[4][0], 4);
  EXPECT_EQ(v[4][2], 1);
  EXPECT_EQ(v[4][5], 1);
  // Scan 5: from Join, PRIORITY 1 (to Start) wins over PRIORITY 2 (to A).
  EXPECT_EQ(v[5][4], 1);
  EXPECT_EQ(v[5][0], 4);
  // Scan 6: Start -> A and B again.
  EXPECT_EQ(v[6][0], 5);
}

// MatIEC's list of transitions: without PRIORITY (counted as 0) appended,
// with one inserted before the first listed with a larger number.
TEST(StSfc, transitions_are_tried_in_matiecs_priority_order) {
  auto first_taken = [](const std::string& transitions) {
    const std::string src = "PROGRAM P\nINITIAL_STEP S: END_STEP\nSTEP A: END_STEP\nSTEP B: END_STEP\nSTEP C: END_STEP\n" +
                            transitions + "END_PROGRAM\n";
    const auto v = run(src, {"P.step.A.X", "P.step.B.X", "P.step.C.X"}, 1);
    if (v.empty()) return std::string("none");
    return std::string(v[0][0] == 1 ? "A" : v[0][1] == 1 ? "B" : v[0][2] == 1 ? "C" : "none");
  };
  const std::string to_a = "TRANSITION (PRIORITY := 1) FROM S TO A := TRUE; END_TRANSITION\n";
  const std::string to_b = "TRANSITION FROM S TO B := TRUE; END_TRANSITION\n";
  const std::string to_c = "TRANSITION (PRIORITY := 0) FROM S TO C := TRUE; END_TRANSITION\n";
  EXPECT_EQ(first_taken(to_a + to_b), "A");  // file order: A, then B appended
  EXPECT_EQ(first_taken(to_b + to_a), "B");  // B (0), then A (1) after it
  EXPECT_EQ(first_taken(to_a + to_c), "C");  // C (0) goes before A (1)
  EXPECT_EQ(first_taken(to_b + to_c), "B");  // C (0) after B (0): not before an equal
}

// A timed qualifier's duration given by a TIME variable (MatIEC's tests write
// `INLINE3(L, delta_1)`), read every cycle; indicator variables after it are
// accepted and change nothing, as in MatIEC.
TEST(StSfc, an_action_duration_may_be_a_variable) {
  const char* src = R"(PROGRAM P
VAR lamp, bell, seen : BOOL; d : TIME := T#300ms; e : TIME := T#200ms; END_VAR
  INITIAL_STEP S: lamp(L, d, seen); bell(D, e); END_STEP
  TRANSITION FROM S TO S := FALSE; END_TRANSITION
END_PROGRAM
)";
  for (EditorSemantics sem : {EditorSemantics::kMatiec, EditorSemantics::kCodesys}) {
    const auto v = run(src, {"P.lamp", "P.bell"}, 5, sem);
    ASSERT_EQ(v.size(), 5u);
    // As with T#300ms and T#200ms: lamp for the first 300 ms, bell from 200 ms.
    const std::vector<std::vector<double>> want = {{1, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 1}};
    for (size_t k = 0; k < want.size(); ++k) EXPECT_EQ(v[k], want[k]) << "scan " << k << " " << static_cast<int>(sem);
  }
  EXPECT_EQ(first_error("PROGRAM P\nVAR a : BOOL; n : INT; END_VAR\nINITIAL_STEP S: a(L, flag); END_STEP\n"
                        "TRANSITION FROM S TO S := FALSE; END_TRANSITION\nEND_PROGRAM\n")
                .substr(0, 8),
            "3:17: 'f");
}

TEST(StSfc, a_chart_in_a_function_block_runs_per_instance) {
  const char* src = R"(FUNCTION_BLOCK Blinker
VAR_INPUT go : BOOL; END_VAR
VAR_OUTPUT q : BOOL; END_VAR
  INITIAL_STEP Off: END_STEP
  STEP On: q(N); END_STEP
  TRANSITION FROM Off TO On := go; END_TRANSITION
  TRANSITION FROM On TO Off := TRUE; END_TRANSITION
END_FUNCTION_BLOCK
PROGRAM P
VAR b1, b2 : Blinker; q1, q2 : BOOL; started : BOOL; END_VAR
  b1(go := TRUE);
  b2(go := started);
  started := TRUE;
  q1 := b1.q;
  q2 := b2.q;
END_PROGRAM
)";
  const auto v = run(src, {"P.q1", "P.q2"}, 4);
  ASSERT_EQ(v.size(), 4u);
  // b1 alternates from scan 0; b2 is first let go in scan 1, so it is one behind.
  EXPECT_EQ(v[0], (std::vector<double>{1, 0}));
  EXPECT_EQ(v[1], (std::vector<double>{0, 1}));
  EXPECT_EQ(v[2], (std::vector<double>{1, 0}));
  EXPECT_EQ(v[3], (std::vector<double>{0, 1}));
}

TEST(StSfc, the_example_fills_and_drains_on_its_step_times) {
  std::ifstream f(std::string(RTPLC_SOURCE_DIR) + "/examples/filler_sfc.st");
  std::stringstream ss;
  ss << f.rdbuf();
  ASSERT_FALSE(ss.str().empty());
  // 100 ms scans. Fill is entered in scan 0 (go), so Fill.T reaches 3 s in
  // scan 30: Drain, batches 1; the pump (L 1.5 s) runs in scans 30..44;
  // Drain.T reaches 2 s in scan 50: Idle; scan 51: Fill again, T from 0.
  const auto v = run(ss.str(), {"Filler0.step.Fill.X", "Filler0.step.Drain.X", "Filler0.step.Idle.X", "Filler0.batches",
                                "Filler0.pump", "Filler0.valve", "Filler0.step.Fill.T"},
                     56);
  ASSERT_EQ(v.size(), 56u);
  EXPECT_EQ(v[29], (std::vector<double>{1, 0, 0, 0, 0, 1, 2.9}));
  EXPECT_EQ(v[30], (std::vector<double>{0, 1, 0, 1, 1, 0, 3}));
  EXPECT_EQ(v[44][4], 1);
  EXPECT_EQ(v[45][4], 0);
  EXPECT_EQ(v[49][1], 1);
  EXPECT_EQ(v[50], (std::vector<double>{0, 0, 1, 1, 0, 0, 3}));
  EXPECT_EQ(v[51], (std::vector<double>{1, 0, 0, 1, 0, 1, 0}));
  EXPECT_EQ(v[55][6], 0.4);
}

TEST(StSfc, a_chart_called_under_if_holds_its_steps_between_calls) {
  // As MatIEC's chart between calls of its FB: no transition fires in a cycle
  // the FB is not called, its steps and BOOL action variables hold; a step's
  // T ran on meanwhile (MatIEC adds the time since the last call).
  const char* src = R"(FUNCTION_BLOCK Blinker
VAR_OUTPUT q : BOOL; n : INT; END_VAR
  INITIAL_STEP Off: END_STEP
  STEP On: q(N); Count(P); END_STEP
  ACTION Count: n := n + 1; END_ACTION
  TRANSITION FROM Off TO On := TRUE; END_TRANSITION
  TRANSITION FROM On TO Off := On.T >= T#200ms; END_TRANSITION
END_FUNCTION_BLOCK
PROGRAM P
VAR b : Blinker; k : INT; q : BOOL; n : INT; END_VAR
  k := k + 1;
  IF k < 3 OR k > 6 THEN b(); END_IF;
  q := b.q;
  n := b.n;
END_PROGRAM
)";
  const auto v = run(src, {"P.q", "P.n", "P.b.step.On.X"}, 10);
  ASSERT_EQ(v.size(), 10u);
  const std::vector<std::vector<double>> want = {
      {1, 1, 1},  // 0: called: Off -> On, Count
      {1, 1, 1},  // 1: called, On.T 100 ms
      {1, 1, 1}, {1, 1, 1}, {1, 1, 1}, {1, 1, 1},  // 2-5: not called: On held, q held
      {0, 1, 0},      // 6: called, On.T 600 ms: On -> Off
      {1, 2, 1},      // 7: Off -> On, Count again
      {1, 2, 1},      // 8
      {0, 2, 0},      // 9: On.T 200 ms
  };
  for (size_t k = 0; k < want.size(); ++k) EXPECT_EQ(v[k], want[k]) << "scan " << k;
}

TEST(StSfc, an_action_body_in_il_is_read_as_il) {
  const char* src = R"(PROGRAM P
VAR n : INT; END_VAR
  INITIAL_STEP S: Inc(N); END_STEP
  ACTION Inc:
    LD n
    ADD 2
    ST n
  END_ACTION
  TRANSITION FROM S TO S := FALSE; END_TRANSITION
END_PROGRAM
)";
  const auto v = run(src, {"P.n"}, 3);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[2][0], 6);
}

// A swap keeps the active step and its elapsed time by name (the chart's
// blocks are named by instance path, as PLCopen's): version 2 adds a step
// after Run and changes the action, and goes on from where version 1 was.
TEST(StSfc, a_swap_keeps_the_active_step_and_its_time) {
  const char* v1 = R"(PROGRAM P
VAR n : INT; END_VAR
  INITIAL_STEP Wait: END_STEP
  STEP Run: Inc(N); END_STEP
  ACTION Inc: n := n + 1; END_ACTION
  TRANSITION FROM Wait TO Run := TRUE; END_TRANSITION
  TRANSITION FROM Run TO Wait := Run.T >= T#1s; END_TRANSITION
END_PROGRAM
)";
  const char* v2 = R"(PROGRAM P
VAR n : INT; END_VAR
  INITIAL_STEP Wait: END_STEP
  STEP Run: Inc(N); END_STEP
  STEP Rest: END_STEP
  ACTION Inc: n := n + 10; END_ACTION
  TRANSITION FROM Wait TO Run := TRUE; END_TRANSITION
  TRANSITION FROM Run TO Rest := Run.T >= T#1s; END_TRANSITION
  TRANSITION FROM Rest TO Wait := TRUE; END_TRANSITION
END_PROGRAM
)";
  CompileOptions o;
  o.period_override = 0.1;
  CompileResult a = compile_source(v1, o), b = compile_source(v2, o);
  ASSERT_TRUE(a.ok() && b.ok()) << a.diags.render("v1.st", v1) << b.diags.render("v2.st", v2);
  TaskArena old_arena(*a.image);
  for (int k = 0; k < 4; ++k) execute_cycle(*a.image, old_arena);  // Run from scan 0: T 0.3 s, n 4
  EXPECT_EQ(testing::block_value(a, old_arena, "P.n"), 4);
  const sched::Migration m = sched::plan_migration(*a.image, *b.image);
  TaskArena next(*b.image);
  sched::apply_migration(m, old_arena, next);
  execute_cycle(*b.image, next);  // Run still active, T 0.4 s: the new action
  EXPECT_EQ(testing::block_value(b, next, "P.step.Run.X"), 1);
  EXPECT_NEAR(testing::block_value(b, next, "P.step.Run.T"), 0.4, 1e-12);
  EXPECT_EQ(testing::block_value(b, next, "P.n"), 14);
  for (int k = 0; k < 6; ++k) execute_cycle(*b.image, next);  // T reaches 1 s: Rest, as version 2 says
  EXPECT_EQ(testing::block_value(b, next, "P.step.Rest.X"), 1);
}

TEST(StSfc, mistakes_are_refused_at_their_place) {
  auto chart = [](const std::string& body) {
    return "PROGRAM P\nVAR go : BOOL; n : INT; END_VAR\n" + body + "END_PROGRAM\n";
  };
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: END_STEP\nTRANSITION FROM S1 TO S9 := go; END_TRANSITION\n")),
            "4:23: step S9 is not declared in this chart");
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: go(X); END_STEP\nSTEP S2: END_STEP\n"
                              "TRANSITION FROM S1 TO S2 := go; END_TRANSITION\n"))
                .substr(0, 40),
            "3:18: action qualifier X is not supporte");
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: END_STEP\nn := 1;\n")).substr(0, 36),
            "4:1: 'n' cannot stand in a textual S");
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: go(N);\n")), "3:1: INITIAL_STEP S1 is never closed by END_STEP");
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: go(L, ); END_STEP\n")).substr(0, 40),
            "3:24: expected the action's duration, a ");
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: END_STEP\nSTEP S1: END_STEP\n")), "4:1: step S1 is declared twice");
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: END_STEP\nSTEP S2: END_STEP\n"
                              "TRANSITION FROM S1 TO S2 := S2.Q; END_TRANSITION\n")),
            "5:29: 'S2.Q': a step has .X (active) and .T (elapsed time), no .Q");
  // An error inside an action's body is at its place in the file.
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: Act(N); END_STEP\nACTION Act:\n  n := n +;\nEND_ACTION\n"
                              "TRANSITION FROM S1 TO S1 := go; END_TRANSITION\n"))
,
            "5:11: expected an expression, found ';'");
  EXPECT_EQ(first_error(chart("STEP S1: END_STEP\n")).substr(0, 40), "3:1: this SFC has no initial step (initi");
  // A condition's missing ';' is named there, not read on into what follows.
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: END_STEP\nTRANSITION FROM S1 TO S1 := go END_TRANSITION\n") +
                        "PROGRAM Q VAR y : BOOL; END_VAR\nINITIAL_STEP U: END_STEP\n"
                        "TRANSITION FROM U TO U := y; END_TRANSITION\nEND_PROGRAM\n"),
            "4:29: expected ';' after the transition's condition, before END_TRANSITION");
  // A function keeps nothing between calls: no chart.
  EXPECT_EQ(first_error("FUNCTION F : BOOL\nINITIAL_STEP S: END_STEP\nEND_FUNCTION\n").substr(0, 54),
            "2:1: FUNCTION F: a function's body cannot be an SFC (a");
  // A variable named STEP is no chart (STEP is a keyword IEC reserves, but not here).
  EXPECT_EQ(first_error("PROGRAM P VAR step : INT; END_VAR\nstep := step + 1;\nEND_PROGRAM\n"), "compiled");
  EXPECT_EQ(first_error("FUNCTION_BLOCK F\nINITIAL_STEP S: END_STEP\nTRANSITION FROM S TO S := TRUE; END_TRANSITION\n"
                        "END_FUNCTION_BLOCK\nPROGRAM P VAR f : F; END_VAR\nf(); f();\nEND_PROGRAM\n")
                .substr(0, 54),
            "6:6: 'f' is called a second time here (in this cycle o");
  EXPECT_EQ(first_error(chart("INITIAL_STEP S1: END_STEP\nTRANSITION FROM S1 TO S1 go; END_TRANSITION\n")),
            "4:26: expected ':=' and the transition's condition");
}

}  // namespace
}  // namespace rtplc::lang
