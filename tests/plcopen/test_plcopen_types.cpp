// User data types in PLCopen projects (docs/plcopen.md, "User data types"):
// structures, enumerations, arrays (bounds, several dimensions, indices known
// at compile time or only at run time), aliases and subranges, with their
// initial values, run cycle by cycle.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "lang/compiler.h"
#include "tests/plcopen/plcopen_harness.h"

namespace rtplc::lang {
namespace {

std::string project_with_types(const std::string& types, const std::string& pous) {
  std::string p = project(kNs201, pous);
  const std::string empty = "<dataTypes/>";
  p.replace(p.find(empty), empty.size(), "<dataTypes>" + types + "</dataTypes>");
  return p;
}

const std::string kPoint =
    "<dataType name=\"Point\"><baseType><struct>"
    "<variable name=\"x\"><type><REAL/></type><initialValue><simpleValue value=\"1.5\"/></initialValue></variable>"
    "<variable name=\"n\"><type><INT/></type></variable>"
    "</struct></baseType></dataType>";
const std::string kMode =
    "<dataType name=\"Mode\"><baseType><enum><values><value name=\"Idle\"/><value name=\"Fill\"/>"
    "<value name=\"Drain\"/></values></enum></baseType><initialValue><simpleValue value=\"Fill\"/></initialValue>"
    "</dataType>";

std::string typed(const std::string& name, const std::string& type_xml, const std::string& init_xml = "",
                  const std::string& addr = "") {
  return "<variable name=\"" + name + "\"" + (addr.empty() ? "" : " address=\"" + addr + "\"") + "><type>" +
         type_xml + "</type>" + (init_xml.empty() ? "" : "<initialValue>" + init_xml + "</initialValue>") +
         "</variable>";
}

std::string first_error(const std::string& src) {
  CompileResult r = compile_source(src);
  EXPECT_FALSE(r.ok());
  if (r.ok() || r.diags.items().empty()) return "";
  EXPECT_GT(r.diags.items()[0].pos.line, 0u) << r.diags.items()[0].message;
  return r.diags.items()[0].message;
}

TEST(PlcopenTypes, a_structure_holds_its_members_with_their_initial_values) {
  const std::string src = project_with_types(
      kPoint, st_program("<localVars>" +
                             typed("p", "<derived name=\"Point\"/>",
                                   "<structValue><value member=\"n\"><simpleValue value=\"3\"/></value></structValue>") +
                             var("y", "REAL") + "</localVars>",
                         "p.x := p.x + 1.0;\np.n := p.n + 1;\ny := p.x * 2.0;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  const auto& vars = r.program.variables;
  EXPECT_NE(std::find(vars.begin(), vars.end(), "main.p.x"), vars.end());  // a `rtplc sim` column
  Machine m(std::move(*r.image));
  m.cycles(2);
  EXPECT_DOUBLE_EQ(m.value("main.p.x"), 3.5);
  EXPECT_EQ(m.value("main.p.n"), 5);
  EXPECT_DOUBLE_EQ(m.value("main.y"), 7.0);
}

TEST(PlcopenTypes, an_enumeration_is_an_int_of_its_value_positions) {
  const std::string src = project_with_types(
      kMode, st_program("<inputVars>" + var("full", "BOOL", "%IX0.0") + var("empty", "BOOL", "%IX0.1") +
                            "</inputVars><localVars>" + typed("mode", "<derived name=\"Mode\"/>") + var("inlet", "BOOL") +
                            var("code", "INT") + "</localVars>",
                        "CASE mode OF\n  Idle: inlet := FALSE; IF empty THEN mode := Mode#Fill; END_IF;\n"
                        "  Fill: inlet := TRUE; IF full THEN mode := Drain; END_IF;\n"
                        "  Mode#Drain: inlet := FALSE; IF empty THEN mode := Idle; END_IF;\nEND_CASE;\ncode := mode;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine m(std::move(*r.image));
  m.cycles(1);
  EXPECT_EQ(m.value("main.code"), 1);  // the type's initial value, Fill
  EXPECT_EQ(m.value("main.inlet"), 1);
  m.set("full", 1);
  m.cycles(1);
  EXPECT_EQ(m.value("main.code"), 2);
  m.set("full", 0);
  m.set("empty", 1);
  m.cycles(1);
  EXPECT_EQ(m.value("main.code"), 0);
  m.cycles(1);
  EXPECT_EQ(m.value("main.code"), 1);
}

TEST(PlcopenTypes, arrays_take_constant_unrolled_and_run_time_indices) {
  const std::string arr = "<array><dimension lower=\"1\" upper=\"5\"/><baseType><INT/></baseType></array>";
  const std::string init =
      "<arrayValue><value><simpleValue value=\"1\"/></value><value><simpleValue value=\"2\"/></value>"
      "<value repetitionValue=\"3\"><simpleValue value=\"7\"/></value></arrayValue>";
  const std::string src = project(
      kNs201, st_program("<inputVars>" + var("k", "INT", "%IW0") + var("v", "INT", "%IW1") + "</inputVars><localVars>" +
                             typed("a", arr, init) + var("i", "INT") + var("sum", "INT") + var("at_k", "INT") +
                             var("first", "INT") + "</localVars>",
                         "sum := 0;\nFOR i := 1 TO 5 DO sum := sum + a[i]; END_FOR;\n"
                         "at_k := a[k];\nfirst := a[1];\nIF v > 0 THEN a[k] := v; END_IF;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine m(std::move(*r.image));
  m.set("k", 4);
  m.cycles(1);
  EXPECT_EQ(m.value("main.sum"), 1 + 2 + 7 + 7 + 7);
  EXPECT_EQ(m.value("main.at_k"), 7);
  m.set("v", 100);  // a[4] := 100, read back next cycle
  m.cycles(2);
  EXPECT_EQ(m.value("main.a[4]"), 100);
  EXPECT_EQ(m.value("main.a[3]"), 7);
  EXPECT_EQ(m.value("main.at_k"), 100);
  EXPECT_EQ(m.value("main.sum"), 1 + 2 + 7 + 100 + 7);
  m.set("k", 9);  // out of range: reads 0, writes nothing
  m.cycles(1);
  EXPECT_EQ(m.value("main.at_k"), 0);
  EXPECT_EQ(m.value("main.sum"), 1 + 2 + 7 + 100 + 7);
  EXPECT_EQ(m.value("main.first"), 1);
}

TEST(PlcopenTypes, two_dimensions_arrays_of_structures_and_of_timers) {
  const std::string grid = "<array><dimension lower=\"0\" upper=\"1\"/><dimension lower=\"0\" upper=\"2\"/>"
                           "<baseType><REAL/></baseType></array>";
  const std::string pts = "<array><dimension lower=\"0\" upper=\"2\"/><baseType><derived name=\"Point\"/></baseType></array>";
  const std::string tons = "<array><dimension lower=\"1\" upper=\"2\"/><baseType><derived name=\"TON\"/></baseType></array>";
  const std::string src = project_with_types(
      kPoint, st_program("<inputVars>" + var("go", "BOOL", "%IX0.0") + "</inputVars><localVars>" + typed("g", grid) +
                             typed("pts", pts) + typed("t", tons) + var("i", "INT") + var("j", "INT") +
                             var("total", "REAL") + var("q", "BOOL") + "</localVars>",
                         "FOR i := 0 TO 1 DO FOR j := 0 TO 2 DO g[i, j] := i * 10 + j; END_FOR; END_FOR;\n"
                         "total := 0.0;\nFOR i := 0 TO 2 DO pts[i].x := g[1, i]; total := total + pts[i].x + pts[i].n; END_FOR;\n"
                         "t[2](IN := go, PT := T#30ms);\nq := t[2].Q;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  const double dt = r.image->period_s();
  Machine m(std::move(*r.image));
  m.cycles(1);
  EXPECT_EQ(m.value("main.g[1,2]"), 12);
  EXPECT_DOUBLE_EQ(m.value("main.pts[2].x"), 12);
  EXPECT_DOUBLE_EQ(m.value("main.total"), 10 + 11 + 12);
  m.set("go", 1);
  m.cycles(static_cast<int>(std::ceil(0.03 / dt)) + 1);
  EXPECT_EQ(m.value("main.q"), 1);
}

TEST(PlcopenTypes, aliases_and_subranges_take_their_base_type) {
  const std::string types =
      "<dataType name=\"Percent\"><baseType><subrangeSigned><range lower=\"0\" upper=\"100\"/>"
      "<baseType><INT/></baseType></subrangeSigned></baseType><initialValue><simpleValue value=\"50\"/></initialValue></dataType>"
      "<dataType name=\"Level\"><baseType><derived name=\"Percent\"/></baseType></dataType>";
  const std::string src = project_with_types(
      types, st_program("<localVars>" + typed("l", "<derived name=\"Level\"/>") + var("h", "REAL") + "</localVars>",
                        "l := l + 1;\nh := l / 4;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine m(std::move(*r.image));
  m.cycles(1);
  EXPECT_EQ(m.value("main.l"), 51);  // the subrange type's initial value, then + 1
  EXPECT_EQ(m.value("main.h"), 12);  // INT division
}

TEST(PlcopenTypes, fbd_variables_name_members_and_elements) {
  const std::string pos = "<position x=\"0\" y=\"0\"/>";
  const std::string arr = "<array><dimension lower=\"0\" upper=\"3\"/><baseType><REAL/></baseType></array>";
  const std::string src = project_with_types(
      kPoint,
      "<pou name=\"main\" pouType=\"program\"><interface><localVars>" + typed("p", "<derived name=\"Point\"/>") +
          typed("a", arr) + "</localVars></interface><body><FBD>"
          "<inVariable localId=\"1\">" + pos + "<connectionPointOut/><expression>p.x</expression></inVariable>"
          "<block localId=\"2\" typeName=\"MUL\">" + pos + "<inputVariables>"
          "<variable formalParameter=\"IN1\"><connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn></variable>"
          "<variable formalParameter=\"IN2\"><connectionPointIn><connection refLocalId=\"3\"/></connectionPointIn></variable>"
          "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"OUT\"><connectionPointOut/></variable></outputVariables></block>"
          "<inVariable localId=\"3\">" + pos + "<connectionPointOut/><expression>4.0</expression></inVariable>"
          "<outVariable localId=\"4\">" + pos + "<connectionPointIn><connection refLocalId=\"2\"/></connectionPointIn><expression>a[2]</expression></outVariable>"
          "</FBD></body></pou>\n");
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine m(std::move(*r.image));
  m.cycles(1);
  EXPECT_DOUBLE_EQ(m.value("main.a[2]"), 6.0);  // p.x starts at 1.5
  EXPECT_DOUBLE_EQ(m.value("main.a[1]"), 0.0);
}

TEST(PlcopenTypes, refuses_what_it_cannot_hold_with_the_place) {
  const std::string arr = "<array><dimension lower=\"1\" upper=\"3\"/><baseType><INT/></baseType></array>";
  const std::string locals = "<localVars>" + typed("a", arr) + typed("p", "<derived name=\"Point\"/>") +
                             typed("q", "<derived name=\"Point\"/>") + var("x", "INT") + "</localVars>";
  EXPECT_NE(first_error(project_with_types(kPoint, st_program(locals, "x := a[4];"))).find("index 4 is outside a's bounds 1..3"),
            std::string::npos);
  EXPECT_NE(first_error(project_with_types(kPoint, st_program(locals, "x := p;"))).find("'p' is a structure: read one member at a time"),
            std::string::npos);
  EXPECT_NE(first_error(project_with_types(kPoint, st_program(locals, "x := p.z;"))).find("structure 'p' has no member 'z'"),
            std::string::npos);
  EXPECT_NE(first_error(project_with_types(kPoint, st_program(locals, "x := a[1, 2];"))).find("'a' has 1 dimension, indexed with 2"),
            std::string::npos);
  EXPECT_NE(first_error(project_with_types(
                kPoint, st_program("<localVars>" + typed("b", arr, "", "%MW0") + "</localVars>", "b[1] := 1;")))
                .find("an array or structure cannot be located"),
            std::string::npos);
  EXPECT_NE(first_error(project(kNs201, st_program("<localVars>" + typed("s", "<pointer><baseType><INT/></baseType></pointer>") + "</localVars>", "")))
                .find("type <pointer> is not supported here"),
            std::string::npos);
  EXPECT_NE(first_error(project_with_types(kMode, st_program("<localVars>" + typed("m", "<derived name=\"Mode\"/>",
                                                                                     "<simpleValue value=\"Boil\"/>") +
                                                                "</localVars>",
                                                            "")))
                .find("'Boil' is not a value of enumeration Mode"),
            std::string::npos);
}

// VAR_IN_OUT: the caller's variable, read and written by the callee.
TEST(PlcopenTypes, var_in_out_passes_the_callers_variable) {
  const std::string bump =
      "<pou name=\"Bump\" pouType=\"functionBlock\"><interface><inputVars>" + var("step", "INT", "", "1") +
      "</inputVars><inOutVars>" + var("x", "INT") +
      "</inOutVars></interface><body><ST><xhtml:p><![CDATA[x := x + step;]]></xhtml:p></ST></body></pou>\n";
  const std::string swap =
      "<pou name=\"Swap\" pouType=\"function\"><interface><returnType><BOOL/></returnType><inOutVars>" +
      var("a", "INT") + var("b", "INT") + "</inOutVars><localVars>" + var("tmp", "INT") +
      "</localVars></interface><body><ST><xhtml:p><![CDATA[tmp := a; a := b; b := tmp; Swap := TRUE;]]></xhtml:p></ST>"
      "</body></pou>\n";
  const std::string pos = "<position x=\"0\" y=\"0\"/>";
  const std::string src = project(
      kNs201,
      bump + swap +
          "<pou name=\"main\" pouType=\"program\"><interface><localVars>" + fb("b1", "Bump") + fb("b2", "Bump") +
          var("n", "INT") + var("m", "INT") + var("p", "INT", "", "1") + var("q", "INT", "", "2") + var("ok", "BOOL") +
          var("seen", "INT") + "</localVars></interface><body><FBD>"
          "<inVariable localId=\"1\">" + pos + "<connectionPointOut/><expression>m</expression></inVariable>"
          "<inVariable localId=\"2\">" + pos + "<connectionPointOut/><expression>5</expression></inVariable>"
          "<block localId=\"3\" typeName=\"Bump\" instanceName=\"b2\">" + pos + "<inputVariables>"
          "<variable formalParameter=\"step\"><connectionPointIn><connection refLocalId=\"2\"/></connectionPointIn></variable>"
          "</inputVariables><inOutVariables><variable formalParameter=\"x\"><connectionPointIn><connection refLocalId=\"1\"/>"
          "</connectionPointIn><connectionPointOut/></variable></inOutVariables><outputVariables/></block>"
          "<outVariable localId=\"4\">" + pos + "<connectionPointIn><connection refLocalId=\"3\" formalParameter=\"x\"/>"
          "</connectionPointIn><expression>seen</expression></outVariable>"
          "</FBD></body></pou>\n");
  // The FBD program above exercises the graphical form; an ST one the textual.
  const std::string st = project(
      kNs201, bump + swap + st_program("<localVars>" + fb("b1", "Bump") + var("n", "INT") + var("p", "INT", "", "1") +
                                           var("q", "INT", "", "2") + var("ok", "BOOL") + "</localVars>",
                                       "b1(step := 2, x := n);\nok := Swap(a := p, b := q);"));
  {
    CompileResult r = compile_source(st);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", st);
    Machine m(std::move(*r.image));
    m.cycles(1);
    EXPECT_EQ(m.value("main.n"), 2);
    EXPECT_EQ(m.value("main.p"), 2);
    EXPECT_EQ(m.value("main.q"), 1);
    EXPECT_EQ(m.value("main.ok"), 1);
    m.cycles(1);
    EXPECT_EQ(m.value("main.n"), 4);
    EXPECT_EQ(m.value("main.p"), 1);  // swapped back
  }
  {
    CompileResult r = compile_source(src);
    ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
    Machine m(std::move(*r.image));
    m.cycles(3);
    EXPECT_EQ(m.value("main.m"), 15);
    EXPECT_EQ(m.value("main.seen"), 15);  // the in-out's output side: m after the call
  }
  const std::string vars = "<inputVars>" + var("i", "INT", "%IW0") + "</inputVars><localVars>" + fb("b1", "Bump") +
                           var("n", "INT") + "</localVars>";
  EXPECT_NE(first_error(project(kNs201, bump + st_program(vars, "b1(x := n + 1);"))).find("needs a variable, not an expression"),
            std::string::npos);
  // Named at the call, not at the first use inside the block's body.
  EXPECT_NE(first_error(project(kNs201, bump + st_program(vars, "b1(step := 1);")))
                .find("function block 'Bump' has VAR_IN_OUT 'x', and this call passes no variable for it"),
            std::string::npos);
  // An input passed as VAR_IN_OUT may be written, as in MatIEC, until the next cycle reads it
  // again (tests/st/test_st_file.cpp, a_program_may_write_its_input_until_the_next_cycle).
  EXPECT_TRUE(compile_source(project(kNs201, bump + st_program(vars, "b1(x := i);"))).ok());
}

// Whole structures and arrays: assigned member by member, and passed to and
// from function blocks and functions by copy.
TEST(PlcopenTypes, whole_structures_and_arrays_are_copied_member_by_member) {
  const std::string arr = "<array><dimension lower=\"0\" upper=\"2\"/><baseType><INT/></baseType></array>";
  const std::string shift =
      "<pou name=\"Shift\" pouType=\"functionBlock\"><interface><inputVars>" + typed("pin", "<derived name=\"Point\"/>") +
      "</inputVars><outputVars>" + typed("pout", "<derived name=\"Point\"/>") + var("len", "REAL") +
      "</outputVars></interface><body><ST><xhtml:p><![CDATA[pout := pin; pout.x := pin.x + 10.0; len := pin.x * 2.0;]]>"
      "</xhtml:p></ST></body></pou>\n";
  const std::string sum =
      "<pou name=\"SumP\" pouType=\"function\"><interface><returnType><REAL/></returnType><inputVars>" +
      typed("pt", "<derived name=\"Point\"/>") +
      "</inputVars></interface><body><ST><xhtml:p><![CDATA[SumP := pt.x + pt.n;]]></xhtml:p></ST></body></pou>\n";
  const std::string src = project_with_types(
      kPoint, shift + sum +
                  st_program("<localVars>" + typed("p", "<derived name=\"Point\"/>") + typed("q", "<derived name=\"Point\"/>") +
                                 typed("r", "<derived name=\"Point\"/>") + typed("a", arr,
                                 "<arrayValue><value><simpleValue value=\"4\"/></value><value><simpleValue value=\"5\"/></value>"
                                 "<value><simpleValue value=\"6\"/></value></arrayValue>") + typed("b", arr) + fb("sh", "Shift") +
                                 var("y", "REAL") + var("z", "REAL") + "</localVars>",
                             "p.n := 7;\nq := p;\nb := a;\nsh(pin := q, pout => r);\ny := sh.len;\nz := SumP(pt := r);"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine m(std::move(*r.image));
  m.cycles(1);
  EXPECT_DOUBLE_EQ(m.value("main.q.x"), 1.5);  // Point's initial x
  EXPECT_EQ(m.value("main.q.n"), 7);
  EXPECT_EQ(m.value("main.b[2]"), 6);
  EXPECT_DOUBLE_EQ(m.value("main.r.x"), 11.5);
  EXPECT_EQ(m.value("main.r.n"), 7);
  EXPECT_DOUBLE_EQ(m.value("main.y"), 3.0);
  EXPECT_DOUBLE_EQ(m.value("main.z"), 18.5);
  // The same FB drawn in FBD: the structure input connected to an inVariable.
  const std::string pos = "<position x=\"0\" y=\"0\"/>";
  const std::string fbd = project_with_types(
      kPoint, shift + "<pou name=\"main\" pouType=\"program\"><interface><localVars>" +
                  typed("p", "<derived name=\"Point\"/>") + fb("sh", "Shift") + var("y", "REAL") +
                  "</localVars></interface><body><FBD>"
                  "<inVariable localId=\"1\">" + pos + "<connectionPointOut/><expression>p</expression></inVariable>"
                  "<block localId=\"2\" typeName=\"Shift\" instanceName=\"sh\">" + pos + "<inputVariables>"
                  "<variable formalParameter=\"pin\"><connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn></variable>"
                  "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"len\"><connectionPointOut/>"
                  "</variable></outputVariables></block>"
                  "<outVariable localId=\"3\">" + pos + "<connectionPointIn><connection refLocalId=\"2\" formalParameter=\"len\"/>"
                  "</connectionPointIn><expression>y</expression></outVariable></FBD></body></pou>\n");
  CompileResult rf = compile_source(fbd);
  ASSERT_TRUE(rf.ok()) << rf.diags.render("t.xml", fbd);
  Machine mf(std::move(*rf.image));
  mf.cycles(1);
  EXPECT_DOUBLE_EQ(mf.value("main.y"), 3.0);
  EXPECT_DOUBLE_EQ(mf.value("main.sh.pout.x"), 11.5);
  // A user function's structure input wired the same way.
  const std::string fn_fbd = project_with_types(
      kPoint, sum + "<pou name=\"main\" pouType=\"program\"><interface><localVars>" +
                  typed("p", "<derived name=\"Point\"/>") + var("y", "REAL") + "</localVars></interface><body><FBD>"
                  "<inVariable localId=\"1\">" + pos + "<connectionPointOut/><expression>p</expression></inVariable>"
                  "<block localId=\"2\" typeName=\"SumP\">" + pos + "<inputVariables>"
                  "<variable formalParameter=\"pt\"><connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn></variable>"
                  "</inputVariables><inOutVariables/><outputVariables><variable formalParameter=\"OUT\"><connectionPointOut/>"
                  "</variable></outputVariables></block>"
                  "<outVariable localId=\"3\">" + pos + "<connectionPointIn><connection refLocalId=\"2\"/></connectionPointIn>"
                  "<expression>y</expression></outVariable></FBD></body></pou>\n");
  CompileResult rfn = compile_source(fn_fbd);
  ASSERT_TRUE(rfn.ok()) << rfn.diags.render("t.xml", fn_fbd);
  Machine mfn(std::move(*rfn.image));
  mfn.cycles(1);
  EXPECT_DOUBLE_EQ(mfn.value("main.y"), 1.5);  // x 1.5 + n 0
  // A whole structure wired to a number's input is refused, not read as 0.
  std::string scalar = fbd;
  scalar.replace(scalar.find("formalParameter=\"pin\"><connectionPointIn><connection refLocalId=\"1\"/>"),
                 std::string("formalParameter=\"pin\"><connectionPointIn><connection refLocalId=\"1\"/>").size(),
                 "formalParameter=\"pin\"><connectionPointIn><connection refLocalId=\"4\"/>");
  scalar.replace(scalar.find("</FBD>"), 6,
                 "<outVariable localId=\"5\">" + pos + "<connectionPointIn><connection refLocalId=\"1\"/></connectionPointIn>"
                 "<expression>y</expression></outVariable><inVariable localId=\"4\">" + pos +
                 "<connectionPointOut/><expression>p</expression></inVariable></FBD>");
  EXPECT_NE(first_error(scalar).find("names a whole structure or array"), std::string::npos) << first_error(scalar);
  const std::string other = "<array><dimension lower=\"0\" upper=\"3\"/><baseType><INT/></baseType></array>";
  EXPECT_NE(first_error(project(kNs201, st_program("<localVars>" + typed("a", arr) + typed("c", other) + "</localVars>",
                                                   "c := a;")))
                .find("'c' and 'a' are not of one type"),
            std::string::npos);
  EXPECT_NE(first_error(project_with_types(kPoint, shift + st_program("<localVars>" + fb("sh", "Shift") + var("k", "REAL") +
                                                                          "</localVars>",
                                                                      "sh(pin := k);")))
                .find("'pin' is a structure or array: pass a variable of its type"),
            std::string::npos);
}

TEST(PlcopenTypes, dates_and_times_of_day_are_elementary_types) {
  // <DT/>, <TOD/>, <DATE/> as the editors write them, with literal initial
  // values; SUB_DT_DT is exact microseconds (docs/st.md, "Dates and times of day").
  const std::string src = project_with_types(
      "", st_program("<localVars>" + typed("a", "<DT/>", "<simpleValue value=\"DT#2024-02-29-23:59:59.25\"/>") +
                         typed("b", "<DATE_AND_TIME/>", "<simpleValue value=\"DT#2024-03-01-00:00:00.000001\"/>") +
                         typed("t", "<TOD/>", "<simpleValue value=\"TOD#06:00:00\"/>") +
                         typed("d", "<DATE/>") + var("gap", "TIME") + var("late", "BOOL") + "</localVars>",
                     "gap := SUB_DT_DT(b, a);\nd := DT_TO_DATE(b);\nlate := DT_TO_TOD(a) > t;"));
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("t.xml", src);
  Machine m(std::move(*r.image));
  m.cycles(1);
  EXPECT_EQ(m.value("main.gap"), 0.750001);
  EXPECT_EQ(m.value("main.d"), 1709164800 + 86400);  // 2024-03-01: 19783 days after 1970-01-01
  EXPECT_EQ(m.value("main.late"), 1);
}

}  // namespace
}  // namespace rtplc::lang
