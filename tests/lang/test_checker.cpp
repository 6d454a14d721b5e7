// The checker: each diagnostic of the spec's "Errors" list at the right place,
// macro expansion with its own state per call, nesting, recursion, limits.
#include <gtest/gtest.h>

#include "lang/compiler.h"
#include "tests/support/fbd_harness.h"

namespace rtplc::lang {
namespace {

struct Found {
  bool ok;
  DiagnosticList diags;
};

Found compile(const std::string& src) {
  CompileResult r = compile_source(src);
  return {r.ok(), r.diags};
}

// Expects exactly one error at line:col whose message contains `text`.
void expect_error(const std::string& src, uint32_t line, uint32_t col, const std::string& text) {
  Found f = compile(src);
  EXPECT_FALSE(f.ok) << src;
  ASSERT_EQ(f.diags.error_count(), 1u) << f.diags.render("t", src);
  const Diagnostic* err = nullptr;
  for (const Diagnostic& d : f.diags.items()) {
    if (d.severity == Severity::kError) err = &d;
  }
  ASSERT_NE(err, nullptr);
  EXPECT_EQ(err->pos.line, line) << f.diags.render("t", src);
  EXPECT_EQ(err->pos.col, col) << f.diags.render("t", src);
  EXPECT_NE(err->message.find(text), std::string::npos) << err->message;
}

std::string body(const std::string& b) { return "%%\n" + b + "END\n"; }

TEST(Checker, unknown_block_with_a_suggestion) {
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = filter(F1, 2)\n"), 3, 6, "did you mean 'filt'");
}

// An IEC name in FBD text: the message says which primitives spell it.
TEST(Checker, an_iec_name_points_at_the_primitives_that_spell_it) {
  expect_error(body("D1 = dsp(d0, c0, 0, \"a\")\nD2 = TON(D1, 1)\n"), 3, 6,
               "IEC TON is written in FBD text as ton (Q), ton_et (ET)");
}

TEST(Checker, wrong_arity) {
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = sub(F1)\n"), 3, 6, "sub takes sub(a, b, [k])");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = abs(F1, F1)\n"), 3, 6, "found 2 arguments");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = pid(F1, F1, 1, 2)\n"), 3, 6, "pid takes");
}

TEST(Checker, analog_where_digital_is_needed_and_back) {
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nD2 = not(F1)\n"), 3, 10, "needs D<n>, but F1 is analog");
  expect_error(body("D1 = dsp(d0, c0, 1, \"a\")\nF2 = abs(D1)\n"), 3, 10, "needs F<n>, but D1 is digital");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nD2 = abs(F1)\n"), 3, 1, "name it F2");
}

TEST(Checker, undefined_and_duplicate_ids) {
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = add(F1, F9)\n"), 3, 14, "F9 is not defined");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF1 = abs(F1)\n"), 3, 1, "already defined (line 2)");
  expect_error(body("D1 = dsp(d0, c0, 1, \"a\")\nF2 = abs(F1)\n"), 3, 10, "D1 is, but it is digital");
}

TEST(Checker, parameters_are_literals_in_range) {
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = sub(F1, F1, F1)\n"), 3, 18, "must be a number");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = intg(F1, 0)\n"), 3, 15, "greater than 0");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = dely(F1, 2.5)\n"), 3, 15, "whole number");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = lim(F1, 3, -3)\n"), 3, 14, "above the upper limit");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = add(F1, 3)\n"), 3, 14, "constant input comes from");
}

TEST(Checker, device_addresses_labels_and_channels) {
  expect_error(body("F1 = dai(d0, d0, c0, \"a\")\n"), 2, 10, "processor address");
  expect_error(body("F1 = dai(p0, d0, c70000, \"a\")\n"), 2, 18, "out of range");
  expect_error(body("F1 = dai(p0, d0, c0, \"has space\")\n"), 2, 22, "may only use");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\ndao(F1, p0, d0, c0, \"x\")\ndao(F1, p0, d0, c0, \"y\")\n"),
               4, 1, "already written");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = asp(d0, c1, 1, \"a\")\n"), 3, 1, "already names");
  expect_error(body("D1 = dsp(d0, c0, 2, \"a\")\n"), 2, 18, "starts at 0 or 1");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF5 = dao(F1, p0, d0, c0, \"x\")\n"), 3, 1, "output block");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nabs(F1)\n"), 3, 1, "needs an id");
}

const char* kPidMacro =
    "MACRO PID(M1, M2, P1, P2, P3)\n{\nM3 = sub(M1, M2, 1)\nM4 = epi(M3, P1, P2)\n"
    "M5 = deriv(M2, P3)\nM7 = sub(M4, M5, 1)\nRETURN(M7)\n}\n";

TEST(Checker, macro_arity_is_checked_against_the_declaration) {
  expect_error("MACRO PID(2|0|3)\n%%\nF1 = asp(d0, c0, 1, \"a\")\nF2 = MACRO PID(F1, F1, 1, 2)\nEND\n%%\n" +
                   std::string(kPidMacro),
               4, 12, "takes 5 arguments");
  expect_error("MACRO PID(2|0|2)\n%%\nEND\n%%\n" + std::string(kPidMacro), 5, 7,
               "declared at line 1 as (2:0:2)");
  expect_error("%%\nEND\n%%\n" + std::string(kPidMacro), 4, 7, "not declared");
  expect_error("MACRO PID(2|0|3)\n%%\nF1 = asp(d0, c0, 1, \"a\")\nF2 = MACRO PID(F1, F1, F1, 2, 3)\nEND\n%%\n" +
                   std::string(kPidMacro),
               4, 24, "must be a number");
  expect_error("MACRO PID(2|0|3)\n%%\nD1 = dsp(d0, c0, 1, \"a\")\nF1 = asp(d0, c1, 1, \"b\")\n"
               "F2 = MACRO PID(D1, F1, 1, 2, 3)\nEND\n%%\n" + std::string(kPidMacro),
               5, 16, "must be an analog block id");
  expect_error("MACRO PID(2|0|3)\n%%\nF1 = asp(d0, c1, 1, \"b\")\n"
               "D2 = MACRO PID(F1, F1, 1, 2, 3)\nEND\n%%\n" + std::string(kPidMacro),
               4, 1, "name it F2");
}

TEST(Checker, macro_errors_return_missing_recursion_undeclared_call) {
  expect_error("MACRO A(1:0:0)\n%%\nEND\n%%\nMACRO A(M1)\n{\nM2 = abs(M1)\n}\n", 8, 1, "has no RETURN");
  expect_error("MACRO A(1:0:0)\nMACRO B(1:0:0)\n%%\nF1 = asp(d0, c0, 1, \"a\")\nF2 = MACRO A(F1)\nEND\n%%\n"
               "MACRO A(M1)\n{\nM2 = MACRO B(M1)\nRETURN(M2)\n}\n"
               "MACRO B(M1)\n{\nM2 = MACRO A(M1)\nRETURN(M2)\n}\n",
               15, 12, "recursive macro call: A -> B -> A");
  expect_error(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = MACRO NOPE(F1)\n"), 3, 12, "not declared");
  expect_error("MACRO A(1:0:0)\n%%\nF1 = asp(d0, c0, 1, \"a\")\nF2 = MACRO A(F1)\nEND\n", 4, 12,
               "no definition");
  expect_error("MACRO A(1:0:0)\n%%\nEND\n%%\nMACRO A(M1)\n{\nM2 = dai(p0, d0, c0, \"x\")\nRETURN(M2)\n}\n",
               7, 6, "I/O blocks are not allowed inside a macro");
  expect_error("MACRO A(1:0:0)\n%%\nEND\n%%\nMACRO A(M1)\n{\nM2 = abs(M9)\nRETURN(M2)\n}\n", 7, 10,
               "M9 is not defined in MACRO A");
  expect_error("MACRO A(1:0:0)\n%%\nEND\n%%\nMACRO A(M1)\n{\nM2 = abs(F1)\nRETURN(M2)\n}\n", 7, 10,
               "cannot see the program's blocks");
}

TEST(Checker, an_uncalled_macro_is_still_checked) {
  expect_error("MACRO A(1:0:1)\n%%\nEND\n%%\nMACRO A(M1, P1)\n{\nM2 = pidd(M1, P1)\nRETURN(M2)\n}\n",
               7, 6, "unknown block 'pidd'");
}

TEST(Checker, macro_size_limit) {
  std::string def = "MACRO BIG(M1)\n{\n";
  for (int i = 2; i < 60; ++i) def += "M" + std::to_string(i) + " = abs(M" + std::to_string(i - 1) + ")\n";
  def += "RETURN(M59)\n}\n";
  expect_error("MACRO BIG(1:0:0)\n%%\nF1 = asp(d0, c0, 1, \"a\")\nF2 = MACRO BIG(F1)\nEND\n%%\n" + def,
               7, 7, "expands to 58 primitive blocks, more than the limit of 50");
}

TEST(Checker, collects_several_errors_in_one_run) {
  Found f = compile(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = nope(F1)\nF3 = sub(F1)\nF4 = abs(F8)\n"
                         "D5 = abs(F1)\n"));
  EXPECT_EQ(f.diags.error_count(), 4u);
}

TEST(Checker, warns_about_a_computed_value_nobody_uses) {
  Found f = compile(body("F1 = asp(d0, c0, 1, \"a\")\nF2 = abs(F1)\n"));
  EXPECT_TRUE(f.ok);
  EXPECT_EQ(f.diags.warning_count(), 1u);
}

TEST(Checker, each_macro_call_has_its_own_state) {
  // Two calls of one integrating macro must not share the integrator.
  testing::FbdHarness h(
      "MACRO ACC(1:0:1)\n%%\nF1 = asp(d0, c0, 1, \"a\")\nF2 = asp(d0, c1, 10, \"b\")\n"
      "F3 = MACRO ACC(F1, 1)\nF4 = MACRO ACC(F2, 2)\nEND\n%%\n"
      "MACRO ACC(M1, P1)\n{\nM2 = intg(M1, P1)\nRETURN(M2)\n}\n",
      0.1, true, true);
  ASSERT_TRUE(h.ok());
  h.step(10);
  EXPECT_NEAR(h.value("F3.M2"), 10 * 1 * 0.1 / 1, 1e-12);
  EXPECT_NEAR(h.value("F4.M2"), 10 * 10 * 0.1 / 2, 1e-12);
}

TEST(Checker, nested_macros_expand_with_their_own_names_and_parameters) {
  testing::FbdHarness h(
      "MACRO OUTER(1:0:1)\nMACRO INNER(1:0:1)\n%%\nF1 = asp(d0, c0, 2, \"a\")\n"
      "F5 = MACRO OUTER(F1, 3)\nF6 = MACRO OUTER(F1, 10)\nEND\n%%\n"
      "MACRO OUTER(M1, P1)\n{\nM2 = MACRO INNER(M1, P1)\nM3 = MACRO INNER(M2, 2)\nRETURN(M3)\n}\n"
      "MACRO INNER(M1, P1)\n{\nM2 = scale(M1, P1, 1)\nRETURN(M2)\n}\n",
      0.1, true, true);
  ASSERT_TRUE(h.ok());
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F5.M2.M2"), 2 * 3 + 1);
  EXPECT_DOUBLE_EQ(h.value("F5.M3.M2"), (2 * 3 + 1) * 2 + 1);
  EXPECT_DOUBLE_EQ(h.value("F6.M3.M2"), (2 * 10 + 1) * 2 + 1);
  EXPECT_EQ(h.result().program.macro_calls, 6u);
}

TEST(Checker, a_forward_reference_into_a_macro_result_is_delayed) {
  testing::FbdHarness h(
      "MACRO ID(1:0:0)\n%%\nF1 = asp(d0, c0, 1, \"a\")\nF2 = add(F1, F3)\nF3 = MACRO ID(F2)\nEND\n%%\n"
      "MACRO ID(M1)\n{\nM2 = abs(M1)\nRETURN(M2)\n}\n",
      0.1, true, true);
  ASSERT_TRUE(h.ok());
  h.step();
  EXPECT_EQ(h.value("F2"), 1);  // F3 read last cycle's 0
  h.step();
  EXPECT_EQ(h.value("F2"), 2);
  h.step();
  EXPECT_EQ(h.value("F2"), 3);
}

TEST(Checker, period_comes_from_stime_or_defaults) {
  CompileResult a = compile_source("%%\nstime(0.25)\nEND\n");
  ASSERT_TRUE(a.ok());
  EXPECT_DOUBLE_EQ(a.image->period_s(), 0.25);
  CompileResult b = compile_source("%%\nEND\n");
  ASSERT_TRUE(b.ok());
  EXPECT_DOUBLE_EQ(b.image->period_s(), 0.1);
  CompileOptions o;
  o.period_override = 0.002;
  CompileResult c = compile_source("%%\nstime(0.25)\nEND\n", o);
  EXPECT_DOUBLE_EQ(c.image->period_s(), 0.002);
}

TEST(Checker, renders_file_line_col_the_line_and_a_caret) {
  std::string src = body("F1 = asp(d0, c0, 1, \"a\")\nF2 = filter(F1, 2)\n");
  std::string out = testing::diagnostics_of(src);
  EXPECT_NE(out.find("t.fbd:3:6: error: unknown block 'filter'"), std::string::npos) << out;
  EXPECT_NE(out.find(" 3 | F2 = filter(F1, 2)\n   |      ^~~~~~\n"), std::string::npos) << out;
}

}  // namespace
}  // namespace rtplc::lang
