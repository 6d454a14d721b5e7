// The parser: every construct of the file format, and recovery after errors.
#include <gtest/gtest.h>

#include "lang/lexer.h"
#include "lang/parser.h"

namespace rtplc::lang {
namespace {

Program parse_text(std::string_view s, DiagnosticList& d) { return parse(tokenize(s, d), d); }

TEST(Parser, reads_declarations_body_and_definitions) {
  DiagnosticList d;
  Program p = parse_text(
      "MACRO PID(2|0|3)\nMACRO SUBR (1:0:1)\n%%\nstime(0.05)\nF1 = dai(p0, d0, c0, \"PV\")\n"
      "F20 = MACRO SUBR(F1, -10)\ndao(F20, p0, d0, c0, \"MV\")\nEND\n%%\n"
      "MACRO SUBR(M1, P1)\n{\nM2 = scale(M1, P1, +2.5)\nRETURN(M2)\n}\n",
      d);
  ASSERT_FALSE(d.has_errors()) << d.render("t", "");
  ASSERT_EQ(p.decls.size(), 2u);
  EXPECT_EQ(p.decls[0].name, "PID");
  EXPECT_EQ(p.decls[0].n_analog, 2u);
  EXPECT_EQ(p.decls[0].n_params, 3u);
  EXPECT_EQ(p.decls[1].n_analog, 1u);
  EXPECT_TRUE(p.has_stime);
  EXPECT_DOUBLE_EQ(p.stime, 0.05);
  ASSERT_EQ(p.body.size(), 3u);
  EXPECT_TRUE(p.body[1].is_macro);
  EXPECT_EQ(p.body[1].args[1].number, -10);
  EXPECT_FALSE(p.body[2].has_target);
  EXPECT_EQ(p.body[2].args[4].text, "MV");
  ASSERT_EQ(p.defs.size(), 1u);
  EXPECT_EQ(p.defs[0].formals.size(), 2u);
  EXPECT_TRUE(p.defs[0].has_return);
  EXPECT_EQ(p.defs[0].ret.number, 2u);
  EXPECT_DOUBLE_EQ(p.defs[0].body[0].args[2].number, 2.5);
  EXPECT_TRUE(p.has_end);
}

TEST(Parser, accepts_a_missing_second_section_marker) {
  DiagnosticList d;
  Program p = parse_text("MACRO A(1:0:0)\n%%\nF1 = asp(d0, c0, 1, \"x\")\nEND\n"
                         "MACRO A(M1)\n{\nM2 = abs(M1)\nRETURN(M2)\n}\n",
                         d);
  EXPECT_FALSE(d.has_errors());
  EXPECT_EQ(p.defs.size(), 1u);
}

TEST(Parser, reports_missing_end) {
  DiagnosticList d;
  parse_text("%%\nF1 = asp(d0, c0, 1, \"x\")\n", d);
  ASSERT_EQ(d.error_count(), 1u);
  EXPECT_NE(d.items()[0].message.find("missing END"), std::string::npos);
  EXPECT_EQ(d.items()[0].pos.line, 3u);
}

TEST(Parser, reports_a_missing_section_marker_and_parses_on) {
  DiagnosticList d;
  Program p = parse_text("F1 = asp(d0, c0, 1, \"x\")\nEND\n", d);
  EXPECT_EQ(d.error_count(), 1u);
  EXPECT_EQ(p.body.size(), 1u);
}

TEST(Parser, recovers_at_the_next_line_and_reports_several_errors) {
  DiagnosticList d;
  Program p = parse_text("%%\nF1 = add(F2 F3)\nF4 = = sub(F1, F2)\nF5 = abs(F1)\n"
                         "F6 = add(F1,\nF7 = abs(F5)\nEND\n",
                         d);
  EXPECT_EQ(d.error_count(), 3u);
  EXPECT_EQ(d.items()[0].pos.line, 2u);
  EXPECT_EQ(d.items()[1].pos.line, 3u);
  EXPECT_EQ(d.items()[2].pos.line, 5u);  // the unclosed '(' is pointed at, not the next line
  // The good statements survive, including the one after the unclosed call.
  ASSERT_EQ(p.body.size(), 2u);
  EXPECT_EQ(p.body[0].target.number, 5u);
  EXPECT_EQ(p.body[1].target.number, 7u);
}

TEST(Parser, stime_errors) {
  DiagnosticList d;
  parse_text("%%\nstime(0)\nstime(0.1)\nstime(0.2)\nEND\n", d);
  EXPECT_EQ(d.error_count(), 2u);
  EXPECT_NE(d.items()[0].message.find("between"), std::string::npos);
  EXPECT_NE(d.items()[1].message.find("twice"), std::string::npos);
}

TEST(Parser, definition_errors_missing_return_and_statements_after_it) {
  DiagnosticList d;
  Program p = parse_text("MACRO A(1:0:0)\nMACRO B(1:0:0)\n%%\nEND\n%%\n"
                         "MACRO A(M1)\n{\nM2 = abs(M1)\n}\n"
                         "MACRO B(M1)\n{\nRETURN(M1)\nM3 = abs(M1)\n}\n",
                         d);
  ASSERT_EQ(p.defs.size(), 2u);
  EXPECT_FALSE(p.defs[0].has_return);
  EXPECT_EQ(d.error_count(), 1u);  // "missing RETURN" is the checker's; here: after RETURN
  EXPECT_NE(d.items()[0].message.find("after RETURN"), std::string::npos);
}

TEST(Parser, never_loops_on_stray_closing_tokens) {
  DiagnosticList d;
  parse_text("%%\n}\n}\n) ( , = | : RETURN\nEND\n} }", d);
  EXPECT_TRUE(d.has_errors());
}

}  // namespace
}  // namespace rtplc::lang
