// The PLCopen XML importer (docs/plcopen.md): projects written for these tests
// in the habits of OpenPLC Editor / Beremiz (tc6_0201, xhtml:p CDATA) and
// CODESYS (tc6_0200, xhtml element, positions 0,0), run cycle by cycle.
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>
#include <string>

#include "lang/compiler.h"
#include "lang/plcopen/sfc_chart.h"
#include "lang/sfc/semantics.h"
#include "sched/program.h"
#include "tests/plcopen/plcopen_harness.h"

namespace rtplc::lang {
namespace {

TEST(Plcopen, runs_the_openplc_style_fbd_project) {
  CompileResult r = compile_file(data("openplc_mixed.xml"));
  ASSERT_TRUE(r.ok()) << r.diags.render("openplc_mixed.xml", "");
  EXPECT_DOUBLE_EQ(r.image->period_s(), 0.02);  // the task's interval
  Machine run(std::move(*r.image));
  run.cycles(5);
  EXPECT_EQ(run.value("instance0.cycles"), 5);  // cycles := cycles + 1 through a feedback loop
  EXPECT_EQ(run.out("pump"), 0);
  run.set("level", 90);  // above the hysteresis FB's HI (its initial value 80)
  run.cycles(1);
  EXPECT_EQ(run.value("instance0.hys.Q"), 1);
  EXPECT_EQ(run.out("pump"), 0);  // TON 500 ms not elapsed
  run.cycles(30);                 // 0.6 s at 20 ms
  EXPECT_EQ(run.value("instance0.t1.Q"), 1);
  EXPECT_EQ(run.out("pump"), 1);
  EXPECT_DOUBLE_EQ(run.out("valve"), 75.5);
  run.set("start", 1);  // negated input of the AND
  run.cycles(1);
  EXPECT_EQ(run.out("pump"), 0);
  run.set("level", 50);  // between LO and HI: the FB keeps Q
  run.cycles(1);
  EXPECT_EQ(run.value("instance0.hys.Q"), 1);
  run.set("level", 10);
  run.cycles(1);
  EXPECT_EQ(run.value("instance0.hys.Q"), 0);
}

TEST(Plcopen, explains_the_feedback_loop) {
  CompileResult r = compile_file(data("openplc_mixed.xml"));
  ASSERT_TRUE(r.ok());
  const std::string e = explain(r);
  EXPECT_NE(e.find("feedback loop"), std::string::npos) << e;
  EXPECT_NE(e.find("CYCLES"), std::string::npos) << e;
}

// A loop drawn through blocks only (ADD feeding itself): the later reference
// reads last cycle's value, and --explain says where the loop was broken.
TEST(Plcopen, breaks_a_block_feedback_loop_and_reports_it) {
  const std::string src = project(
      "http://www.plcopen.org/xml/tc6_0200",
      "<pou name=\"p\" pouType=\"program\"><interface><localVars>" + var("x", "REAL") +
          "</localVars></interface><body><FBD>"
          "<block localId=\"1\" typeName=\"ADD\" executionOrderId=\"0\"><position x=\"0\" y=\"0\"/><inputVariables>"
          "<variable formalParameter=\"IN1\"><connectionPointIn><connection refLocalId=\"1\" formalParameter=\"OUT\"/></connectionPointIn></variable>"
          "<variable formalParameter=\"IN2\"><connectionPointIn><connection refLocalId=\"2\"/></connectionPointIn></variable>"
          "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"OUT\"><connectionPointOut/></variable></outputVariables>"
          "<addData><data name=\"vendor\" handleUnknown=\"discard\"/></addData></block>"
          "<inVariable localId=\"2\" executionOrderId=\"0\"><position x=\"0\" y=\"0\"/><connectionPointOut/><expression>0.5</expression></inVariable>"
          "<outVariable localId=\"3\" executionOrderId=\"0\"><position x=\"0\" y=\"0\"/><connectionPointIn><connection refLocalId=\"1\" formalParameter=\"OUT\"/></connectionPointIn><expression>x</expression></outVariable>"
          "</FBD></body></pou>");
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  const std::string e = explain(r);
  EXPECT_NE(e.find("feedback loop through localId 1 (block ADD)"), std::string::npos) << e;
  Machine run(std::move(*r.image));
  run.cycles(4);
  EXPECT_DOUBLE_EQ(run.value("p.x"), 2.0);
}

// connector/continuation, inOutVariable, a negated block output and a rising-edge input.
TEST(Plcopen, follows_connectors_in_out_variables_negation_and_edges) {
  const std::string pos = "<position x=\"0\" y=\"0\"/>";
  const std::string src = project(
      kNs201,
      "<pou name=\"main\" pouType=\"program\"><interface><inputVars>" + var("b", "BOOL", "%IX0.0") +
          "</inputVars><localVars>" + var("m", "BOOL") + var("nq", "BOOL") + var("pulses", "INT") +
          "</localVars></interface><body><FBD>"
          "<inVariable localId=\"1\">" + pos + "<connectionPointOut/><expression>b</expression></inVariable>"
          "<connector name=\"wire\" localId=\"2\">" + pos + "<connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn></connector>"
          "<continuation name=\"wire\" localId=\"3\">" + pos + "<connectionPointOut/></continuation>"
          "<inOutVariable localId=\"4\">" + pos + "<connectionPointIn><connection refLocalId=\"3\"/></connectionPointIn><connectionPointOut/><expression>m</expression></inOutVariable>"
          "<block localId=\"5\" typeName=\"AND\">" + pos + "<inputVariables>"
          "<variable formalParameter=\"IN1\"><connectionPointIn><connection refLocalId=\"4\"/></connectionPointIn></variable>"
          "<variable formalParameter=\"IN2\"><connectionPointIn><connection refLocalId=\"6\"/></connectionPointIn></variable>"
          "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"OUT\" negated=\"true\"><connectionPointOut/></variable></outputVariables></block>"
          "<inVariable localId=\"6\">" + pos + "<connectionPointOut/><expression>TRUE</expression></inVariable>"
          "<outVariable localId=\"7\">" + pos + "<connectionPointIn><connection refLocalId=\"5\" formalParameter=\"OUT\"/></connectionPointIn><expression>nq</expression></outVariable>"
          "<block localId=\"8\" typeName=\"ADD\">" + pos + "<inputVariables>"
          "<variable formalParameter=\"IN1\"><connectionPointIn><connection refLocalId=\"9\"/></connectionPointIn></variable>"
          "<variable formalParameter=\"IN2\"><connectionPointIn><connection refLocalId=\"10\"/></connectionPointIn></variable>"
          "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"OUT\"><connectionPointOut/></variable></outputVariables></block>"
          "<inVariable localId=\"9\">" + pos + "<connectionPointOut/><expression>pulses</expression></inVariable>"
          "<block localId=\"10\" typeName=\"BOOL_TO_INT\">" + pos + "<inputVariables>"
          "<variable formalParameter=\"IN\" edge=\"rising\"><connectionPointIn><connection refLocalId=\"3\"/></connectionPointIn></variable>"
          "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"OUT\"><connectionPointOut/></variable></outputVariables></block>"
          "<outVariable localId=\"11\">" + pos + "<connectionPointIn><connection refLocalId=\"8\"/></connectionPointIn><expression>pulses</expression></outVariable>"
          "</FBD></body></pou>");
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine run(std::move(*r.image));
  run.cycles(1);
  EXPECT_EQ(run.value("main.m"), 0);
  EXPECT_EQ(run.value("main.nq"), 1);  // NOT (m AND TRUE)
  for (int i = 0; i < 3; ++i) {
    run.set("b", 1);
    run.cycles(2);
    EXPECT_EQ(run.value("main.m"), 1);
    EXPECT_EQ(run.value("main.nq"), 0);
    run.set("b", 0);
    run.cycles(2);
  }
  EXPECT_EQ(run.value("main.pulses"), 3);  // one per rising edge of b, through the continuation
}

TEST(Plcopen, runs_a_codesys_ladder_latch) {
  CompileOptions o;
  o.entry = "Fast";
  CompileResult r = compile_file(data("codesys_ld_st.xml"), o);
  ASSERT_TRUE(r.ok()) << r.diags.render("codesys_ld_st.xml", "");
  EXPECT_DOUBLE_EQ(r.image->period_s(), 0.01);
  Machine run(std::move(*r.image));
  run.cycles(2);
  EXPECT_EQ(run.out("motor"), 0);
  run.set("start_btn", 1);
  run.cycles(1);
  EXPECT_EQ(run.out("motor"), 1);
  run.set("start_btn", 0);
  run.cycles(3);
  EXPECT_EQ(run.out("motor"), 1);  // seal-in contact on motor
  EXPECT_EQ(run.out("alarm"), 0);
  run.set("stop_btn", 1);
  run.cycles(1);
  EXPECT_EQ(run.out("motor"), 0);
  EXPECT_EQ(run.out("alarm"), 1);  // rising contact sets the alarm coil
  run.set("stop_btn", 0);
  run.cycles(3);
  EXPECT_EQ(run.out("alarm"), 1);  // set coil holds
  run.set("start_btn", 1);
  run.cycles(1);
  EXPECT_EQ(run.out("alarm"), 0);  // reset coil
}

TEST(Plcopen, runs_st_with_for_case_globals_and_fb_calls) {
  CompileOptions o;
  o.entry = "scale1";
  CompileResult r = compile_file(data("codesys_ld_st.xml"), o);
  ASSERT_TRUE(r.ok()) << r.diags.render("codesys_ld_st.xml", "");
  Machine run(std::move(*r.image));
  run.set("raw", 40);
  run.cycles(1);
  EXPECT_DOUBLE_EQ(run.out("out"), 80);  // 4 x 40 x 0.25 x g_gain 2
  run.set("raw", 0);
  run.cycles(1);
  EXPECT_DOUBLE_EQ(run.out("out"), 0);
  run.set("raw", 500);
  run.cycles(1);
  EXPECT_DOUBLE_EQ(run.out("out"), 100);  // CASE ELSE
  for (int i = 0; i < 3; ++i) {
    run.set("raw", 0);
    run.cycles(1);
    run.set("raw", 60);
    run.cycles(1);
  }
  EXPECT_EQ(run.value("scale1.n"), 3);  // the 500 edge and three more, stopped at PV = 3
  EXPECT_EQ(run.value("scale1.pulses.Q"), 1);
}

// IL with forward jumps, S/R, a parenthesised operand and CAL (legacy tc6.xsd namespace).
TEST(Plcopen, runs_il_with_forward_jumps) {
  CompileResult r = compile_file(data("legacy_il.xml"));
  ASSERT_TRUE(r.ok()) << r.diags.render("legacy_il.xml", "");
  Machine run(std::move(*r.image));
  run.set("a", 1);
  run.set("n", 21);
  run.cycles(1);
  EXPECT_EQ(run.out("q"), 1);
  EXPECT_EQ(run.out("m"), 42);  // the path that falls through JMPCN
  run.set("a", 0);
  run.cycles(1);
  EXPECT_EQ(run.out("q"), 0);
  EXPECT_EQ(run.out("m"), 7);  // the path through the label
  run.set("b", 1);
  run.cycles(1);
  EXPECT_EQ(run.value("main.lat"), 1);  // S
  run.set("a", 1);
  run.cycles(1);
  EXPECT_EQ(run.value("main.lat"), 0);  // R wins: a AND (b OR a)
  EXPECT_EQ(run.out("q"), 0);           // a ANDN b
  run.cycles(10);
  EXPECT_EQ(run.value("main.t1.Q"), 1);  // CAL t1 after the jumps joined: 1 s at 0.1 s
}

// IL backward jumps are loops (docs/plcopen.md, "IL"): values worked by hand.
std::string il_program(const std::string& vars, const std::string& il) {
  return project(kNs201, "<pou name=\"main\" pouType=\"program\"><interface>" + vars +
                             "</interface><body><IL><xhtml:p><![CDATA[" + il + "]]></xhtml:p></IL></body></pou>");
}

TEST(Plcopen, runs_an_il_backward_jump_as_a_loop) {
  CompileResult r = compile_source(il_program("<localVars>" + var("x", "INT") + "</localVars>",
                                              "top: LD x\n ADD 1\n ST x\n LT 10\n JMPC top\n"));
  ASSERT_TRUE(r.ok()) << r.diags.render("il.xml", "");
  Machine run(std::move(*r.image));
  run.cycles(1);  // counts up to 10 in the first cycle
  EXPECT_EQ(run.value("main.x"), 10);
  run.cycles(1);  // then once per cycle: the body runs before the test
  EXPECT_EQ(run.value("main.x"), 11);
  EXPECT_EQ(run.arena.loop_fault, 0u);
}

// A loop behind a forward jump: its head is reached on some paths only.
TEST(Plcopen, an_il_loop_skipped_by_a_forward_jump_runs_only_when_reached) {
  CompileResult r = compile_source(
      il_program("<inputVars>" + var("n", "INT", "%IW0") + "</inputVars><localVars>" + var("i", "INT") +
                     var("s", "INT") + "</localVars><outputVars>" + var("out", "INT", "%QW0") + "</outputVars>",
                 " LD n\n LE 0\n JMPC skip\n LD 0\n ST s\n ST i\ntop: LD i\n ADD 1\n ST i\n ADD s\n ST s\n"
                 " LD i\n LT n\n JMPC top\nskip: LD s\n ST out\n"));
  ASSERT_TRUE(r.ok()) << r.diags.render("il.xml", "");
  Machine run(std::move(*r.image));
  run.set("n", 4);  // 1 + 2 + 3 + 4
  run.cycles(1);
  EXPECT_EQ(run.out("out"), 10);
  EXPECT_EQ(run.value("main.i"), 4);
  run.set("n", 0);  // jumps over the loop: s keeps its value
  run.cycles(1);
  EXPECT_EQ(run.out("out"), 10);
  EXPECT_EQ(run.value("main.i"), 4);
  run.set("n", 3);
  run.cycles(1);
  EXPECT_EQ(run.out("out"), 6);
  EXPECT_EQ(run.arena.loop_fault, 0u);
}

TEST(Plcopen, an_il_loop_that_never_ends_is_cut_at_the_budget_at_its_jump) {
  CompileResult r = compile_source(il_program("<localVars>" + var("x", "DINT") + "</localVars>",
                                              "spin: LD x\n ADD 1\n ST x\n JMP spin\n"));
  ASSERT_TRUE(r.ok()) << r.diags.render("il.xml", "");
  Machine run(std::move(*r.image));
  run.arena.loop_budget = 500;
  run.cycles(1);
  ASSERT_NE(run.arena.loop_fault, 0u);
  EXPECT_EQ(run.img.blocks()[run.arena.loop_fault - 1].line, 8u);  // the JMP (the body starts at line 5)
}

// A counter CALled in an IL loop steps at each call (x = 0..5: CU = T F T F T F).
TEST(Plcopen, a_counter_called_in_an_il_loop_counts_each_call) {
  CompileResult r = compile_source(il_program("<localVars>" + var("x", "INT") + var("e", "BOOL") + fb("c", "CTU") +
                                                  var("cv", "INT") + "</localVars>",
                                              "top: LD x\n MOD 2\n EQ 0\n ST e\n CAL c(CU := e, PV := 100)\n"
                                              " LD x\n ADD 1\n ST x\n LT 6\n JMPC top\n LD c.CV\n ST cv\n"));
  ASSERT_TRUE(r.ok()) << r.diags.render("il.xml", "");
  Machine run(std::move(*r.image));
  run.cycles(1);
  EXPECT_EQ(run.value("main.x"), 6);
  EXPECT_EQ(run.value("main.cv"), 3);
  run.cycles(1);  // x = 6: once through, CU rises again
  EXPECT_EQ(run.value("main.cv"), 4);
  run.cycles(1);  // x = 7: CU falls
  EXPECT_EQ(run.value("main.cv"), 4);
}

// A timer CALled in an IL loop reads the cycle's time at every call: three
// calls per cycle, ET summed, 3 * ET.
TEST(Plcopen, a_timer_called_in_an_il_loop_reads_one_time_per_cycle) {
  CompileResult r = compile_source(il_program("<localVars>" + var("x", "INT") + fb("t", "TON") + var("s", "TIME") +
                                                  "</localVars>",
                                              "LD 0\n ST x\n LD T#0s\n ST s\ntop: CAL t(IN := TRUE, PT := T#1s)\n"
                                              " LD s\n ADD t.ET\n ST s\n LD x\n ADD 1\n ST x\n LT 3\n JMPC top\n"));
  ASSERT_TRUE(r.ok()) << r.diags.render("il.xml", "");
  Machine run(std::move(*r.image));
  run.cycles(3);  // the third cycle: ET = 2 dt at each call
  EXPECT_NEAR(run.value("main.s"), 3 * 2 * run.img.period_s(), 1e-12);
}

// SFC: steps, inline and named transitions, a simultaneous divergence and
// convergence, N/P/L/D actions on variables, a named ST action and an LD one.
TEST(Plcopen, runs_an_sfc_body) {
  CompileResult r = compile_file(data("beremiz_sfc.xml"));
  ASSERT_TRUE(r.ok()) << r.diags.render("beremiz_sfc.xml", "");
  Machine run(std::move(*r.image));
  run.cycles(2);
  EXPECT_EQ(run.value("fill0.step.Idle.X"), 1);
  EXPECT_EQ(run.out("inlet"), 0);
  run.set("start", 1);
  run.cycles(1);
  EXPECT_EQ(run.value("fill0.step.Filling.X"), 1);
  EXPECT_EQ(run.value("fill0.step.Idle.X"), 0);
  EXPECT_EQ(run.out("inlet"), 1);  // N
  run.set("start", 0);
  run.cycles(3);
  EXPECT_EQ(run.value("fill0.batches"), 1);  // P: once per activation
  EXPECT_EQ(run.value("fill0.lamp_out"), 0);  // its step is not active yet
  run.set("level", 85);
  run.cycles(1);
  EXPECT_EQ(run.value("fill0.step.Mixing.X"), 1);
  EXPECT_EQ(run.value("fill0.step.Draining.X"), 1);
  EXPECT_EQ(run.out("inlet"), 0);
  EXPECT_EQ(run.out("mixer"), 1);  // L 1 s
  EXPECT_EQ(run.out("drain"), 0);  // D 500 ms
  EXPECT_EQ(run.value("fill0.lamp_out"), 1);  // an LD action body ran
  run.cycles(6);
  EXPECT_EQ(run.out("drain"), 1);
  EXPECT_EQ(run.out("mixer"), 1);
  run.cycles(5);
  EXPECT_EQ(run.out("mixer"), 0);
  run.set("level", 2);
  run.cycles(1);
  EXPECT_EQ(run.value("fill0.step.Idle.X"), 1);  // the convergence fired
  EXPECT_EQ(run.value("fill0.step.Mixing.X"), 0);
  EXPECT_EQ(run.out("drain"), 0);
  run.set("start", 1);
  run.cycles(2);
  EXPECT_EQ(run.value("fill0.batches"), 2);
}

// LD: MOVE on a rung: EN from a contact; while EN is false the target keeps its value.
TEST(Plcopen, a_function_with_en_false_leaves_its_target_alone) {
  const std::string src = project(
      kNs201,
      "<pou name=\"main\" pouType=\"program\"><interface><inputVars>" + var("go", "BOOL", "%IX0.0") +
          var("n", "INT", "%IW0") + "</inputVars><localVars>" + var("x", "INT", "", "3") +
          "</localVars></interface><body><LD>"
          "<leftPowerRail localId=\"1\"><position x=\"0\" y=\"0\"/><connectionPointOut formalParameter=\"\"/></leftPowerRail>"
          "<contact localId=\"2\"><position x=\"0\" y=\"0\"/><connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn>"
          "<connectionPointOut/><variable>go</variable></contact>"
          "<block localId=\"3\" typeName=\"MOVE\"><position x=\"0\" y=\"0\"/><inputVariables>"
          "<variable formalParameter=\"EN\"><connectionPointIn><connection refLocalId=\"2\"/></connectionPointIn></variable>"
          "<variable formalParameter=\"IN\"><connectionPointIn><connection refLocalId=\"4\"/></connectionPointIn></variable>"
          "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"ENO\"><connectionPointOut/></variable>"
          "<variable formalParameter=\"OUT\"><connectionPointOut/></variable></outputVariables></block>"
          "<inVariable localId=\"4\"><position x=\"0\" y=\"0\"/><connectionPointOut/><expression>n</expression></inVariable>"
          "<outVariable localId=\"5\"><position x=\"0\" y=\"0\"/><connectionPointIn><connection refLocalId=\"3\" formalParameter=\"OUT\"/>"
          "</connectionPointIn><expression>x</expression></outVariable>"
          "</LD></body></pou>");
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine run(std::move(*r.image));
  run.set("n", 9);
  run.cycles(2);
  EXPECT_EQ(run.value("main.x"), 3);  // the initial value, EN false
  run.set("go", 1);
  run.cycles(1);
  EXPECT_EQ(run.value("main.x"), 9);
  run.set("go", 0);
  run.set("n", 1);
  run.cycles(1);
  EXPECT_EQ(run.value("main.x"), 9);  // kept
}

// A user FB called inside IF (ST) or by CALC (IL) keeps its variables while it is
// not called (standard FBs: test_plcopen_conditional.cpp).
TEST(Plcopen, a_user_fb_called_conditionally_keeps_its_state) {
  const std::string fb =
      "<pou name=\"Count\" pouType=\"functionBlock\"><interface><inputVars>" + var("step", "INT", "", "1") +
      "</inputVars><outputVars>" + var("n", "INT") +
      "</outputVars></interface><body><ST><xhtml:p><![CDATA[n := n + step;]]></xhtml:p></ST></body></pou>\n";
  const std::string vars = "<inputVars>" + var("go", "BOOL", "%IX0.0") + "</inputVars><localVars>" +
                           "<variable name=\"c1\"><type><derived name=\"Count\"/></type></variable>" +
                           "<variable name=\"c2\"><type><derived name=\"Count\"/></type></variable>" + var("a", "INT") +
                           var("b", "INT") + "</localVars>";
  const std::string st = project(kNs201, fb + st_program(vars, "IF go THEN c1(step := 2); END_IF;\na := c1.n;"));
  const std::string il = project(
      kNs201, fb + "<pou name=\"main\" pouType=\"program\"><interface>" + vars +
                  "</interface><body><IL><xhtml:p><![CDATA[LD go\nCALC c1(step := 2)\nLD c1.n\nST a\n]]></xhtml:p></IL></body></pou>\n");
  for (const std::string* src : {&st, &il}) {
    CompileResult r = compile_source(*src);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", *src);
    Machine run(std::move(*r.image));
    run.cycles(3);
    EXPECT_EQ(run.value("main.a"), 0);
    run.set("go", 1);
    run.cycles(2);
    EXPECT_EQ(run.value("main.a"), 4);
    run.set("go", 0);
    run.cycles(5);
    EXPECT_EQ(run.value("main.a"), 4);  // not called: kept
  }
}

// A user function: expanded at each call, formal and informal arguments, no memory.
TEST(Plcopen, expands_user_functions) {
  const std::string fn =
      "<pou name=\"Lin\" pouType=\"function\"><interface><returnType><REAL/></returnType><inputVars>" +
      var("x", "REAL") + var("k", "REAL", "", "2.0") + "</inputVars><localVars>" + var("tmp", "REAL") +
      "</localVars></interface><body><ST><xhtml:p><![CDATA[tmp := tmp + x * k; Lin := tmp + 1.0;]]></xhtml:p></ST></body></pou>\n";
  const std::string src = project(
      kNs201, fn + st_program("<localVars>" + var("a", "REAL") + var("b", "REAL") + "</localVars>",
                              "a := Lin(3.0, 4.0);\nb := Lin(k := 0.5, x := a);"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine run(std::move(*r.image));
  for (int i = 0; i < 3; ++i) {
    run.cycles(1);
    EXPECT_DOUBLE_EQ(run.value("main.a"), 13.0);  // tmp starts at 0 in every call
    EXPECT_DOUBLE_EQ(run.value("main.b"), 7.5);
  }
}

// The standard FBs wired by the importer: CTUD, SR, RS, F_TRIG, TOF.
TEST(Plcopen, wires_the_standard_function_blocks) {
  std::string decl;
  for (const char* fb : {"CTUD", "SR", "RS", "F_TRIG", "TOF"})
    decl += std::string("<variable name=\"i_") + fb + "\"><type><derived name=\"" + fb + "\"/></type></variable>";
  const std::string src = project(
      kNs201,
      st_program("<inputVars>" + var("up", "BOOL", "%IX0.0") + var("dn", "BOOL", "%IX0.1") + var("r", "BOOL", "%IX0.2") +
                     "</inputVars><localVars>" + decl + var("cv", "INT") + var("qu", "BOOL") + var("q_sr", "BOOL") +
                     var("q_rs", "BOOL") + var("fell", "BOOL") + var("off", "BOOL") + "</localVars>",
                 "i_CTUD(CU := up, CD := dn, R := r, LD := FALSE, PV := 3);\ncv := i_CTUD.CV; qu := i_CTUD.QU;\n"
                 "i_SR(S1 := up, R := up AND dn); q_sr := i_SR.Q1;\ni_RS(S := up, R1 := up AND dn); q_rs := i_RS.Q1;\n"
                 "i_F_TRIG(CLK := up); fell := i_F_TRIG.Q;\ni_TOF(IN := up, PT := T#300ms); off := i_TOF.Q;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine run(std::move(*r.image));
  run.cycles(1);
  for (int i = 0; i < 4; ++i) {
    run.set("up", 1);
    run.cycles(1);
    EXPECT_EQ(run.value("main.off"), 1);
    run.set("up", 0);
    run.cycles(1);
    EXPECT_EQ(run.value("main.fell"), 1);  // the cycle up fell
    run.cycles(1);
    EXPECT_EQ(run.value("main.fell"), 0);
  }
  EXPECT_EQ(run.value("main.cv"), 3);  // four pulses; CTUD counts up only while CV < PV = 3
  EXPECT_EQ(run.value("main.qu"), 1);
  EXPECT_EQ(run.value("main.q_sr"), 1);
  EXPECT_EQ(run.value("main.q_rs"), 1);
  EXPECT_EQ(run.value("main.off"), 1);  // TOF: 200 ms after up fell
  run.cycles(2);
  EXPECT_EQ(run.value("main.off"), 0);
  run.set("dn", 1);
  run.cycles(1);
  EXPECT_EQ(run.value("main.cv"), 2);
  run.set("up", 1);  // up AND dn: SR keeps (set dominant), RS resets
  run.cycles(1);
  EXPECT_EQ(run.value("main.q_sr"), 1);
  EXPECT_EQ(run.value("main.q_rs"), 0);
  run.set("r", 1);
  run.cycles(1);
  EXPECT_EQ(run.value("main.cv"), 0);
  EXPECT_EQ(run.value("main.qu"), 0);
}

TEST(Plcopen, if_conversion_keeps_unassigned_values_and_integers_wrap) {
  const std::string src = project(
      kNs201, st_program("<localVars>" + var("c", "INT", "", "32766") + var("x", "REAL") + var("flag", "BOOL") +
                             "</localVars>",
                         "c := c + 1;\nIF c < 0 THEN flag := TRUE; ELSIF c > 100 THEN x := 1.5; ELSE x := -2.0; END_IF;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine run(std::move(*r.image));
  run.cycles(1);
  EXPECT_EQ(run.value("main.c"), 32767);
  EXPECT_EQ(run.value("main.x"), 1.5);
  EXPECT_EQ(run.value("main.flag"), 0);
  run.cycles(1);
  EXPECT_EQ(run.value("main.c"), -32768);  // INT wraps
  EXPECT_EQ(run.value("main.flag"), 1);
  EXPECT_EQ(run.value("main.x"), 1.5);  // not assigned in the taken branch: kept
}

// Directly represented variables (%IX0.0 in an expression, without a declaration).
// The ST and IL operators are the standard functions of lang/iec's table, so
// they work in the operands' width: AND and NOT on DINT have 32 bits.
TEST(Plcopen, operators_work_in_the_width_of_their_operands) {
  const std::string vars = "<inputVars>" + var("a", "DINT", "%ID0") + var("b", "DINT", "%ID1") +
                           "</inputVars><localVars>" + var("x", "DINT") + var("y", "DINT") + var("z", "INT") +
                           "</localVars>";
  const std::string st = project(kNs201, st_program(vars, "x := a AND b;\ny := NOT a;\nz := -32768 - a;"));
  const std::string il = project(
      kNs201, "<pou name=\"main\" pouType=\"program\"><interface>" + vars +
                  "</interface><body><IL><xhtml:p><![CDATA[LD a\nAND b\nST x\nLD a\nNOT\nST y\n"
                  "LD -32768\nSUB a\nST z\n]]></xhtml:p></IL></body></pou>\n");
  for (const std::string* src : {&st, &il}) {
    CompileResult r = compile_source(*src);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", *src);
    Machine run(std::move(*r.image));
    run.set("a", 65536 + 7);
    run.set("b", 65536 + 12);
    run.cycles(1);
    EXPECT_EQ(run.value("main.x"), 65536 + 4);      // 16 bits would give 4
    EXPECT_EQ(run.value("main.y"), -(65536 + 7) - 1);  // NOT in 32 bits, as a signed DINT
    EXPECT_EQ(run.value("main.z"), 32761);  // -98311 in DINT, wrapped into INT on assignment
  }
}

// ADD on an INT wraps its sum; the assignment to an INT does not wrap it again.
TEST(Plcopen, an_integer_sum_is_wrapped_once) {
  const std::string src =
      project(kNs201, st_program("<localVars>" + var("n", "INT", "", "32766") + "</localVars>", "n := n + 1;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  const auto wraps = std::count_if(r.program.blocks.begin(), r.program.blocks.end(),
                                   [](const FlatBlock& b) { return b.written == "wrap"; });
  EXPECT_EQ(wraps, 1);
  Machine run(std::move(*r.image));
  run.cycles(2);
  EXPECT_EQ(run.value("main.n"), -32768);  // 32767 after the first cycle, then 32767 + 1 wraps
}

// Assignments run in the editors' order: top to bottom by position (a row
// left to right), executionOrderId first when it is set. A read sees only the
// assignments before it: `first` is TRUE in the first cycle for the read above
// the assignment that clears it.
TEST(Plcopen, fbd_assignments_run_top_to_bottom_as_in_the_editors) {
  auto at = [](int x, int y) { return "<position x=\"" + std::to_string(x) + "\" y=\"" + std::to_string(y) + "\"/>"; };
  auto body = [&](int read_x, int read_y, int clear_y, const std::string& read_eo, const std::string& clear_eo) {
    return project(
        kNs201,
        "<pou name=\"main\" pouType=\"program\"><interface><localVars>" + var("first", "BOOL", "", "TRUE") +
            var("seen", "BOOL") + var("n", "INT") + "</localVars></interface><body><FBD>"
            "<inVariable localId=\"3\">" + at(10, clear_y) + "<connectionPointOut/><expression>FALSE</expression></inVariable>"
            "<outVariable localId=\"4\" executionOrderId=\"" + clear_eo + "\">" + at(200, clear_y) +
            "<connectionPointIn><connection refLocalId=\"3\"/></connectionPointIn><expression>first</expression></outVariable>"
            "<inVariable localId=\"1\">" + at(10, read_y) + "<connectionPointOut/><expression>first</expression></inVariable>"
            "<outVariable localId=\"2\" executionOrderId=\"" + read_eo + "\">" + at(read_x, read_y) +
            "<connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn><expression>seen</expression></outVariable>"
            "</FBD></body></pou>\n");
  };
  struct Case {
    int read_x, read_y, clear_y;  // the clear's outVariable is at x 200
    const char *read_eo, *clear_eo;
    double seen_first_cycle;
  } cases[] = {
      {200, 10, 100, "0", "0", 1},   // the read is drawn above: it runs first
      {200, 100, 10, "0", "0", 0},   // below: the clear ran before it
      {100, 104, 100, "0", "0", 1},  // one row (within 10 units): left to right, the read is left
      {300, 104, 100, "0", "0", 0},  // ... and here right of the clear
      {200, 100, 10, "1", "2", 1},   // executionOrderId decides when it is set
  };
  for (const Case& c : cases) {
    const std::string src = body(c.read_x, c.read_y, c.clear_y, c.read_eo, c.clear_eo);
    CompileResult r = compile_source(src);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
    Machine run(std::move(*r.image));
    run.cycles(1);
    EXPECT_EQ(run.value("main.seen"), c.seen_first_cycle) << "read at y " << c.read_y << ", clear at y " << c.clear_y;
    run.cycles(1);
    EXPECT_EQ(run.value("main.seen"), 0);
  }
}

// Habits of real exports: task intervals as XML durations (tc6_0200) and
// times of day (legacy tc6.xsd), single-level bit addresses, CODESYS V3's
// POUs and global variable lists in the resource's addData, library-named
// IEC blocks, and inline SFC actions that all carry localId 0 (Beremiz).
TEST(Plcopen, reads_the_editors_other_habits) {
  for (const auto& [interval, seconds] : {std::pair<std::string, double>{"T#20ms", 0.02},
                                          {"PT0.02S", 0.02},
                                          {"PT1M", 60},
                                          {"00:00:00.100000", 0.1}}) {
    const std::string src = project(
        kNs201, st_program("<localVars>" + var("n", "INT") + "</localVars>", "n := n + 1;"),
        "<instances><configurations><configuration name=\"c\"><resource name=\"r\"><task name=\"t\" interval=\"" +
            interval + "\" priority=\"0\"><pouInstance name=\"main\" typeName=\"main\"/></task></resource>"
            "</configuration></configurations></instances>\n");
    CompileResult r = compile_source(src);
    ASSERT_TRUE(r.ok()) << interval << "\n" << r.diags.render("t.xml", src);
    EXPECT_DOUBLE_EQ(r.image->period_s(), seconds) << interval;
  }
  {
    const std::string src = project(
        kNs201, st_program("<inputVars>" + var("b", "BOOL", "%IX12") + "</inputVars><localVars>" + var("x", "BOOL") +
                               "</localVars>",
                           "x := b;"));
    CompileResult r = compile_source(src);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
    const auto in = std::find_if(r.program.blocks.begin(), r.program.blocks.end(),
                                 [](const FlatBlock& b) { return b.written == "ddi"; });
    ASSERT_NE(in, r.program.blocks.end());
    EXPECT_EQ(in->d, 1);  // %IX12 is %IX1.4
    EXPECT_EQ(in->c, 4u);
  }
  {
    const std::string src =
        "<!-- exported by hand --><?xml version=\"1.0\"?>\n<project xmlns=\"http://www.plcopen.org/xml/tc6_0200\">"
        "<fileHeader companyName=\"t\"/><types><dataTypes/><pous/></types><instances><configurations>"
        "<configuration name=\"Device\"><resource name=\"Application\">"
        "<task name=\"Task\" interval=\"PT0.01S\" priority=\"1\"><pouInstance name=\"PLC_PRG\" typeName=\"PLC_PRG\"/></task>"
        "<addData><data name=\"http://www.3s-software.com/plcopenxml/globalvars\" handleUnknown=\"implementation\">"
        "<globalVars name=\"GVL\">" + var("limit", "INT", "", "3") + "</globalVars></data>"
        "<data name=\"http://www.3s-software.com/plcopenxml/pou\" handleUnknown=\"implementation\">"
        "<pou name=\"PLC_PRG\" pouType=\"program\"><interface><localVars>" + var("c", "INT") +
        "<variable name=\"edge\"><type><derived name=\"Standard.R_TRIG\"/></type></variable>"
        "</localVars></interface><body><ST><xhtml xmlns=\"http://www.w3.org/1999/xhtml\">"
        "edge(CLK := TRUE); IF c &lt; limit THEN c := c + 1; END_IF;</xhtml></ST></body></pou></data></addData>"
        "</resource></configuration></configurations></instances></project>\n";
    CompileResult r = compile_source(src);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
    EXPECT_DOUBLE_EQ(r.image->period_s(), 0.01);
    Machine run(std::move(*r.image));
    run.cycles(5);
    EXPECT_EQ(run.value("PLC_PRG.c"), 3);
    EXPECT_EQ(run.value("PLC_PRG.edge.Q"), 0);  // TRUE since the first cycle: one edge, then none
  }
  {
    const std::string pos = "<position x=\"0\" y=\"0\"/>";
    const std::string src = project(
        kNs201,
        "<pou name=\"main\" pouType=\"program\"><interface><localVars>" + var("a", "INT") + var("b", "INT") +
            "</localVars></interface><body><SFC>"
            "<step localId=\"1\" name=\"S\" initialStep=\"true\">" + pos +
            "<connectionPointIn/><connectionPointOut formalParameter=\"\"/>"
            "<connectionPointOutAction formalParameter=\"\"/></step>"
            "<actionBlock localId=\"2\">" + pos + "<connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn>"
            "<action localId=\"0\" qualifier=\"N\"><inline><ST><xhtml:p><![CDATA[a := a + 1;]]></xhtml:p></ST></inline></action>"
            "<action localId=\"0\" qualifier=\"N\"><inline><ST><xhtml:p><![CDATA[b := b + 2;]]></xhtml:p></ST></inline></action>"
            "</actionBlock></SFC></body></pou>\n");
    CompileResult r = compile_source(src);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
    Machine run(std::move(*r.image));
    run.cycles(3);
    EXPECT_EQ(run.value("main.a"), 3);
    EXPECT_EQ(run.value("main.b"), 6);
  }
}

// CODESYS bodies carry pragmas and // comments; both are skipped.
TEST(Plcopen, st_skips_pragmas_and_line_comments) {
  const std::string src = project(
      kNs201, st_program("<localVars>" + var("a", "DINT") + "</localVars>",
                         "// counts\n{attribute 'hide'}\nif a < 16#FF then a := a + 2#10; end_if; (* by 2 *)"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine run(std::move(*r.image));
  run.cycles(3);
  EXPECT_EQ(run.value("main.a"), 6);
  const std::string bad = project(kNs201, st_program("<localVars>" + var("a", "DINT") + "</localVars>", "{attribute a := 1;"));
  CompileResult b = compile_source(bad);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.diags.items()[0].message.find("unterminated pragma"), std::string::npos);
}

// Two variables at one %Q address are one output (OpenPLC accepts this): the
// one the program writes drives it, in either order; both written is an error.
TEST(Plcopen, aliases_at_one_output_address_have_one_writer) {
  for (const bool written_first : {true, false}) {
    const std::string a = var("pump", "BOOL", "%QX1.0"), b = var("valve", "BOOL", "%QX1.0");
    const std::string src = project(
        kNs201, st_program("<inputVars>" + var("start", "BOOL", "%IX0.0") + "</inputVars><outputVars>" +
                               (written_first ? a + b : b + a) + "</outputVars>",
                           "pump := start;"));
    CompileResult r = compile_source(src);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
    Machine run(std::move(*r.image));
    run.set("start", 1);
    run.cycles(1);
    EXPECT_EQ(run.out("pump"), 1);
  }
  const std::string both = project(
      kNs201, st_program("<outputVars>" + var("pump", "BOOL", "%QX1.0") + var("valve", "BOOL", "%QX1.0") +
                             "</outputVars>",
                         "pump := TRUE; valve := FALSE;"));
  CompileResult r = compile_source(both);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.diags.items()[0].message.find("'valve' and 'pump'"), std::string::npos) << r.diags.items()[0].message;
  EXPECT_NE(r.diags.items()[0].message.find("both written: an output has one writer"), std::string::npos);
}

// An outVariable left unconnected in the editor assigns nothing (a warning,
// as Beremiz and OpenPLC skip it); an FB output named like the variable it
// feeds is no feedback loop.
TEST(Plcopen, fbd_unconnected_outputs_and_same_named_fb_outputs) {
  const std::string pos = "<position x=\"0\" y=\"0\"/>";
  const std::string inc =
      "<pou name=\"Inc\" pouType=\"functionBlock\"><interface><outputVars>" + var("q", "INT") +
      "</outputVars></interface><body><ST><xhtml:p><![CDATA[q := q + 1;]]></xhtml:p></ST></body></pou>\n";
  const std::string src = project(
      kNs201,
      inc + "<pou name=\"main\" pouType=\"program\"><interface><localVars>" + fb("i1", "Inc") + var("q", "INT") +
          var("z", "INT") + "</localVars></interface><body><FBD>"
          "<block localId=\"1\" typeName=\"Inc\" instanceName=\"i1\">" + pos + "<inputVariables/><inOutVariables/>"
          "<outputVariables><variable formalParameter=\"q\"><connectionPointOut/></variable></outputVariables></block>"
          "<outVariable localId=\"2\">" + pos + "<connectionPointIn><connection refLocalId=\"1\" formalParameter=\"q\"/>"
          "</connectionPointIn><expression>q</expression></outVariable>"
          "<outVariable localId=\"3\">" + pos + "<connectionPointIn/><expression>z</expression></outVariable>"
          "</FBD></body></pou>\n");
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  ASSERT_EQ(r.diags.warning_count(), 1u);
  EXPECT_NE(r.diags.items()[0].message.find("localId 3 has nothing connected to its input: it assigns nothing"),
            std::string::npos);
  for (const std::string& n : r.program.notes) EXPECT_EQ(n.find("is read before"), std::string::npos) << n;
  Machine run(std::move(*r.image));
  run.cycles(3);
  EXPECT_EQ(run.value("main.q"), 3);
  EXPECT_EQ(run.value("main.z"), 0);
}

TEST(Plcopen, reads_and_writes_directly_represented_variables) {
  const std::string src = project(
      kNs201, st_program("<localVars>" + var("k", "INT") + "</localVars>",
                         "%QX0.1 := %IX0.0 AND NOT %IX0.1;\nk := %MW4 * 2;\n%QW2 := k;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine run(std::move(*r.image));
  run.set("IX0.0", 1);
  run.set("MW4", 21);  // read only: an operator set-point
  run.cycles(1);
  EXPECT_EQ(run.out("QX0.1"), 1);
  EXPECT_EQ(run.out("QW2"), 42);
}

TEST(Plcopen, runs_while_repeat_and_for_with_variable_bounds_in_st_bodies) {
  // One ST for PLCopen bodies and .st files: the loops run here too.
  const std::string src = project(
      kNs201, st_program("<localVars>" + var("i", "INT") + var("n", "INT", "", "4") + var("x", "REAL") +
                             var("r", "INT") + "</localVars>",
                         "i := 0;\nWHILE i < 3 DO i := i + 1; END_WHILE;\nx := 0.0;\n"
                         "FOR r := 1 TO n DO x := x + 1.5; END_FOR;\nREPEAT n := n - 1; UNTIL n <= 2 END_REPEAT;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine m(std::move(*r.image));
  m.cycles(1);
  EXPECT_EQ(m.value("main.i"), 3);
  EXPECT_EQ(m.value("main.x"), 6.0);  // n = 4 at the FOR
  EXPECT_EQ(m.value("main.n"), 2);    // counted down after it
  m.cycles(1);                        // n starts at 2: the FOR runs twice, REPEAT once
  EXPECT_EQ(m.value("main.x"), 3.0);
  EXPECT_EQ(m.value("main.n"), 1);
}

TEST(Plcopen, accepts_three_namespaces_and_refuses_others) {
  const std::string pou = st_program("<localVars>" + var("x", "REAL") + "</localVars>", "x := x + 1.0;");
  for (const char* ns : {"http://www.plcopen.org/xml/tc6_0201", "http://www.plcopen.org/xml/tc6_0200",
                         "http://www.plcopen.org/xml/tc6.xsd"}) {
    CompileResult r = compile_source(project(ns, pou));
    EXPECT_TRUE(r.ok()) << ns << "\n" << r.diags.render("t.xml", "");
  }
  CompileResult bad = compile_source(project("http://example.org/other", pou));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.diags.items()[0].message.find("not PLCopen TC6"), std::string::npos);
}

TEST(Plcopen, refuses_macro_steps_and_vendor_elements_by_name) {
  const std::string sfc = project(kNs201,
                                  "<pou name=\"main\" pouType=\"program\"><interface/><body><SFC>"
                                  "<macroStep localId=\"1\" name=\"M\"/></SFC></body></pou>");
  CompileResult r = compile_source(sfc);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.diags.items()[0].message.find("<macroStep> in an SFC body is not supported yet"), std::string::npos)
      << r.diags.items()[0].message;
  const std::string vendor = project(kNs201,
                                     "<pou name=\"main\" pouType=\"program\"><interface/><body><FBD>"
                                     "<vendorElement localId=\"1\"/></FBD></body></pou>");
  CompileResult v = compile_source(vendor);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.diags.items()[0].message.find("vendorElement"), std::string::npos);
  EXPECT_EQ(v.diags.items()[0].pos.line, 5u);  // the line of the <pou>
}

// Writing an input is MatIEC's: it lasts until the next cycle reads the input
// again (docs/plcopen.md, "Located variables"), and --explain notes it.
TEST(Plcopen, writing_an_input_lasts_until_the_next_cycle_and_is_noted) {
  const std::string src = project(kNs201, st_program("<inputVars>" + var("b", "BOOL", "%IX0.0") + "</inputVars>" +
                                                         "<localVars>" + var("seen", "BOOL") + "</localVars>",
                                                     "b := TRUE; seen := b;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  ASSERT_FALSE(r.program.notes.empty());
  bool noted = false;
  for (const std::string& n : r.program.notes) noted = noted || n.find("'b' is an input (%IX0.0) the program writes") == 0;
  EXPECT_TRUE(noted);
  Machine m(std::move(*r.image));
  m.cycles(1);
  EXPECT_EQ(m.value("main.seen"), 1);
}

TEST(Plcopen, maps_located_variables_to_channels) {
  const std::string src = project(
      kNs201, st_program("<inputVars>" + var("ai", "REAL", "%IW3") + var("di", "BOOL", "%IX2.5") + var("big", "DINT", "%ID1") +
                             "</inputVars><outputVars>" + var("ao", "REAL", "%QW3") + var("dq", "BOOL", "%QX1.7") +
                             "</outputVars><localVars>" + var("sp", "REAL", "%MD4", "12.5") + var("mem", "INT", "%MW2") +
                             "</localVars>",
                         "ao := ai + sp + DINT_TO_REAL(big); dq := di; mem := TIME_TO_INT(T#1.5s);"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  auto find = [&](const char* label) -> const Binding* {
    for (const Binding& b : r.image->bindings())
      if (std::string_view(r.image->str(b.label)) == label) return &b;
    return nullptr;
  };
  for (const char* l : {"ai", "di", "ao", "dq", "sp", "big"}) ASSERT_NE(find(l), nullptr) << l;
  EXPECT_EQ(1000u * find("ai")->p + 100u * find("ai")->d + find("ai")->c, 3u);     // p0.d0.c3
  EXPECT_EQ(1000u * find("di")->p + 100u * find("di")->d + find("di")->c, 1205u);  // p1.d2.c5
  EXPECT_EQ(find("big")->p, 2u);
  EXPECT_EQ(1000u * find("dq")->p + 100u * find("dq")->d + find("dq")->c, 1107u);
  EXPECT_EQ(find("sp")->dir, BindingDir::kSetpoint);  // read-only %M: an operator set-point
  EXPECT_DOUBLE_EQ(find("sp")->init, 12.5);
  EXPECT_EQ(find("mem"), nullptr);  // written by the program: internal
  Machine run(std::move(*r.image));
  run.cycles(1);
  EXPECT_EQ(run.value("main.mem"), 1);  // MatIEC's (no CODESYS header): whole seconds
  CompileOptions o;
  o.semantics = EditorSemantics::kCodesys;
  CompileResult c = compile_source(src, o);
  ASSERT_TRUE(c.ok());
  Machine cr(std::move(*c.image));
  cr.cycles(1);
  EXPECT_EQ(cr.value("main.mem"), 1500);  // CODESYS's: milliseconds
}

// Beremiz's hierarchical addresses (an extension's location, then the item):
// processor 100 / 125 / 150 / 175 / 200 + the first level for X / W / D / L /
// B, one address per form (docs/plcopen.md, "Located variables"): a.b is
// d255.c<b>, a.b.c is d<b>.c<c>, a.b.c.d is d<b>.c<256 + 256c + d>.
TEST(Plcopen, maps_hierarchical_addresses_to_their_own_processors) {
  const std::string src = project(
      kNs201, st_program("<inputVars>" + var("pm", "INT", "%IW0.1.1.2") + var("s1", "BOOL", "%IX2.0.3.4") +
                             var("w2", "INT", "%IW0.0") + var("w3", "INT", "%IW0.0.0") + var("w4", "INT", "%IW0.0.0.0") +
                             var("big", "DINT", "%ID1.2.3") + var("b", "BYTE", "%IB0.7") + "</inputVars><outputVars>" +
                             var("busy", "BOOL", "%QX0.1.0.0") + var("q", "LREAL", "%QL3.4.254.255") +
                             "</outputVars>",
                         "busy := s1; q := INT_TO_LREAL(pm + w2 + w3 + w4) + DINT_TO_LREAL(big) + BYTE_TO_LREAL(b);"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  auto at = [&](const char* label) -> std::string {
    for (const Binding& b : r.image->bindings()) {
      if (std::string_view(r.image->str(b.label)) == label) {
        return "p" + std::to_string(b.p) + ".d" + std::to_string(b.d) + ".c" + std::to_string(b.c);
      }
    }
    return "none";
  };
  EXPECT_EQ(at("pm"), "p125.d1.c514");   // 256 + 256 * 1 + 2
  EXPECT_EQ(at("s1"), "p102.d0.c1028");  // 256 + 256 * 3 + 4
  // Two, three and four levels that look alike are three channels.
  EXPECT_EQ(at("w2"), "p125.d255.c0");
  EXPECT_EQ(at("w3"), "p125.d0.c0");
  EXPECT_EQ(at("w4"), "p125.d0.c256");
  EXPECT_EQ(at("big"), "p151.d2.c3");
  EXPECT_EQ(at("b"), "p200.d255.c7");
  EXPECT_EQ(at("busy"), "p100.d1.c256");
  EXPECT_EQ(at("q"), "p178.d4.c65535");
  auto refused = [&](const char* address, const char* type) {
    const std::string bad = project(kNs201, st_program("<localVars>" + var("v", type, address) + "</localVars>", "v := v;"));
    CompileResult b = compile_source(bad);
    return b.ok() ? std::string("compiled") : b.diags.items()[0].message;
  };
  EXPECT_NE(refused("%MW0.1.2", "INT").find("a memory address has one"), std::string::npos);
  EXPECT_NE(refused("%IX0.1.2.3.4", "BOOL").find("more than four levels"), std::string::npos);
  EXPECT_NE(refused("%IW25.0.0", "INT").find("first level above 24"), std::string::npos);
  EXPECT_NE(refused("%IW0.255.0", "INT").find("second level above 254"), std::string::npos);
  EXPECT_NE(refused("%IW0.1.255.0", "INT").find("third level above 254"), std::string::npos);
}

// TIME meeting numbers, as each editor's runtime converts (docs/plcopen.md,
// "Which editor's semantics"): MatIEC in whole seconds (its __time_to_int is
// tv_sec, __int_to_time makes seconds), CODESYS in milliseconds.
TEST(Plcopen, time_conversions_follow_the_chosen_editor) {
  // r is a variable (its value reaches the conversion at run time, not folded).
  const std::string src = project(
      kNs201, st_program("<localVars>" + var("a", "DINT") + var("b", "DINT") + var("c", "REAL") + var("d", "TIME") +
                             var("e", "TIME") + var("f", "UINT") + var("g", "INT") + var("h", "INT") +
                             var("r", "REAL", "", "-3.4") + var("q", "REAL", "", "2.5") + "</localVars>",
                         "a := TIME_TO_DINT(T#1.5s); b := TIME_TO_DINT(T#-1.5s); c := TIME_TO_REAL(T#1.5s);\n"
                         "d := DINT_TO_TIME(2); e := REAL_TO_TIME(2.5);\n"
                         "f := REAL_TO_UINT(r); g := REAL_TO_INT(q); h := REAL_TO_INT(-q);\n"
                         "r := r + 0.0; q := q + 0.0;"));
  struct Want {
    EditorSemantics sem;
    double a, b, c, d, e;  // TIME in seconds, as rtplc keeps it
    double f;              // REAL_TO_UINT(-3.4): MatIEC's __real_to_uint gives 0, CODESYS's wraps -3
  };
  for (const Want& w : {Want{EditorSemantics::kMatiec, 1, -1, 1.5, 2, 2.5, 0},
                        Want{EditorSemantics::kFromHeader, 1, -1, 1.5, 2, 2.5, 0},  // no CODESYS header
                        Want{EditorSemantics::kCodesys, 1500, -1500, 1500, 0.002, 0.0025, 65536 - 3}}) {
    CompileOptions o;
    o.semantics = w.sem;
    CompileResult r = compile_source(src, o);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
    Machine run(std::move(*r.image));
    run.cycles(1);
    const int k = static_cast<int>(w.sem);
    EXPECT_EQ(run.value("main.a"), w.a) << k;
    EXPECT_EQ(run.value("main.b"), w.b) << k;
    EXPECT_DOUBLE_EQ(run.value("main.c"), w.c) << k;
    EXPECT_DOUBLE_EQ(run.value("main.d"), w.d) << k;
    EXPECT_DOUBLE_EQ(run.value("main.e"), w.e) << k;
    EXPECT_EQ(run.value("main.f"), w.f) << k;
    EXPECT_EQ(run.value("main.g"), 2) << k;   // 2.5: the tie goes to the even neighbour
    EXPECT_EQ(run.value("main.h"), -2) << k;  // -2.5 likewise
  }
}

// An FBD body imported gives the same trace as the seed-language program it stands for.
TEST(Plcopen, fbd_body_matches_the_equivalent_seed_program) {
  const std::string fbd =
      project(kNs201,
              "<pou name=\"p\" pouType=\"program\"><interface><inputVars>" + var("pv", "REAL", "%IW0") +
                  "</inputVars><outputVars>" + var("mv", "REAL", "%QW0") +
                  "</outputVars></interface><body><FBD>"
                  "<inVariable localId=\"1\"><position x=\"0\" y=\"0\"/><connectionPointOut/><expression>pv</expression></inVariable>"
                  "<inVariable localId=\"2\"><position x=\"0\" y=\"0\"/><connectionPointOut/><expression>2.5</expression></inVariable>"
                  "<block localId=\"3\" typeName=\"MUL\" executionOrderId=\"0\"><position x=\"0\" y=\"0\"/><inputVariables>"
                  "<variable formalParameter=\"IN1\"><connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn></variable>"
                  "<variable formalParameter=\"IN2\"><connectionPointIn><connection refLocalId=\"2\"/></connectionPointIn></variable>"
                  "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"OUT\"><connectionPointOut/></variable></outputVariables></block>"
                  "<block localId=\"4\" typeName=\"LIMIT\" executionOrderId=\"0\"><position x=\"0\" y=\"0\"/><inputVariables>"
                  "<variable formalParameter=\"MN\"><connectionPointIn><connection refLocalId=\"5\"/></connectionPointIn></variable>"
                  "<variable formalParameter=\"IN\"><connectionPointIn><connection refLocalId=\"3\"/></connectionPointIn></variable>"
                  "<variable formalParameter=\"MX\"><connectionPointIn><connection refLocalId=\"6\"/></connectionPointIn></variable>"
                  "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"OUT\"><connectionPointOut/></variable></outputVariables></block>"
                  "<inVariable localId=\"5\"><position x=\"0\" y=\"0\"/><connectionPointOut/><expression>0.0</expression></inVariable>"
                  "<inVariable localId=\"6\"><position x=\"0\" y=\"0\"/><connectionPointOut/><expression>100.0</expression></inVariable>"
                  "<outVariable localId=\"7\"><position x=\"0\" y=\"0\"/><connectionPointIn><connection refLocalId=\"4\"/></connectionPointIn><expression>mv</expression></outVariable>"
                  "</FBD></body></pou>");
  const std::string seed =
      "%%\nstime(0.1)\nF1 = dai(p0, d0, c0, \"pv\")\nF2 = mult(F1, F1, 0)\nF3 = scale(F2, 0, 2.5)\n"
      "F4 = mult(F1, F3)\nF5 = lim(F4, 0, 100)\ndao(F5, p0, d0, c0, \"mv\")\nEND\n%%\n";
  CompileResult a = compile_source(fbd), b = compile_source(seed);
  ASSERT_TRUE(a.ok()) << a.diags.render("t.xml", fbd);
  ASSERT_TRUE(b.ok()) << b.diags.render("t.fbd", seed);
  Machine ra(std::move(*a.image)), rb(std::move(*b.image));
  for (int i = 0; i < 60; ++i) {
    const double pv = -10 + i * 1.5;
    ra.set("pv", pv);
    rb.set("pv", pv);
    ra.cycles(1);
    rb.cycles(1);
    EXPECT_DOUBLE_EQ(ra.out("mv"), rb.out("mv")) << "cycle " << i;
  }
}

// Standard functions come from lang/iec's table (docs/iec.md), so the importer
// has every one of them with the table's typing: SHL and NEG, which it never
// listed itself, and OR on an INT that works on 16 bits.
TEST(Plcopen, lowers_standard_functions_through_the_iec_table) {
  const std::string src = project(
      kNs201, st_program("<localVars>" + var("w", "WORD", "", "3855") + var("i", "INT", "", "-1") +
                             var("s", "WORD") + var("n", "INT") + var("o", "INT") + var("m", "REAL") +
                             "</localVars>",
                         "s := SHL(IN := w, N := 4); n := NEG(i); o := OR(i, 0);"
                         " m := MUX(1, 1.5, 2.5, 3.5);"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine run(std::move(*r.image));
  run.cycles(1);
  EXPECT_EQ(run.value("main.s"), 0xF0F0);  // 16#0F0F shifted left by 4 within a WORD
  EXPECT_EQ(run.value("main.n"), 1);
  EXPECT_EQ(run.value("main.o"), -1);
  EXPECT_EQ(run.value("main.m"), 2.5);
}

TEST(Plcopen, names_stateful_blocks_by_instance_path) {
  CompileResult r = compile_file(data("openplc_mixed.xml"));
  ASSERT_TRUE(r.ok());
  bool ton = false;
  for (const FlatBlock& b : r.program.blocks) ton = ton || (b.name == "instance0.t1.Q" && b.written == "ton");
  EXPECT_TRUE(ton);
  EXPECT_NE(std::find(r.program.variables.begin(), r.program.variables.end(), "instance0.hys.Q"),
            r.program.variables.end());
}

// Hot swap matches blocks by name and opcode: an edited project (another PT, one
// more rung) keeps the timer, the FB instance's latch and the counter variable.
TEST(Plcopen, hot_swap_keeps_state_by_instance_path) {
  std::string err;
  auto text = read_text_file(data("openplc_mixed.xml"), &err);
  ASSERT_TRUE(text) << err;
  std::string edited = *text;
  edited.replace(edited.find("T#500ms"), 7, "T#800ms");
  CompileResult a = compile_source(*text), b = compile_source(edited);
  ASSERT_TRUE(a.ok() && b.ok());
  const sched::Migration m = sched::plan_migration(*a.image, *b.image);
  for (const char* kept : {"instance0.t1.Q", "instance0.t1.ET", "instance0.hys.Q", "instance0.cycles"})
    EXPECT_NE(std::find(m.kept.begin(), m.kept.end(), kept), m.kept.end()) << kept;

}

TEST(Plcopen, asks_which_task_when_there_are_several) {
  CompileResult r = compile_file(data("codesys_ld_st.xml"));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.diags.items()[0].message.find("task Fast, task Slow"), std::string::npos);
}

// `rtplc analyze FILE.xml`: the chart the importer compiles, read on its own.
TEST(PlcopenSfc, the_beremiz_chart_reads_as_an_sfc_chart_for_the_net_builder) {
  std::string err;
  auto text = read_text_file(data("beremiz_sfc.xml"), &err);
  ASSERT_TRUE(text) << err;
  DiagnosticList d;
  std::optional<sfc::Chart> c = plcopen::read_sfc_pou(*text, "", d);
  ASSERT_TRUE(c) << d.render("beremiz_sfc.xml", *text);
  ASSERT_EQ(c->steps.size(), 4u);
  EXPECT_TRUE(c->steps[0].initial);
  ASSERT_EQ(c->transitions.size(), 3u);
  // The simultaneous convergence: one transition leaves both branches.
  ASSERT_EQ(c->transitions[2].from.size(), 2u);
  EXPECT_EQ(c->transitions[2].from[0].name, "Mixing");
  EXPECT_EQ(c->transitions[2].from[1].name, "Draining");
  ASSERT_EQ(c->transitions[2].to.size(), 1u);
  EXPECT_EQ(c->transitions[2].to[0].name, "Idle");
  sfc::check_chart(*c, d);
  EXPECT_FALSE(d.has_errors()) << d.render("beremiz_sfc.xml", *text);

  DiagnosticList none;
  EXPECT_FALSE(plcopen::read_sfc_pou(*text, "nope", none));
  EXPECT_TRUE(none.has_errors());
  auto mixed = read_text_file(data("openplc_mixed.xml"), &err);
  ASSERT_TRUE(mixed) << err;
  DiagnosticList no_sfc;
  EXPECT_FALSE(plcopen::read_sfc_pou(*mixed, "", no_sfc));
  EXPECT_TRUE(no_sfc.has_errors());
}

}  // namespace
}  // namespace rtplc::lang
