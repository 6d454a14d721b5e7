// Standard function blocks that are not called every cycle (docs/plcopen.md,
// "Calls that do not run every cycle"): under IF, CASE, a conditional IL CAL,
// EN, and in an event task. An FB that is not called keeps its state and
// shows its last call's outputs; a timer's elapsed time runs on meanwhile
// (MatIEC's and CODESYS's TON compare the current time with the time IN rose).
#include <gtest/gtest.h>

#include <string>

#include "lang/compiler.h"
#include "tests/plcopen/plcopen_harness.h"

namespace rtplc::lang {
namespace {

std::string task(const std::string& attrs, const std::string& globals = "") {
  return "<instances><configurations><configuration name=\"c\"><resource name=\"r\">" + globals +
         "<task name=\"t\" priority=\"1\" " + attrs +
         "><pouInstance name=\"main\" typeName=\"main\"/></task></resource></configuration></configurations></instances>\n";
}
const std::string kEvery10ms = task("interval=\"T#10ms\"");

CompileResult compile_ok(const std::string& src) {
  CompileResult r = compile_source(src);
  EXPECT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  return r;
}

// TON under IF, beside a reference TON called every cycle with the same IN.
TEST(PlcopenConditional, a_timer_under_if_holds_its_outputs_while_not_called) {
  const std::string src = project(
      kNs201,
      st_program("<inputVars>" + var("go", "BOOL", "%IX0.0") + var("x", "BOOL", "%IX0.1") + "</inputVars><localVars>" +
                     fb("t", "TON") + fb("ref", "TON") + var("q", "BOOL") + var("et", "TIME") + "</localVars>",
                 "IF go THEN t(IN := x, PT := T#100ms); END_IF;\nq := t.Q; et := t.ET;\nref(IN := x, PT := T#100ms);"),
      kEvery10ms);
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  Machine m(std::move(*r.image));
  m.set("go", 1);
  m.set("x", 1);
  for (int i = 0; i < 5; ++i) {  // called every cycle: the same as the reference
    m.cycles(1);
    EXPECT_EQ(m.value("main.q"), m.value("main.ref.Q"));
    EXPECT_DOUBLE_EQ(m.value("main.et"), m.value("main.ref.ET"));
  }
  const double et_at_last_call = m.value("main.et");
  EXPECT_GT(et_at_last_call, 0);
  EXPECT_EQ(m.value("main.q"), 0);
  m.set("go", 0);  // not called: Q and ET stay as they were
  m.cycles(12);
  EXPECT_EQ(m.value("main.ref.Q"), 1);
  EXPECT_EQ(m.value("main.q"), 0);
  EXPECT_DOUBLE_EQ(m.value("main.et"), et_at_last_call);
  m.set("go", 1);  // called again: the time since IN rose counts
  m.cycles(1);
  EXPECT_EQ(m.value("main.q"), 1);
  EXPECT_DOUBLE_EQ(m.value("main.et"), 0.1);
  m.set("go", 0);
  m.set("x", 0);  // a fall nobody calls the timer with is not seen
  m.cycles(3);
  EXPECT_EQ(m.value("main.ref.Q"), 0);
  EXPECT_EQ(m.value("main.q"), 1);
  m.set("go", 1);
  m.cycles(1);
  EXPECT_EQ(m.value("main.q"), 0);
  EXPECT_DOUBLE_EQ(m.value("main.et"), 0);
}

// CTU under IF and by CALC in IL: its CU edge is taken between calls, as
// R_TRIG's memory holds the CU of the last call.
TEST(PlcopenConditional, a_counter_called_conditionally_counts_edges_between_its_calls) {
  const std::string vars = "<inputVars>" + var("go", "BOOL", "%IX0.0") + var("pulse", "BOOL", "%IX0.1") +
                           "</inputVars><localVars>" + fb("c", "CTU") + var("cv", "INT") + var("q", "BOOL") +
                           "</localVars>";
  const std::string st =
      project(kNs201, st_program(vars, "IF go THEN c(CU := pulse, PV := 3); END_IF;\ncv := c.CV; q := c.Q;"), kEvery10ms);
  const std::string il = project(
      kNs201,
      "<pou name=\"main\" pouType=\"program\"><interface>" + vars +
          "</interface><body><IL><xhtml:p><![CDATA[LD go\nCALC c(CU := pulse, PV := 3)\nLD c.CV\nST cv\nLD c.Q\nST q\n]]></xhtml:p></IL></body></pou>\n",
      kEvery10ms);
  for (const std::string* src : {&st, &il}) {
    CompileResult r = compile_ok(*src);
    ASSERT_TRUE(r.ok());
    Machine m(std::move(*r.image));
    m.set("go", 1);
    for (int i = 0; i < 2; ++i) {
      m.set("pulse", 1);
      m.cycles(1);
      m.set("pulse", 0);
      m.cycles(1);
    }
    EXPECT_EQ(m.value("main.cv"), 2);
    m.set("go", 0);  // edges while not called are not counted
    for (int i = 0; i < 3; ++i) {
      m.set("pulse", 1);
      m.cycles(1);
      m.set("pulse", 0);
      m.cycles(1);
    }
    EXPECT_EQ(m.value("main.cv"), 2);
    m.set("pulse", 1);  // CU was FALSE at the last call and is TRUE now: one edge
    m.cycles(2);
    EXPECT_EQ(m.value("main.cv"), 2);
    m.set("go", 1);
    m.cycles(1);
    EXPECT_EQ(m.value("main.cv"), 3);
    EXPECT_EQ(m.value("main.q"), 1);
    m.cycles(3);
    EXPECT_EQ(m.value("main.cv"), 3);
  }
}

// R_TRIG's Q is an output variable: it keeps the last call's TRUE until the next call.
TEST(PlcopenConditional, an_edge_detector_in_a_case_branch_keeps_q_until_called_again) {
  const std::string src = project(
      kNs201,
      st_program("<inputVars>" + var("mode", "INT", "%IW0") + var("x", "BOOL", "%IX0.1") + "</inputVars><localVars>" +
                     fb("e", "R_TRIG") + var("q", "BOOL") + "</localVars>",
                 "CASE mode OF\n  1: e(CLK := x);\n  2: q := FALSE;\nEND_CASE;\nq := e.Q;"),
      kEvery10ms);
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  Machine m(std::move(*r.image));
  m.set("mode", 1);
  m.cycles(1);
  m.set("x", 1);
  m.cycles(1);
  EXPECT_EQ(m.value("main.q"), 1);
  m.set("mode", 2);
  m.cycles(3);
  EXPECT_EQ(m.value("main.q"), 1);  // not called: Q held
  m.set("mode", 1);
  m.cycles(1);
  EXPECT_EQ(m.value("main.q"), 0);  // CLK was already TRUE at the last call
}

// EN on a standard FB in FBD, and on a user FB in LD: EN false means not called.
TEST(PlcopenConditional, en_on_a_function_block_calls_it_only_while_en_holds) {
  const std::string pos = "<position x=\"0\" y=\"0\"/>";
  auto in = [&](int id, const char* expr) {
    return "<inVariable localId=\"" + std::to_string(id) + "\">" + pos + "<connectionPointOut/><expression>" + expr +
           "</expression></inVariable>";
  };
  auto out = [&](int id, int from, const char* formal, const char* expr) {
    return "<outVariable localId=\"" + std::to_string(id) + "\">" + pos + "<connectionPointIn><connection refLocalId=\"" +
           std::to_string(from) + "\" formalParameter=\"" + formal + "\"/></connectionPointIn><expression>" + expr +
           "</expression></outVariable>";
  };
  auto arg = [](const char* formal, int from) {
    return std::string("<variable formalParameter=\"") + formal + "\"><connectionPointIn><connection refLocalId=\"" +
           std::to_string(from) + "\"/></connectionPointIn></variable>";
  };
  const std::string src = project(
      kNs201,
      "<pou name=\"main\" pouType=\"program\"><interface><inputVars>" + var("en", "BOOL", "%IX0.0") +
          var("pulse", "BOOL", "%IX0.1") + "</inputVars><localVars>" + fb("c", "CTU") + var("cv", "INT") +
          var("eno", "BOOL") + "</localVars></interface><body><FBD>" + in(1, "en") + in(2, "pulse") + in(3, "10") +
          "<block localId=\"4\" typeName=\"CTU\" instanceName=\"c\">" + pos + "<inputVariables>" + arg("EN", 1) +
          arg("CU", 2) + arg("PV", 3) +
          "</inputVariables><inOutVariables/><outputVariables>"
          "<variable formalParameter=\"ENO\"><connectionPointOut/></variable>"
          "<variable formalParameter=\"Q\"><connectionPointOut/></variable>"
          "<variable formalParameter=\"CV\"><connectionPointOut/></variable></outputVariables></block>" +
          out(5, 4, "CV", "cv") + out(6, 4, "ENO", "eno") + "</FBD></body></pou>\n",
      kEvery10ms);
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  Machine m(std::move(*r.image));
  auto pulse = [&](int n) {
    for (int i = 0; i < n; ++i) {
      m.set("pulse", 1);
      m.cycles(1);
      m.set("pulse", 0);
      m.cycles(1);
    }
  };
  m.set("en", 1);
  pulse(3);
  EXPECT_EQ(m.value("main.cv"), 3);
  EXPECT_EQ(m.value("main.eno"), 1);
  m.set("en", 0);
  pulse(4);
  EXPECT_EQ(m.value("main.cv"), 3);
  EXPECT_EQ(m.value("main.eno"), 0);
  m.set("en", 1);
  pulse(1);
  EXPECT_EQ(m.value("main.cv"), 4);
}

TEST(PlcopenConditional, a_user_fb_with_en_false_keeps_its_variables) {
  const std::string pos = "<position x=\"0\" y=\"0\"/>";
  const std::string count =
      "<pou name=\"Count\" pouType=\"functionBlock\"><interface><inputVars>" + var("step", "INT", "", "1") +
      "</inputVars><outputVars>" + var("n", "INT") +
      "</outputVars></interface><body><ST><xhtml:p><![CDATA[n := n + step;]]></xhtml:p></ST></body></pou>\n";
  const std::string src = project(
      kNs201,
      count + "<pou name=\"main\" pouType=\"program\"><interface><inputVars>" + var("run", "BOOL", "%IX0.0") +
          "</inputVars><localVars>" + fb("k", "Count") + var("n", "INT") + "</localVars></interface><body><LD>"
          "<leftPowerRail localId=\"1\">" + pos + "<connectionPointOut formalParameter=\"\"/></leftPowerRail>"
          "<contact localId=\"2\" negated=\"false\" edge=\"none\">" + pos +
          "<connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn><connectionPointOut/><variable>run</variable></contact>"
          "<block localId=\"3\" typeName=\"Count\" instanceName=\"k\">" + pos + "<inputVariables>"
          "<variable formalParameter=\"EN\"><connectionPointIn><connection refLocalId=\"2\"/></connectionPointIn></variable>"
          "</inputVariables><inOutVariables/><outputVariables>"
          "<variable formalParameter=\"ENO\"><connectionPointOut/></variable>"
          "<variable formalParameter=\"n\"><connectionPointOut/></variable></outputVariables></block>"
          "<outVariable localId=\"4\">" + pos + "<connectionPointIn><connection refLocalId=\"3\" formalParameter=\"n\"/></connectionPointIn><expression>n</expression></outVariable>"
          "</LD></body></pou>\n",
      kEvery10ms);
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  Machine m(std::move(*r.image));
  m.cycles(3);
  EXPECT_EQ(m.value("main.n"), 0);
  m.set("run", 1);
  m.cycles(4);
  EXPECT_EQ(m.value("main.n"), 4);
  m.set("run", 0);
  m.cycles(4);
  EXPECT_EQ(m.value("main.n"), 4);
  m.set("run", 1);
  m.cycles(1);
  EXPECT_EQ(m.value("main.n"), 5);
}

// A task with single="trig": the body runs once per rising edge of trig,
// checked every period, and everything it writes holds in between.
TEST(PlcopenConditional, an_event_task_runs_its_program_on_each_rising_edge) {
  const std::string globals = "<globalVars>" + var("trig", "BOOL", "%IX0.0") + "</globalVars>";
  const std::string src = project(
      kNs201,
      st_program("<inputVars>" + var("x", "BOOL", "%IX0.1") + "</inputVars><localVars>" + var("n", "INT") +
                     fb("e", "R_TRIG") + var("seen", "INT") + "</localVars>",
                 "n := n + 1;\ne(CLK := x);\nIF e.Q THEN seen := seen + 1; END_IF;"),
      task("single=\"trig\"", globals));
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  bool noted = false;
  for (const std::string& n : r.program.notes) noted = noted || n.find("event task") != std::string::npos;
  EXPECT_TRUE(noted);
  Machine m(std::move(*r.image));
  m.cycles(5);
  EXPECT_EQ(m.value("main.n"), 0);
  for (int k = 1; k <= 3; ++k) {
    m.set("trig", 1);
    m.cycles(4);  // held high: one run
    EXPECT_EQ(m.value("main.n"), k);
    m.set("trig", 0);
    m.cycles(2);
    EXPECT_EQ(m.value("main.n"), k);
  }
  m.set("x", 1);  // x rises between runs: the next run's R_TRIG sees it
  m.cycles(3);
  m.set("trig", 1);
  m.cycles(1);
  EXPECT_EQ(m.value("main.seen"), 1);
  EXPECT_EQ(m.value("main.n"), 4);
}

TEST(PlcopenConditional, an_event_task_needs_a_bool_trigger) {
  const std::string globals = "<globalVars>" + var("level", "INT", "%IW0") + "</globalVars>";
  const std::string src =
      project(kNs201, st_program("<localVars>" + var("n", "INT") + "</localVars>", "n := n + 1;"),
              task("single=\"level\"", globals));
  CompileResult r = compile_source(src);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.diags.items()[0].message.find("single=\"level\" names a variable that is not BOOL"), std::string::npos)
      << r.diags.items()[0].message;
  EXPECT_GT(r.diags.items()[0].pos.line, 0u);
}

// An SFC's steps move every cycle: an FB with an SFC body called under IF is refused.
// A chart called only in some cycles evolves only in those (its behaviour:
// tests/st/test_st_sfc.cpp, a_chart_called_under_if_holds_its_steps_between_calls).
TEST(PlcopenConditional, an_sfc_function_block_called_under_if_compiles) {
  const std::string chart =
      "<pou name=\"Seq\" pouType=\"functionBlock\"><interface><inputVars>" + var("go", "BOOL") +
      "</inputVars></interface><body><SFC>"
      "<step localId=\"1\" name=\"A\" initialStep=\"true\"><position x=\"0\" y=\"0\"/><connectionPointIn/><connectionPointOut formalParameter=\"\"/></step>"
      "</SFC></body></pou>\n";
  const std::string src = project(
      kNs201, chart + st_program("<inputVars>" + var("x", "BOOL", "%IX0.0") + "</inputVars><localVars>" + fb("s", "Seq") +
                                     "</localVars>",
                                 "IF x THEN s(go := TRUE); END_IF;"),
      kEvery10ms);
  CompileResult r = compile_source(src);
  EXPECT_TRUE(r.ok()) << r.diags.render("p.xml", src);
}


// RETURN ends the body for this cycle: what follows runs under NOT the
// condition that it ran, a standard FB there included.
TEST(PlcopenConditional, return_skips_the_rest_of_the_body) {
  const std::string src = project(
      kNs201,
      st_program("<inputVars>" + var("x", "BOOL", "%IX0.0") + "</inputVars><localVars>" + var("a", "INT") +
                     var("b", "INT") + var("c", "INT") + fb("t", "TON") + var("q", "BOOL") + "</localVars>",
                 "a := 1;\nIF x THEN b := b + 1; RETURN; END_IF;\na := 2; c := c + 1;\n"
                 "t(IN := TRUE, PT := T#50ms); q := t.Q;"),
      kEvery10ms);
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  Machine m(std::move(*r.image));
  m.set("x", 1);
  m.cycles(10);
  EXPECT_EQ(m.value("main.a"), 1);
  EXPECT_EQ(m.value("main.b"), 10);
  EXPECT_EQ(m.value("main.c"), 0);
  EXPECT_EQ(m.value("main.q"), 0);  // the timer was never called
  m.set("x", 0);
  m.cycles(3);
  EXPECT_EQ(m.value("main.a"), 2);
  EXPECT_EQ(m.value("main.b"), 10);
  EXPECT_EQ(m.value("main.c"), 3);
  EXPECT_EQ(m.value("main.q"), 0);  // timing since its first call
  m.cycles(5);
  EXPECT_EQ(m.value("main.q"), 1);
}

TEST(PlcopenConditional, return_in_a_function_gives_the_result_so_far) {
  const std::string fn =
      "<pou name=\"Sat\" pouType=\"function\"><interface><returnType><INT/></returnType><inputVars>" +
      var("v", "INT") +
      "</inputVars></interface><body><ST><xhtml:p><![CDATA[Sat := v;\nIF v > 10 THEN Sat := 10; RETURN; END_IF;\n"
      "Sat := Sat * 2;]]></xhtml:p></ST></body></pou>\n";
  const std::string src = project(
      kNs201, fn + st_program("<inputVars>" + var("v", "INT", "%IW0") + "</inputVars><localVars>" + var("y", "INT") +
                                  "</localVars>",
                              "y := Sat(v);"),
      kEvery10ms);
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  Machine m(std::move(*r.image));
  for (const auto& [v, y] : {std::pair{3, 6}, {20, 10}, {10, 20}, {-4, -8}}) {
    m.set("v", v);
    m.cycles(1);
    EXPECT_EQ(m.value("main.y"), y) << "v = " << v;
  }
}

TEST(PlcopenConditional, exit_and_continue_in_an_unrolled_for) {
  const std::string src = project(
      kNs201,
      st_program("<inputVars>" + var("limit", "INT", "%IW0") + var("k", "INT", "%IW1") + "</inputVars><localVars>" +
                     var("i", "INT") + var("j", "INT") + var("found", "INT") + var("sum", "INT") + "</localVars>",
                 "found := 0;\nFOR i := 1 TO 10 DO\n  IF i * i > limit THEN found := i; EXIT; END_IF;\nEND_FOR;\n"
                 "sum := 0;\nFOR j := 1 TO 10 DO\n  IF j MOD k = 0 THEN CONTINUE; END_IF;\n  sum := sum + j;\nEND_FOR;"),
      kEvery10ms);
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  Machine m(std::move(*r.image));
  for (const auto& [limit, found] : {std::pair{20, 5}, {50, 8}, {0, 1}, {200, 0}}) {
    m.set("limit", limit);
    m.set("k", 3);
    m.cycles(1);
    EXPECT_EQ(m.value("main.found"), found) << "limit " << limit;
    if (found > 0) {
      EXPECT_EQ(m.value("main.i"), found) << "the loop variable stays where EXIT left";
    }
    EXPECT_EQ(m.value("main.sum"), 55 - 3 - 6 - 9);
  }
  m.set("k", 5);
  m.cycles(1);
  EXPECT_EQ(m.value("main.sum"), 55 - 5 - 10);
}

TEST(PlcopenConditional, refuses_exit_outside_a_loop_and_a_jump_to_no_label_in_st) {
  for (const auto& [body, msg] : {std::pair<std::string, std::string>{"x := 1;\nEXIT;", "EXIT outside a loop"},
                                  {"x := 1;\nJMP l1;", "no label 'L1'"}}) {
    const std::string src = project(kNs201, st_program("<localVars>" + var("x", "INT") + "</localVars>", body));
    CompileResult r = compile_source(src);
    ASSERT_FALSE(r.ok()) << body;
    EXPECT_NE(r.diags.items()[0].message.find(msg), std::string::npos) << r.diags.items()[0].message;
    EXPECT_GT(r.diags.items()[0].pos.line, 0u);
  }
}

// One instance called in exclusive branches of an IF or CASE runs once, at
// the END_IF, on the inputs of the branch taken.
TEST(PlcopenConditional, an_instance_called_in_both_branches_runs_on_the_branch_taken) {
  const std::string src = project(
      kNs201,
      st_program("<inputVars>" + var("c", "BOOL", "%IX0.0") + var("mode", "INT", "%IW0") + var("p", "BOOL", "%IX0.1") +
                     "</inputVars><localVars>" + fb("t", "TON") + fb("ref", "TON") + fb("k", "CTU") + var("q", "BOOL") +
                     var("cv", "INT") + "</localVars>",
                 "IF c THEN\n  t(IN := TRUE, PT := T#50ms);\nELSE\n  t(IN := FALSE, PT := T#50ms);\nEND_IF;\n"
                 "q := t.Q;\nref(IN := c, PT := T#50ms);\n"
                 "CASE mode OF\n  1: k(CU := p, PV := 100);\n  2: k(CU := NOT p, PV := 100);\n  3: k(R := TRUE);\nEND_CASE;\n"
                 "cv := k.CV;"),
      kEvery10ms);
  CompileResult r = compile_ok(src);
  ASSERT_TRUE(r.ok());
  Machine m(std::move(*r.image));
  for (int i = 0; i < 30; ++i) {  // c on for 12 cycles, off for 4, ...
    m.set("c", i % 16 < 12);
    m.cycles(1);
    EXPECT_EQ(m.value("main.q"), m.value("main.ref.Q")) << "cycle " << i;
    EXPECT_DOUBLE_EQ(m.value("main.t.ET"), m.value("main.ref.ET")) << "cycle " << i;
  }
  m.set("mode", 1);
  for (int i = 0; i < 3; ++i) {  // three rising edges of p
    m.set("p", 1);
    m.cycles(1);
    m.set("p", 0);
    m.cycles(1);
  }
  EXPECT_EQ(m.value("main.cv"), 3);
  m.set("mode", 2);  // CU is NOT p: p is FALSE, so CU is TRUE at once, an edge from the last call's FALSE
  m.cycles(1);
  EXPECT_EQ(m.value("main.cv"), 4);
  m.set("mode", 0);  // not called
  m.set("p", 1);
  m.cycles(2);
  EXPECT_EQ(m.value("main.cv"), 4);
  m.set("mode", 3);  // R := TRUE; CU left out keeps its last value
  m.cycles(1);
  EXPECT_EQ(m.value("main.cv"), 0);
}

TEST(PlcopenConditional, refuses_reading_a_gathered_instance_after_a_nested_call_and_two_calls_in_a_row) {
  const std::string vars = "<inputVars>" + var("c", "BOOL", "%IX0.0") + var("d", "BOOL", "%IX0.1") +
                           "</inputVars><localVars>" + fb("t", "TON") + var("q", "BOOL") + "</localVars>";
  // Read after its own call in the branch: the IF is lowered in two passes
  // (tests/st/test_st_timers.cpp, the state machine). Called inside a nested IF, it cannot be.
  CompileResult read_after = compile_source(project(
      kNs201, st_program(vars, "IF c THEN t(IN := TRUE, PT := T#1s); q := t.Q; ELSE t(IN := FALSE); END_IF;")));
  EXPECT_TRUE(read_after.ok()) << read_after.diags.render("p.xml", "");
  CompileResult inside = compile_source(project(
      kNs201, st_program(vars, "IF c THEN IF d THEN t(IN := TRUE, PT := T#1s); END_IF; q := t.Q; "
                               "ELSE t(IN := FALSE); END_IF;")));
  ASSERT_FALSE(inside.ok());
  EXPECT_NE(inside.diags.items()[0].message.find("read it after the END_IF"), std::string::npos)
      << inside.diags.items()[0].message;
  CompileResult twice =
      compile_source(project(kNs201, st_program(vars, "t(IN := c, PT := T#1s);\nt(IN := NOT c, PT := T#1s);")));
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.diags.items()[0].message.find("is called twice in one cycle"), std::string::npos);
  EXPECT_GT(twice.diags.items()[0].pos.line, 0u);
}

}  // namespace
}  // namespace rtplc::lang
