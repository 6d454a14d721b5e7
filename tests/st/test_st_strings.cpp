// STRING (docs/st.md, "Strings"): variables with a declared or default length,
// literals with their `$` escapes, the standard's string functions, their
// edge cases, comparisons, conversions in MatIEC's and CODESYS's texts,
// strings kept across cycles and in real loops, and the verifier's checks.
// Expected values are worked by hand from the standard, MatIEC's library and
// CODESYS's documentation.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "blocks/image.h"
#include "blocks/string_ops.h"
#include "lang/compiler.h"
#include "sched/program.h"
#include "tests/st/first_error.h"
#include "tests/support/block_value.h"
#include "tests/support/fbd_harness.h"

namespace rtplc::lang {
namespace {

using testing::FbdHarness;

TEST(StStrings, the_standard_functions_and_their_edges) {
  const char* src = R"(PROGRAM Main
VAR
  s : STRING := 'ABCDE';
  n, f1, f2, f3, f4 : INT;
  l1, l2, r1, m1, m2, m3, m4, c1, i1, i2, i3, d1, d2, d3, d4, p1, p2, p3 : STRING;
END_VAR
  n := LEN(s);
  l1 := LEFT(s, 2);       l2 := LEFT(IN := s, L := 9);
  r1 := RIGHT(s, 3);
  m1 := MID(s, 2, 2);     m2 := MID(s, 9, 4);   m3 := MID(s, 2, 6);   m4 := MID(s, 2, 0);
  c1 := CONCAT('ab', 'cd', 'e');
  i1 := INSERT('ABC', 'XY', 2);  i2 := INSERT('ABC', 'XY', 0);  i3 := INSERT('ABC', 'XY', 7);
  d1 := DELETE('ABXYC', 2, 3);   d2 := DELETE('ABC', 1, 7);     d3 := DELETE('ABCDE', 9, 2);
  d4 := DELETE('ABC', 1, 0);
  p1 := REPLACE('ABCDE', 'XYZ', 1, 2);  p2 := REPLACE('ABCDE', 'X', 2, 3);  p3 := REPLACE('ABC', 'Z', 1, 9);
  f1 := FIND('ABCBC', 'BC');  f2 := FIND('AAB', 'AB');  f3 := FIND('ABCDE', 'XY');  f4 := FIND('ABC', '');
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("s.st", src);
  h.step();
  EXPECT_EQ(h.value("Main.n"), 5);
  EXPECT_EQ(h.text("Main.l1"), "AB");
  EXPECT_EQ(h.text("Main.l2"), "ABCDE");  // more than there is: all of it
  EXPECT_EQ(h.text("Main.r1"), "CDE");
  EXPECT_EQ(h.text("Main.m1"), "BC");
  EXPECT_EQ(h.text("Main.m2"), "DE");     // 9 from position 4: what is left
  EXPECT_EQ(h.text("Main.m3"), "");       // position past the end
  EXPECT_EQ(h.text("Main.m4"), "");       // position 0 (MatIEC reads its length byte there)
  EXPECT_EQ(h.text("Main.c1"), "abcde");
  EXPECT_EQ(h.text("Main.i1"), "ABXYC");
  EXPECT_EQ(h.text("Main.i2"), "XYABC");
  EXPECT_EQ(h.text("Main.i3"), "ABCXY");
  EXPECT_EQ(h.text("Main.d1"), "ABC");
  EXPECT_EQ(h.text("Main.d2"), "ABC");    // position past the end: nothing deleted
  EXPECT_EQ(h.text("Main.d3"), "A");      // more than is left: to the end
  EXPECT_EQ(h.text("Main.d4"), "ABC");    // position 0: nothing (MatIEC crashes)
  EXPECT_EQ(h.text("Main.p1"), "AXYZCDE");  // the standard's (MatIEC gives 'AXCDE')
  EXPECT_EQ(h.text("Main.p2"), "ABXE");
  EXPECT_EQ(h.text("Main.p3"), "ABCZ");
  EXPECT_EQ(h.value("Main.f1"), 2);
  EXPECT_EQ(h.value("Main.f2"), 2);       // (MatIEC's search misses it and gives 0)
  EXPECT_EQ(h.value("Main.f3"), 0);
  EXPECT_EQ(h.value("Main.f4"), 0);
}

TEST(StStrings, lengths_escapes_and_comparisons) {
  const char* src = R"(PROGRAM Main
VAR
  short : STRING[4] := 'abcdefg';
  cut : STRING(3);
  q : STRING := 'it$'s $$5$N$41';
  lt, gt, eq, ne, le : BOOL;
  grow : STRING[6];
END_VAR
  cut := CONCAT(short, 'xyz');
  lt := 'AB' < 'ABC' AND LT('A', 'AB', 'B') AND NOT GT('b', 'c', 'a') AND EQ(cut, 'abc', cut);
  gt := 'b' > 'abc';
  eq := '' = '';
  ne := short <> 'abcd';
  le := cut <= 'abc';
  grow := CONCAT(grow, 'ab');
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("s.st", src);
  h.step();
  EXPECT_EQ(h.text("Main.short"), "abcd");  // the initial value cut to the declared length
  EXPECT_EQ(h.text("Main.cut"), "abc");
  EXPECT_EQ(h.text("Main.q"), "it's $5\nA");
  EXPECT_EQ(h.value("Main.lt"), 1);
  EXPECT_EQ(h.value("Main.gt"), 1);
  EXPECT_EQ(h.value("Main.eq"), 1);
  EXPECT_EQ(h.value("Main.ne"), 0);
  EXPECT_EQ(h.value("Main.le"), 1);
  // Kept across cycles, never past its length.
  EXPECT_EQ(h.text("Main.grow"), "ab");
  h.step();
  EXPECT_EQ(h.text("Main.grow"), "abab");
  h.step(3);
  EXPECT_EQ(h.text("Main.grow"), "ababab");
}

TEST(StStrings, strings_in_real_loops_and_branches) {
  const char* src = R"(PROGRAM Main
VAR
  n AT %IW0 : INT;
  i : INT;
  acc, rev, word, joined : STRING;
  parts : ARRAY[1..3] OF STRING[4] := ['ab', 'c', 'def'];
END_VAR
  acc := '';
  FOR i := 1 TO n DO
    acc := CONCAT(acc, INT_TO_STRING(i));
    IF i MOD 2 = 0 THEN acc := CONCAT(acc, '-'); END_IF;
  END_FOR;
  joined := '';
  FOR i := n TO n + 2 DO
    joined := CONCAT(joined, parts[i MOD 3 + 1], '/');
    parts[i MOD 3 + 1] := CONCAT(parts[i MOD 3 + 1], 'x');
  END_FOR;
  word := 'stressed';
  rev := '';
  WHILE LEN(word) > 0 DO
    rev := CONCAT(rev, RIGHT(word, 1));
    word := LEFT(word, LEN(word) - 1);
  END_WHILE;
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("s.st", src);
  h.set("n", 5);
  h.step();
  EXPECT_EQ(h.text("Main.acc"), "12-34-5");
  EXPECT_EQ(h.text("Main.rev"), "desserts");
  EXPECT_EQ(h.text("Main.word"), "");
  // i = 5, 6, 7 read parts[3], parts[1], parts[2] before each gets its x.
  EXPECT_EQ(h.text("Main.joined"), "def/ab/c/");
  EXPECT_EQ(h.text("Main.parts[3]"), "defx");
  h.set("n", 0);
  h.step();
  EXPECT_EQ(h.text("Main.acc"), "");
  // i = 0, 1, 2: parts[1], [2], [3]; parts[3] stays at its length, 4.
  EXPECT_EQ(h.text("Main.joined"), "abx/cx/defx/");
  EXPECT_EQ(h.text("Main.parts[3]"), "defx");
}

// The conversions' texts and numbers, for both editors' runtimes.
TEST(StStrings, conversions_as_each_editor_writes_and_reads_them) {
  const char* src = R"(PROGRAM Main
VAR
  r : REAL := 0.1;
  lr : LREAL := 0.1;
  t1 : TIME := T#1s500ms;
  t2 : TIME := T#2d;
  b : BYTE := 255;
  sr, slr, st1, st2, sb, sbool, sint, stod, sdt : STRING;
  i1, i2, i3 : INT;
  by : BYTE;
  x1, x2 : REAL;
  ok : BOOL;
  tt : TIME;
END_VAR
  sr := REAL_TO_STRING(r);
  slr := LREAL_TO_STRING(lr);
  st1 := TIME_TO_STRING(t1);
  st2 := TIME_TO_STRING(t2);
  sb := BYTE_TO_STRING(b);
  sbool := BOOL_TO_STRING(TRUE);
  sint := INT_TO_STRING(-42);
  stod := TOD_TO_STRING(TOD#12:34:56.5);
  sdt := DT_TO_STRING(DT#2001-09-09-01:46:40);
  i1 := STRING_TO_INT('12.7');
  i2 := STRING_TO_INT('1_000');
  i3 := STRING_TO_INT('16#ff_ff');
  by := STRING_TO_BYTE('500');
  x1 := STRING_TO_REAL('1.5e3');
  x2 := STRING_TO_REAL('1e3');
  ok := STRING_TO_BOOL('true');
  tt := STRING_TO_TIME('T#2s');
END_PROGRAM
)";
  struct Want {
    EditorSemantics sem;
    const char *sr, *slr, *st1, *st2, *sb, *stod;
    double i2, i3, x2, tt;
  };
  for (const Want& w : {Want{EditorSemantics::kMatiec, "0.1000000015", "0.1", "T#0d0h0m1s500ms", "T#2d", "16#ff",
                             "TOD#12:34:56.500000", 1, -1, 1, 0},
                        Want{EditorSemantics::kCodesys, "0.1", "0.1", "T#1s500ms", "T#2d", "255", "TOD#12:34:56.500",
                             1000, -1, 1000, 2}}) {
    CompileOptions o;
    o.semantics = w.sem;
    CompileResult r = compile_source(src, o);
    ASSERT_TRUE(r.ok()) << r.diags.render("c.st", src);
    TaskArena arena(*r.image);
    execute_cycle(*r.image, arena);
    const int k = static_cast<int>(w.sem);
    EXPECT_EQ(testing::block_text(r, arena, "Main.sr"), w.sr) << k;
    EXPECT_EQ(testing::block_text(r, arena, "Main.slr"), w.slr) << k;
    EXPECT_EQ(testing::block_text(r, arena, "Main.st1"), w.st1) << k;
    EXPECT_EQ(testing::block_text(r, arena, "Main.st2"), w.st2) << k;
    EXPECT_EQ(testing::block_text(r, arena, "Main.sb"), w.sb) << k;
    EXPECT_EQ(testing::block_text(r, arena, "Main.sbool"), "TRUE") << k;
    EXPECT_EQ(testing::block_text(r, arena, "Main.sint"), "-42") << k;
    EXPECT_EQ(testing::block_text(r, arena, "Main.stod"), w.stod) << k;
    EXPECT_EQ(testing::block_text(r, arena, "Main.sdt"), "DT#2001-09-09-01:46:40") << k;
    EXPECT_EQ(testing::block_value(r, arena, "Main.i1"), 12) << k;
    EXPECT_EQ(testing::block_value(r, arena, "Main.i2"), w.i2) << k;
    EXPECT_EQ(testing::block_value(r, arena, "Main.i3"), w.i3) << k;
    EXPECT_EQ(testing::block_value(r, arena, "Main.by"), 244) << k;  // 500 wrapped into a BYTE
    EXPECT_EQ(testing::block_value(r, arena, "Main.x1"), 1500) << k;
    EXPECT_EQ(testing::block_value(r, arena, "Main.x2"), w.x2) << k;
    EXPECT_EQ(testing::block_value(r, arena, "Main.ok"), 1) << k;
    EXPECT_EQ(testing::block_value(r, arena, "Main.tt"), w.tt) << k;
  }
}

TEST(StStrings, what_is_refused_is_named_at_its_place) {
  auto err = [](const std::string& body, const std::string& decl = "s : STRING; n : INT;") {
    return testing::first_error("PROGRAM P\nVAR " + decl + " END_VAR\n" + body + "\nEND_PROGRAM\n");
  };
  EXPECT_NE(err("s := 5;").find("3:1: 's' is a STRING: convert the number"), std::string::npos) << err("s := 5;");
  EXPECT_NE(err("n := s;").find("a STRING assigned to 'n'"), std::string::npos) << err("n := s;");
  EXPECT_NE(err("s := s + 'x';").find("does not take STRINGs: join them with CONCAT"), std::string::npos);
  EXPECT_NE(err("IF s THEN n := 1; END_IF;").find("a STRING where a number is needed"), std::string::npos);
  EXPECT_NE(err("s := 'a$qb';").find("3:6: unknown escape $q"), std::string::npos) << err("s := 'a$qb';");
  EXPECT_NE(err("s := \"wide\";").find("WSTRING"), std::string::npos);
  EXPECT_NE(err("n := ABS(s);").find("ABS does not take a STRING"), std::string::npos);
  EXPECT_NE(err("s := LEFT(s);").find("LEFT takes 2 arguments (IN, L)"), std::string::npos) << err("s := LEFT(s);");
  EXPECT_NE(err("s := MID(s, 'a', 1);").find("MID's L is a number"), std::string::npos);
  EXPECT_NE(err("", "s : STRING[0];").find("a STRING of 0 characters: 1 to 1024"), std::string::npos);
  EXPECT_NE(err("", "s AT %MW0 : STRING;").find("a STRING at %MW0 is not supported yet"), std::string::npos);
}

// The verifier: a string input must read a whole string.
TEST(StStrings, the_verifier_refuses_a_string_input_that_reads_a_number) {
  const char* src = "PROGRAM P\nVAR s : STRING := 'ab'; n : INT; k : INT; END_VAR\nn := LEN(s); k := k + 1;\nEND_PROGRAM\n";
  CompileResult r = compile_source(src, {});
  ASSERT_TRUE(r.ok()) << r.diags.render("v.st", src);
  std::vector<std::byte> bytes(r.image->bytes().begin(), r.image->bytes().end());
  ASSERT_TRUE(verify_image(bytes).ok());
  const ImageHeader& h = r.image->header();
  uint32_t number_slot = UINT32_MAX;
  for (const Instr& in : r.image->code()) {
    if (op_writes_value(in.op) && !op_output_string(in.op)) number_slot = in.out;
  }
  ASSERT_NE(number_slot, UINT32_MAX);
  bool changed = false;
  for (uint32_t i = 0; i < h.n_instr; ++i) {
    auto* in = reinterpret_cast<Instr*>(bytes.data() + h.off_instr) + i;
    if (in->op != Op::SLen) continue;
    in->in[0] = number_slot;
    changed = true;
  }
  ASSERT_TRUE(changed);
  const auto v = verify_image(bytes);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.error().find("a string input reads no string"), std::string::npos) << v.error();
}

// Reading a string never goes past the value arena, whatever its length slot holds.
TEST(StStrings, a_wild_length_reads_within_the_arena) {
  std::vector<double> v = {1e9, 65, 66, 67};
  EXPECT_EQ(string_value(v.data(), 4, 0), "ABC");
  v[0] = -3;
  EXPECT_EQ(string_value(v.data(), 4, 0), "");
  v[0] = 2;
  EXPECT_EQ(string_value(v.data(), 4, 0), "AB");
  EXPECT_EQ(string_value(v.data(), 4, 7), "");
}


// A swap keeps a string variable whose length stays, and starts one whose
// length changed afresh (sched/program.h, plan_migration).
TEST(StStrings, a_swap_keeps_a_string_of_the_same_length) {
  const char* v1 = "PROGRAM P\nVAR s : STRING[8]; t : STRING[4]; END_VAR\ns := CONCAT(s, 'a'); t := CONCAT(t, 'b');\nEND_PROGRAM\n";
  const char* v2 = "PROGRAM P\nVAR s : STRING[8]; t : STRING[6]; END_VAR\ns := CONCAT(s, 'c'); t := CONCAT(t, 'd');\nEND_PROGRAM\n";
  CompileResult a = compile_source(v1, {}), b = compile_source(v2, {});
  ASSERT_TRUE(a.ok() && b.ok());
  TaskArena old_arena(*a.image);
  for (int k = 0; k < 3; ++k) execute_cycle(*a.image, old_arena);
  EXPECT_EQ(testing::block_text(a, old_arena, "P.s"), "aaa");
  const sched::Migration m = sched::plan_migration(*a.image, *b.image);
  TaskArena next(*b.image);
  sched::apply_migration(m, old_arena, next);
  execute_cycle(*b.image, next);
  EXPECT_EQ(testing::block_text(b, next, "P.s"), "aaac");
  EXPECT_EQ(testing::block_text(b, next, "P.t"), "d");  // STRING[4] became STRING[6]: reset
}


// The header every Beremiz build/plc.st starts with: LOGGER takes a STRING and
// holds C code in a nested pragma `{{ ... }}`, which rtplc skips whole.
TEST(StStrings, the_beremiz_logger_header_compiles_and_runs) {
  const char* src = R"(TYPE
  LOGLEVEL : (CRITICAL, WARNING, INFO, DEBUG) := INFO;
END_TYPE

FUNCTION_BLOCK LOGGER
  VAR_INPUT
    TRIG : BOOL;
    MSG : STRING;
    LEVEL : LOGLEVEL := INFO;
  END_VAR
  VAR
    TRIG0 : BOOL;
  END_VAR
  IF TRIG AND NOT TRIG0 THEN
  {{
   LogMessage(GetFbVar(LEVEL),(char*)GetFbVar(MSG, .body),GetFbVar(MSG, .len));
  }}
  END_IF;
  TRIG0:=TRIG;
END_FUNCTION_BLOCK

PROGRAM Main
VAR
  log : LOGGER;
  n : INT;
END_VAR
  n := n + 1;
  log(TRIG := n MOD 2 = 0, MSG := CONCAT('n = ', INT_TO_STRING(n)));
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("plc.st", src);
  EXPECT_EQ(h.result().diags.warning_count(), 0u) << h.result().diags.render("plc.st", src);
  h.step(3);
  EXPECT_EQ(h.text("Main.log.MSG"), "n = 3");
  EXPECT_EQ(h.value("Main.log.TRIG0"), 0);
}


// A shared string literal first used inside a loop that takes no iteration is
// still written (constants run before any branch).
TEST(StStrings, a_literal_first_used_in_an_empty_loop_is_still_there) {
  const char* src = R"(PROGRAM Main
VAR i, n : INT; s, t : STRING; b : BOOL; END_VAR
  FOR i := 1 TO n DO
    s := CONCAT(s, 'abc');
  END_FOR;
  t := 'abc';
  b := t = 'abc';
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("s.st", src);
  h.step();
  EXPECT_EQ(h.text("Main.t"), "abc");
  EXPECT_EQ(h.text("Main.s"), "");
}

// Variables exchanged inside a real loop: the loop's homes take their values
// at once (a parallel assignment), for strings as for numbers and BOOLs.
TEST(StStrings, values_swapped_inside_a_loop_stay_swapped) {
  const char* src = R"(PROGRAM Main
VAR
  i, n : INT;
  a : STRING := 'A'; b : STRING := 'B'; tmp : STRING;
  x : LREAL := 1; y : LREAL := 2; z : LREAL;
  p : BOOL := TRUE; q : BOOL; r : BOOL;
END_VAR
  n := n + 1;
  i := 0;
  WHILE i < n DO
    tmp := a; a := b; b := tmp;
    z := x; x := y; y := z;
    r := p; p := q; q := r;
    i := i + 1;
  END_WHILE;
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("s.st", src);
  h.step();  // one swap
  EXPECT_EQ(h.text("Main.a"), "B");
  EXPECT_EQ(h.text("Main.b"), "A");
  EXPECT_EQ(h.value("Main.x"), 2);
  EXPECT_EQ(h.value("Main.y"), 1);
  EXPECT_EQ(h.value("Main.p"), 0);
  EXPECT_EQ(h.value("Main.q"), 1);
  h.step();  // two swaps: as it was
  EXPECT_EQ(h.text("Main.a"), "B");
  EXPECT_EQ(h.value("Main.x"), 2);
  EXPECT_EQ(h.value("Main.p"), 0);
  h.step();  // three: swapped
  EXPECT_EQ(h.text("Main.a"), "A");
  EXPECT_EQ(h.text("Main.b"), "B");
  EXPECT_EQ(h.value("Main.x"), 1);
  EXPECT_EQ(h.value("Main.p"), 1);
}

TEST(StStrings, more_refusals_and_typed_literals) {
  auto err = [](const std::string& body) {
    return testing::first_error("PROGRAM P\nVAR s : STRING; n : INT; END_VAR\n" + body + "\nEND_PROGRAM\n");
  };
  EXPECT_NE(err("s := CONCAT(IN0 := 'a', IN1 := 'b');").find("CONCAT has no input 'IN0'"), std::string::npos);
  EXPECT_NE(err("s := CONCAT(IN1 := 'a', IN101 := 'b');").find("CONCAT has no input 'IN101'"), std::string::npos);
  EXPECT_NE(err("s := CONCAT(IN1 := 'a', IN99999999999999999999999 := 'b');").find("has no input"), std::string::npos);
  EXPECT_NE(err("s := CONCAT(IN1 := 'a', IN1 := 'b');").find("CONCAT's IN1 is given twice"), std::string::npos);
  EXPECT_NE(err("s := DINT_TO_STRING(s);").find("DINT_TO_STRING takes a DINT, not a STRING"), std::string::npos);
  const char* src = R"(PROGRAM Main
VAR s, d, dt : STRING; END_VAR
  s := CONCAT(STRING#'typed', '!');
  d := DATE_TO_STRING(D#2024-02-29);
  dt := DT_TO_STRING(DT#2255-12-31-23:59:59);
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("s.st", src);
  h.step();
  EXPECT_EQ(h.text("Main.s"), "typed!");
  EXPECT_EQ(h.text("Main.d"), "D#2024-02-29");
  EXPECT_EQ(h.text("Main.dt"), "DT#2255-12-31-23:59:59");
}


std::string il_project(const std::string& vars, const std::string& il) {
  return R"(<?xml version="1.0"?>
<project xmlns="http://www.plcopen.org/xml/tc6.xsd" xmlns:xhtml="http://www.w3.org/1999/xhtml">
<types><dataTypes/><pous>
<pou name="main" pouType="program"><interface><localVars>)" +
         vars + R"(</localVars></interface><body><IL><xhtml:p><![CDATA[)" + il +
         R"(]]></xhtml:p></IL></body></pou></pous></types></project>
)";
}

// IL's current result may be a STRING on one way to a label and a number on
// another: it is refused only when an instruction uses it before loading.
TEST(StStrings, il_current_result_of_two_types_at_a_label) {
  const std::string vars = R"(<variable name="t"><type><string/></type></variable>
<variable name="i"><type><INT/></type></variable><variable name="b"><type><BOOL/></type></variable>)";
  {
    const std::string src = il_project(vars, "\n  LD b\n  JMPC skip\n  LD 'abc'\n  ST t\nskip:\n  LD 1\n  ST i\n");
    FbdHarness h(src, 0.1, true, true);
    ASSERT_TRUE(h.ok()) << h.result().diags.render("il.xml", src);
    h.step();
    EXPECT_EQ(h.text("main.t"), "abc");
    EXPECT_EQ(h.value("main.i"), 1);
  }
  {
    // A loop whose head falls in with a STRING and jumps back with a BOOL, and loads first.
    const std::string src = il_project(vars, "\n  LD 0\n  ST i\n  LD ''\n  ST t\nloop:\n  LD t\n  CONCAT 'ab'\n"
                                             "  ST t\n  LD i\n  ADD 1\n  ST i\n  LT 3\n  JMPC loop\n");
    FbdHarness h(src, 0.1, true, true);
    ASSERT_TRUE(h.ok()) << h.result().diags.render("il.xml", src);
    h.step();
    EXPECT_EQ(h.text("main.t"), "ababab");
  }
  const std::string used = il_project(vars, "\n  LD b\n  JMPC skip\n  LD 'abc'\nskip:\n  ST t\n");
  const CompileResult r = compile_source(used);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.diags.items()[0].message.find("ST uses the current result, which is a STRING on one way to the label"),
            std::string::npos)
      << r.diags.items()[0].message;
}


// WSTRING: UTF-16 code units, "..." literals with $hhhh, the same functions,
// conversions to and from STRING and numbers, shown as UTF-8.
TEST(StStrings, wstrings_hold_utf16_and_convert_to_and_from_strings) {
  const char* src = R"(PROGRAM Main
VAR
  w : WSTRING := "Grüße $20AC";
  w2 : WSTRING[4];
  clef : WSTRING := "$D834$DD1E!";
  s : STRING;
  back : WSTRING;
  n, nc, k, p : INT;
  eq : BOOL;
  num : WSTRING;
END_VAR
  w2 := CONCAT(w, "!");
  s := WSTRING_TO_STRING(w);
  back := STRING_TO_WSTRING('abc');
  n := LEN(w);
  nc := LEN(clef);
  eq := w2 = "Grüß";
  num := INT_TO_WSTRING(42);
  k := WSTRING_TO_INT("17");
  p := FIND(w, "$20AC");
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("w.st", src);
  h.step();
  EXPECT_EQ(h.text("Main.w"), "Grüße €");
  EXPECT_EQ(h.value("Main.n"), 7);        // code units: G r ü ß e, a blank, the euro sign
  EXPECT_EQ(h.value("Main.nc"), 3);       // U+1D11E is two code units, then '!'
  EXPECT_EQ(h.text("Main.clef"), "\xF0\x9D\x84\x9E!");
  EXPECT_EQ(h.text("Main.w2"), "Grüß");   // cut to 4 code units
  EXPECT_EQ(h.value("Main.eq"), 1);
  EXPECT_EQ(h.text("Main.s"), "Gr\xFC\xDF" "e ?");  // a unit up to 255 is that byte; the euro sign '?'
  EXPECT_EQ(h.text("Main.back"), "abc");
  EXPECT_EQ(h.text("Main.num"), "42");
  EXPECT_EQ(h.value("Main.k"), 17);
  EXPECT_EQ(h.value("Main.p"), 7);
  auto err = [](const std::string& body) {
    return testing::first_error("PROGRAM P\nVAR s : STRING; w : WSTRING; END_VAR\n" + body + "\nEND_PROGRAM\n");
  };
  EXPECT_NE(err("w := s;").find("'w' is a WSTRING: convert the STRING (STRING_TO_WSTRING)"), std::string::npos)
      << err("w := s;");
  EXPECT_NE(err("w := CONCAT(w, 'x');").find("CONCAT mixes a STRING and a WSTRING"), std::string::npos);
  EXPECT_NE(err("IF s = w THEN s := ''; END_IF;").find("a STRING and a WSTRING together"), std::string::npos);
  EXPECT_NE(err("w := \"$12\";").find("unknown escape $1"), std::string::npos) << err("w := \"$12\";");
}


// WSTRINGs in real loops keep their type (the loop's home is a WSTRING's),
// an array of them reads by a run-time index, and a comma inside a literal
// of an array's initial value belongs to the literal.
TEST(StStrings, wstrings_in_loops_and_arrays) {
  const char* src = R"(PROGRAM Main
VAR
  w : WSTRING;
  i, k : INT;
  wa : ARRAY[1..3] OF WSTRING[10] := ["p,q", "é", "€"];
  sa : ARRAY[1..2] OF STRING := ['a,b', 'c'];
  pick : WSTRING[10];
END_VAR
  w := "";
  i := 0;
  WHILE i < 2 DO
    w := CONCAT(w, "é€");
    i := i + 1;
  END_WHILE;
  k := k MOD 3 + 1;
  pick := wa[k];
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("w.st", src);
  h.step();
  EXPECT_EQ(h.text("Main.w"), "é€é€");
  EXPECT_EQ(h.text("Main.pick"), "p,q");
  EXPECT_EQ(h.text("Main.sa[1]"), "a,b");
  h.step(2);
  EXPECT_EQ(h.text("Main.pick"), "€");
}

TEST(StStrings, string_kinds_meet_only_converted_at_calls_and_choices) {
  auto err = [](const std::string& src) { return testing::first_error(src); };
  const std::string fb =
      "FUNCTION_BLOCK F\nVAR_IN_OUT io : STRING; END_VAR\nio := RIGHT(io, 1);\nEND_FUNCTION_BLOCK\n";
  EXPECT_NE(err(fb + "PROGRAM P\nVAR f : F; w : WSTRING; END_VAR\nf(io := w);\nEND_PROGRAM\n")
                .find("function block 'F''s VAR_IN_OUT 'io' is a STRING, and this call passes a WSTRING ('w')"),
            std::string::npos)
      << err(fb + "PROGRAM P\nVAR f : F; w : WSTRING; END_VAR\nf(io := w);\nEND_PROGRAM\n");
  const std::string decl = "PROGRAM P\nVAR s : STRING; w : WSTRING; END_VAR\n";
  EXPECT_NE(err(decl + "w := SEL(FALSE, w, s);\nEND_PROGRAM\n").find("a choice between a STRING and a WSTRING"),
            std::string::npos);
  EXPECT_NE(err(decl + "s := STRING#\"x\";\nEND_PROGRAM\n").find("STRING# takes '...'"), std::string::npos);
  EXPECT_NE(err(decl + "w := WSTRING#'x';\nEND_PROGRAM\n").find("WSTRING# takes \"...\""), std::string::npos);
}

// A VAR_TEMP starts from its initial value at every call and every cycle.
TEST(StStrings, var_temp_starts_afresh_at_every_call) {
  const char* src = R"(FUNCTION_BLOCK F
VAR_INPUT x : INT; END_VAR
VAR_OUTPUT last : INT; END_VAR
VAR_TEMP t : INT; note : STRING := 'n'; END_VAR
  t := t + x;
  note := CONCAT(note, 'x');
  last := t * 10 + LEN(note);
END_FUNCTION_BLOCK
PROGRAM Main
VAR f : F; a, b : INT; END_VAR
  f(x := 1);
  a := f.last;
  f(x := 2);
  b := f.last;
END_PROGRAM
)";
  FbdHarness h(src, 0.1, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", src);
  for (int cycle = 0; cycle < 3; ++cycle) {
    h.step();
    EXPECT_EQ(h.value("Main.a"), 12) << cycle;
    EXPECT_EQ(h.value("Main.b"), 22) << cycle;
  }
}

}  // namespace
}  // namespace rtplc::lang
