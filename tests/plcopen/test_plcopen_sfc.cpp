// The PLCopen importer's SFC bodies (docs/plcopen.md, "SFC"): the action
// qualifiers beyond N S R P L D, and transition conditions drawn in FBD or LD,
// run cycle by cycle on projects written for these tests (tests/plcopen/data).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "lang/compiler.h"
#include "lang/plcopen/sfc_chart.h"
#include "tests/plcopen/plcopen_harness.h"

namespace rtplc::lang {
namespace {

std::string read_data(const char* f) {
  std::ifstream in(data(f));
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// `text` with its first `from` replaced by `to` (the test fails if absent).
std::string edited(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The first error's message and line, or "" when it compiled.
std::string first_error(const CompileResult& r, uint32_t* line = nullptr) {
  for (const Diagnostic& d : r.diags.items()) {
    if (d.severity != Severity::kError) continue;
    if (line) *line = d.pos.line;
    return d.message;
  }
  return "";
}

// The 1-based line of the first `needle` in `text`.
uint32_t line_of(const std::string& text, const std::string& needle) {
  const size_t at = text.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  return static_cast<uint32_t>(1 + std::count(text.begin(), text.begin() + static_cast<long>(std::min(at, text.size())), '\n'));
}

// sfc_order.xml (A -go-> B -(n1 >= 2)-> A, each step's N action counting),
// cycle by cycle with go TRUE from the start: "n0 n1 step" per cycle.
std::string order_trace(const std::string& src, EditorSemantics sem) {
  CompileOptions o;
  o.semantics = sem;
  CompileResult r = compile_source(src, o);
  EXPECT_TRUE(r.ok()) << r.diags.render("sfc_order.xml", src);
  if (!r.ok()) return "";
  Machine run(std::move(*r.image));
  std::string got;
  for (int k = 0; k < 5; ++k) {
    run.set("go", 1);
    run.cycles(1);
    got += std::to_string(static_cast<int>(run.value("o.n0"))) + std::to_string(static_cast<int>(run.value("o.n1"))) +
           (run.value("o.step.A.X") != 0 ? "A" : "") + (run.value("o.step.B.X") != 0 ? "B" : "") + " ";
  }
  return got;
}

TEST(PlcopenSfcOrder, matiec_fires_from_the_first_cycle_and_runs_the_new_steps_actions_in_the_same_cycle) {
  const std::string src = read_data("sfc_order.xml");  // its header names Beremiz
  // Cycle 1: A is active before it, go fires, B's action runs (A's never did).
  // Cycle 2: n1 = 1 < 2, B stays. Cycle 3: n1 = 2 fires, A's action (n0 = 1).
  // Cycle 4: go fires again, n1 = 3. Cycle 5: n1 >= 2 fires at once, n0 = 2.
  const std::string want = "01B 02B 12A 13B 23A ";
  EXPECT_EQ(order_trace(src, EditorSemantics::kFromHeader), want);
  EXPECT_EQ(order_trace(src, EditorSemantics::kMatiec), want);
  // The explain notes say whose and why.
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok());
  const auto& notes = r.program.notes;
  EXPECT_TRUE(std::any_of(notes.begin(), notes.end(), [](const std::string& n) {
    return n.find("semantics: MatIEC's") == 0 && n.find("names Beremiz") != std::string::npos;
  }));
}

TEST(PlcopenSfcOrder, codesys_runs_the_actions_first_with_a_last_call_and_switches_for_the_next_cycle) {
  const std::string src = edited(read_data("sfc_order.xml"), "productName=\"Beremiz\"", "productName=\"CODESYS\"");
  // Cycle 1: A's action (n0 = 1), then go: B next. Cycle 2: B's action (n1 =
  // 1) and A's last call (n0 = 2). Cycle 3: n1 = 2, the transition sees it:
  // A next. Cycle 4: A's action (n0 = 3), B's last call (n1 = 3), go: B next.
  // Cycle 5: B (n1 = 4), A's last call (n0 = 4); n1 >= 2: A next. The step
  // shown is the one active for the next cycle.
  const std::string want = "10B 21B 22A 33B 44A ";
  EXPECT_EQ(order_trace(src, EditorSemantics::kFromHeader), want);
  EXPECT_EQ(order_trace(src, EditorSemantics::kCodesys), want);
  // Overridden both ways.
  EXPECT_EQ(order_trace(src, EditorSemantics::kMatiec), "01B 02B 12A 13B 23A ");
  EXPECT_EQ(order_trace(read_data("sfc_order.xml"), EditorSemantics::kCodesys), want);
  // CODESYS's own exports name it in companyName or in a 3S addData; an empty
  // productName with "3S-Smart Software Solutions" as the company counts too.
  EXPECT_EQ(order_trace(edited(read_data("sfc_order.xml"), "companyName=\"Unknown\" productName=\"Beremiz\"",
                               "companyName=\"3S-Smart Software Solutions GmbH\" productName=\"\""),
                        EditorSemantics::kFromHeader),
            want);
}

// sfc_qualifiers.xml at 100 ms, cycle by cycle: go, stop and rst as "100"...;
// per cycle the active step's initial and p1_out p0_out sd_out ds_out sl_out.
TEST(PlcopenSfcQualifiers, p1_p0_sd_ds_and_sl_follow_the_hand_worked_trace) {
  CompileResult r = compile_file(data("sfc_qualifiers.xml"));
  ASSERT_TRUE(r.ok()) << r.diags.render("sfc_qualifiers.xml", read_data("sfc_qualifiers.xml"));
  Machine run(std::move(*r.image));
  const std::vector<std::string> inputs = {"000", "100", "010", "000", "000", "000", "100", "010",
                                           "001", "000", "100", "000", "000", "000", "010", "001"};
  std::string got;
  for (const std::string& in : inputs) {
    run.set("go", in[0] == '1');
    run.set("stop", in[1] == '1');
    run.set("rst", in[2] == '1');
    run.cycles(1);
    for (const char* st : {"Idle", "Run", "Clear"}) {
      if (run.value(std::string("q0.step.") + st + ".X") != 0) got += st[0];
    }
    for (const char* v : {"p1_out", "p0_out", "sd_out", "ds_out", "sl_out"})
      got += std::to_string(static_cast<int>(run.value(std::string("q0.") + v)));
    got += ' ';
  }
  // Run is active in cycles 2, 7 and 11-14 (T = 0.3 s is three cycles):
  // P1 pulses as Run starts, P0 as it ends; SD comes on 3 cycles after cycle 2
  // though Run ended, stays on until Clear's R, and again 3 cycles after 11;
  // DS only once Run lasts 3 cycles (cycle 14), stored past Run's end; SL is
  // on for 3 cycles from 2, not again in 7 (not reset yet), again from 11.
  EXPECT_EQ(got,
            "I00000 R10001 I01001 I00001 I00100 I00100 R10100 I01100 "
            "C00000 I00000 R10001 R00001 R00001 R00110 I01110 C00000 ");
  EXPECT_EQ(run.value("q0.ends"), 3) << "the P0 action body ran once per end of Run";
}

TEST(PlcopenSfcQualifiers, a_timed_qualifier_needs_a_duration_and_dl_is_refused) {
  const std::string xml = read_data("sfc_qualifiers.xml");
  const std::pair<const char*, uint32_t> timed[] = {{"SD", 51}, {"DS", 52}, {"SL", 53}};
  for (const auto& [q, at] : timed) {
    const std::string with = std::string("qualifier=\"") + q + "\" duration=\"T#300ms\"";
    CompileResult r = compile_source(edited(xml, with, std::string("qualifier=\"") + q + "\""));
    uint32_t line = 0;
    EXPECT_EQ(first_error(r, &line), std::string("qualifier ") + q + " needs a duration");
    EXPECT_EQ(line, at) << "the <action>'s line";
  }
  CompileResult dl = compile_source(edited(xml, "qualifier=\"SD\"", "qualifier=\"DL\""));
  EXPECT_NE(first_error(dl).find("action qualifier DL is not supported"), std::string::npos)
      << first_error(dl);
}


// sfc_graph_conditions.xml: the chart S0 -> ... -> S6 -> S0 where each
// transition's condition is drawn another way (the file's comment lists them);
// each step waits until its condition's inputs say so, and no longer.
struct GraphChart {
  Machine run;
  explicit GraphChart(TaskImage img) : run(std::move(img)) {}
  std::string active() {
    std::string a;
    for (int i = 0; i <= 6; ++i) {
      if (run.value("s0.step.S" + std::to_string(i) + ".X") != 0) a += (a.empty() ? "S" : " S") + std::to_string(i);
    }
    return a;
  }
  std::string after(int n) {
    run.cycles(n);
    return active();
  }
};

TEST(PlcopenSfcConditions, fbd_and_ld_conditions_in_every_form_move_the_chart) {
  CompileResult r = compile_file(data("sfc_graph_conditions.xml"));
  ASSERT_TRUE(r.ok()) << r.diags.render("sfc_graph_conditions.xml", read_data("sfc_graph_conditions.xml"));
  GraphChart c(std::move(*r.image));
  Machine& m = c.run;
  EXPECT_EQ(c.after(2), "S0");
  m.set("level", 50);
  EXPECT_EQ(c.after(2), "S0") << "T1: GT(level, 80) drawn in the SFC body";
  m.set("level", 90);
  EXPECT_EQ(c.after(1), "S1");
  EXPECT_EQ(m.value("s0.seen"), 90) << "the inline FBD action of S1 ran";
  m.set("level", 95);
  m.set("b_in", 1);
  m.set("c_in", 1);
  EXPECT_EQ(c.after(2), "S1") << "T2: b_in AND NOT c_in, contacts drawn in the SFC body";
  EXPECT_EQ(m.value("s0.seen"), 95);
  EXPECT_EQ(m.value("s0.lamp"), 0);
  m.set("c_in", 0);
  EXPECT_EQ(c.after(1), "S2");
  EXPECT_EQ(m.value("s0.lamp"), 1) << "the inline LD action of S2 ran";
  m.set("level", 40);
  m.set("d_in", 1);
  EXPECT_EQ(c.after(2), "S2") << "T3: inline FBD AND(d_in, e_in)";
  EXPECT_EQ(m.value("s0.seen"), 95) << "S1's action does not run while S1 is inactive";
  m.set("e_in", 1);
  EXPECT_EQ(c.after(1), "S3");
  EXPECT_EQ(c.after(2), "S3") << "T4: inline LD coil t4 = d_in, condition negated";
  m.set("d_in", 0);
  m.set("e_in", 0);
  EXPECT_EQ(c.after(1), "S4");
  EXPECT_EQ(c.after(2), "S4") << "T5: inline LD, what reaches the right rail: e_in";
  m.set("e_in", 1);
  EXPECT_EQ(c.after(1), "S5");
  EXPECT_EQ(c.after(2), "S5") << "T6: named FBD transition t_fbd = LT(level, 5)";
  m.set("level", 2);
  EXPECT_EQ(c.after(1), "S6");
  EXPECT_EQ(c.after(2), "S6") << "T7: named LD transition t_ld = f_in";
  m.set("f_in", 1);
  EXPECT_EQ(c.after(1), "S0");
  EXPECT_EQ(m.value("s0.lamp"), 1) << "an action body's variable keeps its value after the step";
}

TEST(PlcopenSfcConditions, a_chart_with_drawn_conditions_reads_for_the_net_builder) {
  DiagnosticList d;
  std::optional<sfc::Chart> chart = plcopen::read_sfc_pou(read_data("sfc_graph_conditions.xml"), "", d);
  ASSERT_TRUE(chart) << (d.items().empty() ? "" : d.items()[0].message);
  EXPECT_EQ(chart->steps.size(), 7u);
  EXPECT_EQ(chart->transitions.size(), 7u);
}

// IL conditions: the current result at the end of the body, inline or in a
// named transition.
TEST(PlcopenSfcConditions, il_conditions_are_the_current_result_at_the_end) {
  const std::string pos = "<position x=\"0\" y=\"0\"/>";
  const std::string src = project(
      kNs201,
      "<pou name=\"main\" pouType=\"program\"><interface><inputVars>" + var("a", "BOOL", "%IX0.0") +
          var("b", "BOOL", "%IX0.1") + var("level", "INT", "%IW0") + "</inputVars></interface>"
          "<transitions><transition name=\"t_back\"><body><IL><xhtml:p><![CDATA[LD level\nLT 5\nANDN b]]></xhtml:p>"
          "</IL></body></transition></transitions><body><SFC>"
          "<step localId=\"1\" name=\"A\" initialStep=\"true\">" + pos +
          "<connectionPointIn><connection refLocalId=\"4\"/></connectionPointIn><connectionPointOut formalParameter=\"\"/></step>"
          "<transition localId=\"2\">" + pos + "<connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn>"
          "<connectionPointOut/><condition><inline name=\"\"><IL><xhtml:p><![CDATA[LD a\nAND( b\nOR TRUE\n)]]></xhtml:p></IL>"
          "</inline></condition></transition>"
          "<step localId=\"3\" name=\"B\">" + pos +
          "<connectionPointIn><connection refLocalId=\"2\"/></connectionPointIn><connectionPointOut formalParameter=\"\"/></step>"
          "<transition localId=\"4\">" + pos + "<connectionPointIn><connection refLocalId=\"3\"/></connectionPointIn>"
          "<connectionPointOut/><condition><reference name=\"t_back\"/></condition></transition>"
          "</SFC></body></pou>\n");
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine m(std::move(*r.image));
  m.set("level", 50);
  m.cycles(2);
  EXPECT_EQ(m.value("main.step.A.X"), 1);
  m.set("a", 1);
  m.cycles(1);
  EXPECT_EQ(m.value("main.step.B.X"), 1);
  m.set("level", 3);
  m.set("b", 1);
  m.cycles(2);
  EXPECT_EQ(m.value("main.step.B.X"), 1) << "level < 5 AND NOT b";
  m.set("b", 0);
  m.cycles(1);
  EXPECT_EQ(m.value("main.step.A.X"), 1);
}

// What is still refused, each with the element to blame and its line.
TEST(PlcopenSfcConditions, refuses_what_a_graphical_condition_cannot_say_with_its_line) {
  const std::string xml = read_data("sfc_graph_conditions.xml");
  struct Case {
    std::string from, to;  // the edit of the file
    std::string message;
    std::string at;  // text on the line the error points at
  } cases[] = {
      {"<connection refLocalId=\"102\" formalParameter=\"OUT\"/></connectionPointIn></condition>",
       "<connection refLocalId=\"1\"/></connectionPointIn></condition>",
       "the condition of transition localId 2 is connected to localId 1, an SFC element",
       "<condition><connectionPointIn><connection refLocalId=\"102\""},
      {"<connection refLocalId=\"112\"/></connectionPointIn></condition>", "</connectionPointIn></condition>",
       "the condition of transition localId 4 has nothing connected to it",
       "<condition><connectionPointIn><connection refLocalId=\"112\""},
      {"<expression>t_fbd</expression>", "<expression>seen</expression>",
       "transition 't_fbd' has no outVariable named 't_fbd' in its FBD body", "<transition name=\"t_fbd\">"},
      {"<coil localId=\"3\">", "<coil localId=\"3\" storage=\"set\">",
       "a set coil cannot give a transition its value", "<coil localId=\"3\">"},
      {"<rightPowerRail localId=\"4\">",
       "<coil localId=\"5\"><position x=\"0\" y=\"0\"/><connectionPointIn><connection refLocalId=\"1\"/>"
       "</connectionPointIn><variable>t_ld</variable></coil>\n<rightPowerRail localId=\"4\">",
       "transition 't_ld' is written twice in its body (localId 3 and 5)", "<rightPowerRail localId=\"4\">"},
      {"<inline name=\"t3\">", "<inline name=\"\">",
       "an inline FBD condition needs <inline name=...> and an outVariable of that name", "<inline name=\"t3\">"},
      {"<condition><reference name=\"t_fbd\"/></condition>",
       "<condition><inline name=\"x\"><SFC/></inline></condition>",
       "an inline transition condition in SFC is not supported", "<condition><reference name=\"t_fbd\"/>"},
  };
  for (const Case& k : cases) {
    std::string text = edited(xml, k.from, k.to);
    CompileResult r = compile_source(text);
    uint32_t line = 0;
    const std::string got = first_error(r, &line);
    EXPECT_NE(got.find(k.message), std::string::npos) << "got: " << got;
    EXPECT_EQ(line, line_of(xml, k.at)) << k.message;
  }
}

}  // namespace
}  // namespace rtplc::lang
