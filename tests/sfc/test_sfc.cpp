// The SFC front end (docs/sfc.md): syntax, diagnostics, and what the compiled
// task does cycle by cycle — step evolution, qualifiers, branches, jumps.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "lang/compiler.h"
#include "lang/sfc/builder.h"
#include "lang/sfc/lexer.h"
#include "tests/support/fbd_harness.h"

namespace rtplc {
namespace {

using testing::FbdHarness;

std::string read(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// A chart with the usual header and two signals, for the qualifier tests.
std::string chart(const std::string& body) {
  return "SFC t\nstime(0.1)\n"
         "INPUT GO = ddi(p0, d0, c0, \"GO\")\n"
         "INPUT STOP = ddi(p0, d0, c1, \"STOP\")\n"
         "OUTPUT Q = ddo(p0, d1, c0, \"Q\")\n" +
         body;
}

struct Sfc : FbdHarness {
  explicit Sfc(const std::string& src, double dt = 0.1) : FbdHarness(src, dt, true, true) {}
  bool active(const std::string& step) { return value("step." + step) != 0; }
};

TEST(SfcFrontEnd, detects_the_language_from_the_first_word) {
  EXPECT_TRUE(lang::sfc::starts_with_sfc_keyword("// comment\n/* block */ SFC x\n"));
  EXPECT_TRUE(lang::sfc::starts_with_sfc_keyword("\xEF\xBB\xBFSFC x"));
  EXPECT_FALSE(lang::sfc::starts_with_sfc_keyword("%%\nF1 = dai(p0, d0, c0)\nEND\n"));
  EXPECT_FALSE(lang::sfc::starts_with_sfc_keyword("SFCX"));
}

TEST(SfcFrontEnd, the_tank_example_compiles_to_an_ordinary_task_image) {
  lang::CompileResult r = lang::compile_file(RTPLC_SOURCE_DIR "/examples/tank.sfc");
  ASSERT_TRUE(r.ok()) << r.diags.render("tank.sfc", read(RTPLC_SOURCE_DIR "/examples/tank.sfc"));
  EXPECT_EQ(r.diags.warning_count(), 0u)
      << r.diags.render("tank.sfc", read(RTPLC_SOURCE_DIR "/examples/tank.sfc"));
  EXPECT_DOUBLE_EQ(r.image->period_s(), 0.1);
  // Every step is a labelled output channel on p255 (the monitor shows it).
  int step_flags = 0;
  for (const Binding& b : r.image->bindings()) {
    if (b.dir == BindingDir::kOutput && b.p == lang::sfc::kStepFlagProcessor) {
      ++step_flags;
      EXPECT_EQ(std::string(r.image->str(b.label)).rfind("tank.S", 0), 0u);
    }
  }
  EXPECT_EQ(step_flags, 7);
  const std::string report = lang::explain(r);
  EXPECT_NE(report.find("step.S0"), std::string::npos);
}

TEST(SfcRun, the_tank_runs_its_cycle_against_a_hand_plant) {
  Sfc s(read(RTPLC_SOURCE_DIR "/examples/tank.sfc"));
  ASSERT_TRUE(s.ok());
  double level = 0;  // 0 empty .. 1 full; LS2 at <= 0.1, LS1 at >= 0.9
  auto plant = [&] {
    s.set("LS2", level <= 0.1 ? 1 : 0);
    s.set("LS1", level >= 0.9 ? 1 : 0);
  };
  auto cycle = [&] {
    plant();
    s.step();
    level += 0.05 * s.out("valve1") - 0.05 * s.out("valve2");
    level = std::max(0.0, std::min(1.0, level));
  };
  cycle();
  EXPECT_TRUE(s.active("S0"));
  EXPECT_EQ(s.out("lamp1"), 1);
  EXPECT_EQ(s.out("tank.S0"), 1);
  for (int k = 0; k < 5; ++k) cycle();
  EXPECT_TRUE(s.active("S0")) << "waits for the push button";
  s.set("PBS", 1);
  cycle();
  EXPECT_TRUE(s.active("S1"));
  EXPECT_FALSE(s.active("S0"));
  EXPECT_EQ(s.out("lamp1"), 0);
  EXPECT_EQ(s.out("valve1"), 1);
  s.set("PBS", 0);
  bool saw[7] = {};
  for (int k = 0; k < 200 && !(saw[6] && s.active("S0")); ++k) {
    cycle();
    for (int i = 0; i < 7; ++i) saw[i] = saw[i] || s.active("S" + std::to_string(i));
    int n = 0;
    for (int i = 0; i < 7; ++i) n += s.active("S" + std::to_string(i)) ? 1 : 0;
    ASSERT_EQ(n, 1) << "one token in a sequence, cycle " << k;
  }
  for (int i = 0; i < 7; ++i) EXPECT_TRUE(saw[i]) << "step S" << i;
  EXPECT_TRUE(s.active("S0"));
  EXPECT_LE(level, 0.1);
  EXPECT_EQ(s.out("valve1"), 0);
  EXPECT_EQ(s.out("valve2"), 0);
  EXPECT_EQ(s.out("lamp1"), 1);
}

TEST(SfcRun, a_transition_fires_on_the_cycle_after_its_step_became_active) {
  Sfc s(
      chart("INITIAL STEP A\nN Q\nEND_STEP\nSTEP B\nEND_STEP\n"
            "TRANSITION t1 FROM A TO B WHEN GO\nTRANSITION t2 FROM B TO A WHEN TRUE\n"));
  ASSERT_TRUE(s.ok());
  s.set("GO", 1);
  s.step();  // first cycle: the initial step becomes active, nothing fires yet
  EXPECT_TRUE(s.active("A"));
  EXPECT_EQ(s.out("Q"), 1);
  s.step();
  EXPECT_TRUE(s.active("B"));
  EXPECT_EQ(s.out("Q"), 0);
  s.step();  // WHEN TRUE still waits one cycle in B
  EXPECT_TRUE(s.active("A"));
}

TEST(SfcRun, set_and_reset_latch_the_output_across_steps) {
  Sfc s(
      chart("INITIAL STEP A\nS Q\nEND_STEP\nSTEP B\nEND_STEP\nSTEP C\nR Q\nEND_STEP\n"
            "TRANSITION t1 FROM A TO B WHEN GO\nTRANSITION t2 FROM B TO C WHEN STOP\n"
            "TRANSITION t3 FROM C TO A WHEN NOT STOP\n"));
  ASSERT_TRUE(s.ok());
  s.step();
  EXPECT_EQ(s.out("Q"), 1);
  s.set("GO", 1);
  s.step(3);
  EXPECT_TRUE(s.active("B"));
  EXPECT_EQ(s.out("Q"), 1) << "S holds after its step";
  s.set("GO", 0);
  s.set("STOP", 1);
  s.step();
  EXPECT_TRUE(s.active("C"));
  EXPECT_EQ(s.out("Q"), 0);
}

TEST(SfcRun, pulse_limited_and_delayed_actions_follow_the_step_time) {
  Sfc s(
      chart("OUTPUT R1 = ddo(p0, d1, c1, \"R1\")\nOUTPUT R2 = ddo(p0, d1, c2, \"R2\")\n"
            "INITIAL STEP A\nP Q\nL R1 0.3s\nD R2 300ms\nEND_STEP\n"
            "TRANSITION t1 FROM A TO A WHEN STOP\n"));
  ASSERT_TRUE(s.ok()) << s.result().diags.render("t", "");
  std::string trace;
  for (int k = 0; k < 6; ++k) {
    s.step();
    trace += std::to_string(static_cast<int>(s.out("Q"))) +
             std::to_string(static_cast<int>(s.out("R1"))) +
             std::to_string(static_cast<int>(s.out("R2"))) + " ";
  }
  // P: the first cycle only. L 0.3 s at 0.1 s: three cycles. D 0.3 s: from the fourth.
  EXPECT_EQ(trace, "110 010 010 001 001 001 ");
}

// The charts of the stored/delayed qualifier tests: A is idle, B holds the
// action under test, C resets Q. GO takes A to B, STOP takes B back to A, RST
// takes A to C, and C returns to A at once.
std::string qualifier_chart(const std::string& actions_of_b) {
  return chart("INPUT RST = ddi(p0, d0, c2, \"RST\")\nOUTPUT R1 = ddo(p0, d1, c1, \"R1\")\n"
               "INITIAL STEP A\nEND_STEP\nSTEP B\n" +
               actions_of_b +
               "END_STEP\nSTEP C\nR Q\nEND_STEP\n"
               "TRANSITION t1 FROM A TO B WHEN GO\nTRANSITION t2 FROM B TO A WHEN STOP\n"
               "TRANSITION t3 FROM A TO C WHEN RST\nTRANSITION t4 FROM C TO A WHEN TRUE\n");
}

// One cycle per entry of `inputs` (GO, STOP, RST as "100", ...); per cycle the
// active step and the outputs `outs`, e.g. "B1 A0 ".
std::string trace(Sfc& s, const std::vector<std::string>& inputs,
                  const std::vector<std::string>& outs = {"Q"}) {
  std::string t;
  for (const std::string& in : inputs) {
    s.set("GO", in[0] == '1');
    s.set("STOP", in[1] == '1');
    s.set("RST", in[2] == '1');
    s.step();
    for (const char* st : {"A", "B", "C"}) {
      if (s.active(st)) t += st;
    }
    for (const std::string& o : outs) t += std::to_string(static_cast<int>(s.out(o)));
    t += ' ';
  }
  return t;
}

// P1 pulses the cycle the step became active (as P), P0 the cycle it ended.
TEST(SfcRun, p1_and_p0_pulse_at_the_steps_rising_and_falling_edge) {
  Sfc s(qualifier_chart("P1 Q\nP0 R1\n"));
  ASSERT_TRUE(s.ok()) << s.result().diags.render("t", "");
  EXPECT_EQ(trace(s, {"000", "100", "000", "000", "010", "000", "100", "010", "000"}, {"Q", "R1"}),
            "A00 B10 B00 B00 A01 A00 B10 A01 A00 ");
}

// SD at 0.1 s, T = 0.3 s: stored in the cycle B becomes active, 1 three
// cycles later although B ended in between, until C's R; an R before the
// time is up means it never comes on.
TEST(SfcRun, sd_is_stored_then_delayed_and_outlives_its_step) {
  Sfc s(qualifier_chart("SD Q 0.3s\n"));
  ASSERT_TRUE(s.ok()) << s.result().diags.render("t", "");
  EXPECT_EQ(trace(s, {"000", "100", "010", "000", "000", "000", "001", "000"}),
            "A0 B0 A0 A0 A1 A1 C0 A0 ");
  // Again, reset one cycle before the delay ends.
  EXPECT_EQ(trace(s, {"100", "010", "001", "000", "000", "000"}), "B0 A0 C0 A0 A0 A0 ");
}

// DS: only if B is still active T after it became active is Q set, and then
// stored past B's end until R.
TEST(SfcRun, ds_stores_only_when_the_step_outlasts_the_delay) {
  Sfc s(qualifier_chart("DS Q 0.3s\n"));
  ASSERT_TRUE(s.ok()) << s.result().diags.render("t", "");
  EXPECT_EQ(trace(s, {"000", "100", "000", "010", "100", "000", "000", "000", "010", "000",
                      "001", "000"}),
            "A0 B0 B0 A0 B0 B0 B0 B1 A1 A1 C0 A0 ");
}

// SL: set when B becomes active and 1 for T (three cycles) even though B ends
// after one; B again without an R does not restart it (the latch is still
// set, its time spent); after C's R it runs again.
TEST(SfcRun, sl_is_stored_and_limited_in_time_until_reset) {
  Sfc s(qualifier_chart("SL Q 0.3s\n"));
  ASSERT_TRUE(s.ok()) << s.result().diags.render("t", "");
  EXPECT_EQ(trace(s, {"000", "100", "010", "000", "000", "000", "100", "010", "001", "000",
                      "100", "000", "000", "000"}),
            "A0 B1 A1 A1 A0 A0 B0 A0 C0 A0 B1 B1 B1 B0 ");
  // An R while it runs ends it at once.
  Sfc r(qualifier_chart("SL Q 0.3s\n"));
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(trace(r, {"000", "100", "010", "001", "000"}), "A0 B1 A1 C0 A0 ");
}

TEST(SfcRun, selection_divergence_takes_the_first_written_branch) {
  Sfc s(
      chart("INITIAL STEP A\nEND_STEP\nSTEP B\nEND_STEP\nSTEP C\nEND_STEP\n"
            "TRANSITION tb FROM A TO B WHEN GO\nTRANSITION tc FROM A TO C WHEN GO OR STOP\n"
            "TRANSITION bj FROM B TO A WHEN TRUE\nTRANSITION cj FROM C TO A WHEN TRUE\n"));
  ASSERT_TRUE(s.ok());
  s.set("GO", 1);
  s.set("STOP", 1);
  s.step(2);
  EXPECT_TRUE(s.active("B"));
  EXPECT_FALSE(s.active("C")) << "one token stays one token";
  s.step();
  EXPECT_TRUE(s.active("A"));
  s.set("GO", 0);
  s.step();
  EXPECT_TRUE(s.active("C"));
}

TEST(SfcRun, simultaneous_branches_split_and_join) {
  Sfc s(
      chart("INITIAL STEP A\nEND_STEP\nSTEP B1\nEND_STEP\nSTEP B2\nEND_STEP\nSTEP B3\nEND_STEP\n"
            "STEP W\nEND_STEP\n"
            "TRANSITION split FROM A TO (B1, B2) WHEN GO\n"
            "TRANSITION b FROM B2 TO B3 WHEN STOP\n"
            "TRANSITION join FROM (B1, B3) TO W WHEN TRUE\n"
            "TRANSITION back FROM W TO A WHEN NOT GO\n"));
  ASSERT_TRUE(s.ok());
  s.set("GO", 1);
  s.step(2);
  EXPECT_TRUE(s.active("B1"));
  EXPECT_TRUE(s.active("B2"));
  s.step(3);
  EXPECT_TRUE(s.active("B1")) << "the join waits for every branch";
  s.set("STOP", 1);
  s.step();
  EXPECT_TRUE(s.active("B3"));
  s.step();
  EXPECT_TRUE(s.active("W"));
  EXPECT_FALSE(s.active("B1"));
  EXPECT_FALSE(s.active("B3"));
}

TEST(SfcRun, signals_are_fbd_blocks_over_inputs_and_step_flags) {
  Sfc s(chart(
      "SIGNAL both = and(GO, STOP)\nSIGNAL waited = time(A.X, 0.2)\n"
      "INITIAL STEP A\nEND_STEP\nSTEP B\nN Q\nEND_STEP\n"
      "TRANSITION t1 FROM A TO B WHEN waited AND NOT both\nTRANSITION t2 FROM B TO A WHEN both\n"));
  ASSERT_TRUE(s.ok());
  s.step(3);
  EXPECT_TRUE(s.active("A"));
  s.step(2);
  EXPECT_TRUE(s.active("B"));
  s.set("GO", 1);
  s.set("STOP", 1);
  s.step(2);
  EXPECT_TRUE(s.active("A"));
}

TEST(SfcRun, two_initial_steps_start_together) {
  Sfc s(
      chart("INITIAL STEP A\nN Q\nEND_STEP\nINITIAL STEP B\nEND_STEP\nSTEP C\nEND_STEP\n"
            "TRANSITION j FROM (A, B) TO C WHEN GO\nTRANSITION k FROM C TO (A, B) WHEN NOT GO\n"));
  ASSERT_TRUE(s.ok());
  s.step();
  EXPECT_TRUE(s.active("A"));
  EXPECT_TRUE(s.active("B"));
  s.set("GO", 1);
  s.step();
  EXPECT_TRUE(s.active("C"));
  s.step(5);
  EXPECT_TRUE(s.active("C")) << "initial steps are activated in the first cycle only";
}

// ---- diagnostics ----

std::string diags(const std::string& src, bool* ok) {
  return testing::diagnostics_of(src, ok);
}

TEST(SfcDiagnostics, several_errors_in_one_run_each_with_line_col_and_caret) {
  bool ok = true;
  const std::string out = diags(chart("INITIAL STEP A\nN Qq\nX Q\nEND_STEP\n"
                                      "TRANSITION t1 FROM A TO Bb WHEN GOO\n"),
                                &ok);
  EXPECT_FALSE(ok);
  EXPECT_NE(out.find("t.fbd:7:3: error: unknown output 'Qq'; did you mean 'Q'?"), std::string::npos)
      << out;
  EXPECT_NE(out.find("t.fbd:8:1: error: expected an action qualifier"), std::string::npos) << out;
  EXPECT_NE(out.find("t.fbd:10:25: error: unknown step 'Bb'"), std::string::npos) << out;
  EXPECT_NE(out.find("unknown signal 'GOO'; did you mean 'GO'?"), std::string::npos) << out;
  EXPECT_NE(out.find(" 8 | X Q\n   | ^\n"), std::string::npos) << out;
}

TEST(SfcDiagnostics, rules_of_steps_actions_and_conditions) {
  struct Case {
    std::string body;
    std::string message;
  } cases[] = {
      {"STEP A\nEND_STEP\nTRANSITION t FROM A TO A WHEN GO\n", "no step is INITIAL"},
      {"INITIAL STEP A\nL Q\nEND_STEP\n", "qualifier L needs a time"},
      {"INITIAL STEP A\nN Q 5s\nEND_STEP\n", "qualifier N takes no time"},
      {"INITIAL STEP A\nSD Q\nEND_STEP\n", "qualifier SD needs a time"},
      {"INITIAL STEP A\nDS Q\nEND_STEP\n", "qualifier DS needs a time"},
      {"INITIAL STEP A\nSL Q\nEND_STEP\n", "qualifier SL needs a time"},
      {"INITIAL STEP A\nP1 Q 1s\nEND_STEP\n", "qualifier P1 takes no time"},
      {"INITIAL STEP A\nDL Q 1s\nEND_STEP\n", "expected an action qualifier (N, S, R, P, P1"},
      {"INITIAL STEP A\nN GO\nEND_STEP\n", "action target 'GO' is not an OUTPUT"},
      {"INITIAL STEP A\nEND_STEP\nSTEP A\nEND_STEP\n", "step 'A' is already defined as step"},
      {"SIGNAL lv = dai(p0, d0, c5)\nINITIAL STEP A\nEND_STEP\nTRANSITION t FROM A TO A WHEN lv\n",
       "a condition needs a digital signal, but lv is analog"},
      {"INITIAL STEP A\nEND_STEP\nTRANSITION t FROM A TO A WHEN A\n",
       "a step's active flag is written A.X"},
      {"INPUT X = and(GO, STOP)\nINITIAL STEP A\nEND_STEP\n",
       "INPUT takes an input or set-point block"},
      {"INITIAL STEP A\nEND_STEP\nTRANSITION t FROM A TO A WHEN GO AND\n", "expected a condition"},
      {"INITIAL STEP A\nEND_STEP\nTRANSITION t FROM A TO A\n", "expected WHEN"},
      {"INITIAL STEP A\n", "step A is not closed"},
      {"SIGNAL s = tme(GO, 1)\nINITIAL STEP A\nEND_STEP\n", "unknown block 'tme'"},
      {"SIGNAL s = time(GO, -1)\nINITIAL STEP A\nEND_STEP\n", "parameter 'T'"},
  };
  for (const Case& c : cases) {
    bool ok = true;
    const std::string out = diags(chart(c.body), &ok);
    EXPECT_FALSE(ok) << c.body;
    EXPECT_NE(out.find(c.message), std::string::npos) << c.body << "\n" << out;
  }
}

TEST(SfcDiagnostics, a_missing_header_is_reported_for_an_sfc_file) {
  lang::CompileResult r = lang::compile_file(RTPLC_SOURCE_DIR "/tests/sfc/data/no_header.sfc");
  EXPECT_FALSE(r.ok());
  ASSERT_FALSE(r.diags.items().empty());
  EXPECT_NE(r.diags.items()[0].message.find("starts with 'SFC name'"), std::string::npos);
}

TEST(SfcDiagnostics, warnings_for_unreachable_and_final_steps) {
  bool ok = false;
  const std::string out =
      diags(chart("INITIAL STEP A\nN Q\nEND_STEP\nSTEP B\nEND_STEP\nSTEP C\nEND_STEP\n"
                  "TRANSITION t FROM A TO B WHEN GO\n"),
            &ok);
  EXPECT_TRUE(ok) << out;
  EXPECT_NE(out.find("step C is not initial and no transition leads to it"), std::string::npos)
      << out;
  EXPECT_NE(out.find("no transition leaves step B"), std::string::npos) << out;
}

TEST(SfcRun, an_internal_flag_carries_state_between_steps_and_into_conditions) {
  Sfc s(
      chart("OUTPUT F\nINITIAL STEP A\nN Q\nS F\nEND_STEP\nSTEP B\nR F\nEND_STEP\n"
            "TRANSITION t1 FROM A TO B WHEN F AND GO\nTRANSITION t2 FROM B TO A WHEN NOT F AND NOT "
            "GO\n"));
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s.result().diags.warning_count(), 0u) << s.result().diags.render("t", "");
  s.set("GO", 1);
  s.step();
  EXPECT_EQ(s.value("out.F"), 1);
  s.step();
  EXPECT_TRUE(s.active("B"));
  EXPECT_EQ(s.value("out.F"), 0);
  s.set("GO", 0);
  s.step(2);
  EXPECT_TRUE(s.active("A"));
}

TEST(SfcDiagnostics, an_unread_signal_and_an_undriven_output_are_warnings) {
  bool ok = false;
  const std::string out = diags(chart("SIGNAL idle = not(GO)\nINITIAL STEP A\nEND_STEP\n"
                                      "TRANSITION t FROM A TO A WHEN STOP\n"),
                                &ok);
  EXPECT_TRUE(ok) << out;
  EXPECT_NE(out.find("idle (not) is computed but never used"), std::string::npos) << out;
  EXPECT_NE(out.find("no action drives output Q"), std::string::npos) << out;
}

TEST(SfcDiagnostics, a_stored_qualifier_without_a_reset_is_a_warning) {
  bool ok = false;
  const std::string out = diags(chart("INITIAL STEP A\nSL Q 1s\nEND_STEP\n"
                                      "TRANSITION t FROM A TO A WHEN STOP\n"),
                                &ok);
  EXPECT_TRUE(ok) << out;
  EXPECT_NE(out.find("t.fbd:7:1: warning: qualifier SL stores Q until an 'R Q', and no step has one"),
            std::string::npos)
      << out;
  const std::string with_reset = diags(qualifier_chart("SL Q 1s\n"), &ok);
  EXPECT_EQ(with_reset.find("never resets"), std::string::npos) << with_reset;
}

TEST(SfcFrontEnd, the_same_chart_compiles_to_the_same_image) {
  const std::string src = read(RTPLC_SOURCE_DIR "/examples/tank.sfc");
  lang::CompileResult a = lang::compile_source(src), b = lang::compile_source(src);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a.image->bytes().size(), b.image->bytes().size());
  EXPECT_TRUE(
      std::equal(a.image->bytes().begin(), a.image->bytes().end(), b.image->bytes().begin()));
}

// The hook the PLCopen importer uses (builder.h, HostLink): a chart built into
// another front end's program. Steps A -> B on the host's condition `$go`; B
// drives the output `$Q`.
lang::sfc::Chart hosted_chart() {
  using namespace lang::sfc;
  Chart c;
  c.name = "p";
  Signal cond;
  cond.role = Signal::Role::kHost;
  cond.name = "$go";
  Signal out;
  out.role = Signal::Role::kOutput;
  out.name = "$Q";
  c.signals = {cond, out};
  Step a, b;
  a.name = "A";
  a.initial = true;
  b.name = "B";
  Action n;
  n.qualifier = "N";
  n.target = "$Q";
  b.actions.push_back(n);
  c.steps = {a, b};
  Transition t;
  t.name = "$t1";
  t.from = {NameRef{"A", {}}};
  t.to = {NameRef{"B", {}}};
  t.condition.op = Expr::Op::kName;
  t.condition.name = "$go";
  c.transitions = {t};
  return c;
}

// hosted_chart() built through `host`; `d` gets the diagnostics.
lang::CheckedProgram build_hosted(const lang::sfc::HostLink& host, DiagnosticList& d) {
  const lang::sfc::Chart c = hosted_chart();
  const lang::sfc::ChartIndex ix = lang::sfc::check_chart(c, d);
  EXPECT_FALSE(d.has_errors());
  return lang::sfc::build_flat_program(c, ix, d, &host);
}

TEST(SfcHost, a_hosted_chart_reads_host_blocks_and_names_its_own_under_the_prefix) {
  using namespace lang::sfc;
  HostLink host;
  host.prefix = "main.$sfc.";
  host.first_index = 7;
  std::vector<std::string> asked;
  host.resolve = [&](const std::string& name) -> std::optional<uint32_t> {
    asked.push_back(name);
    if (name == "$go") return 3;
    return std::nullopt;
  };
  DiagnosticList d;
  const lang::CheckedProgram p = build_hosted(host, d);
  ASSERT_FALSE(d.has_errors());
  EXPECT_EQ(asked, std::vector<std::string>{"$go"});
  bool reads_host = false, has_flag = false, has_action = false;
  for (const lang::FlatBlock& blk : p.blocks) {
    EXPECT_NE(blk.written, "ddo") << "a hosted chart's step flags get no channel";
    if (!blk.name.empty()) {
      EXPECT_EQ(blk.name.rfind(host.prefix, 0), 0u) << blk.name;
    }
    has_flag = has_flag || blk.name == step_flag_block(host, "B");
    has_action = has_action || blk.name == action_flag_block(host, "$Q");
    for (uint32_t k = 0; k < blk.n_in; ++k) {
      EXPECT_TRUE(blk.in[k] == 3 || (blk.in[k] >= 7 && blk.in[k] < 7 + p.blocks.size()));
      if (blk.name == "main.$sfc.tr.$t1" && blk.in[k] == 3) reads_host = true;
    }
  }
  EXPECT_TRUE(reads_host);
  EXPECT_TRUE(has_flag);
  EXPECT_TRUE(has_action);
}

TEST(SfcHost, a_host_name_the_resolver_does_not_know_is_reported) {
  lang::sfc::HostLink host;
  host.resolve = [](const std::string&) -> std::optional<uint32_t> { return std::nullopt; };
  DiagnosticList d;
  build_hosted(host, d);
  EXPECT_TRUE(d.has_errors());
}

}  // namespace
}  // namespace rtplc
