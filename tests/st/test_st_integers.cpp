// Exact integer arithmetic in ST (docs/language.md, "Types"): a product on an
// integer type is computed in 64-bit integers and wrapped, in a real loop, in
// an unrolled one and when the compiler folds constants (the `imul` block's
// own edge cases are in tests/blocks/test_iec_blocks.cpp). The expected values are worked by hand (Python's
// unbounded integers: x = (x * 1103515245 + 12345) % 2**32).
#include <gtest/gtest.h>

#include <string>

#include "blocks/int_math.h"
#include "lang/compiler.h"
#include "tests/support/fbd_harness.h"

namespace rtplc::lang {
namespace {

using testing::FbdHarness;

// The UDINT linear congruential generator from seed 12345, 1,000 steps: its
// 32-bit products reach 2^62, past what a double holds exactly, so a double
// product wrapped afterwards gives 832443392. Exact: 1603858065.
constexpr double kLcg1000 = 1603858065;

// The generator, FOR i := 1 TO `to`; `n` is an input.
std::string generator(const std::string& to) {
  return "PROGRAM Main\nVAR\n  n AT %IW0 : INT;\n  x : UDINT;\n  i : INT;\nEND_VAR\n"
         "  x := 12345;\n  FOR i := 1 TO " + to + " DO\n    x := x * 1103515245 + 12345;\n  END_FOR;\n"
         "END_PROGRAM\n";
}

TEST(StIntegers, a_udint_generator_in_a_real_loop_is_exact) {
  const std::string src = generator("n");
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("lcg.st", src);
  h.set("n", 1000);
  h.step();
  EXPECT_EQ(h.value("Main.x"), kLcg1000);
  h.set("n", 1);
  h.step();
  EXPECT_EQ(h.value("Main.x"), 3554416254);  // 12345 * 1103515245 + 12345 mod 2^32
}

TEST(StIntegers, the_same_generator_unrolled_and_folded_is_exact) {
  // Constant bounds: the FOR is unrolled and every step folded at compile time
  // (before, the folded product grew unwrapped until the compiler refused an
  // infinite constant).
  const std::string src = generator("1000");
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("lcg.st", src);
  h.step();
  EXPECT_EQ(h.value("Main.x"), kLcg1000);
}

TEST(StIntegers, products_and_sums_wrap_in_their_type) {
  const char* src = R"(PROGRAM Main
VAR
  a AT %IW0 : DINT;
  b AT %IW1 : DINT;
  u : UDINT;
  k : UDINT;
  d : DINT;
  e : DINT;
  s : SINT;
  w : UINT;
END_VAR
  u := 4000000000;
  u := u * 3;          (* folded: 12,000,000,000 mod 2^32 *)
  k := 4000000000;
  k := k + 500000000;  (* folded: 4,500,000,000 mod 2^32 *)
  d := a * b;          (* at run time *)
  e := a * b * b;
  s := a * b;
  w := b - a;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("w.st", src);
  h.set("a", 100000);
  h.set("b", 100000);
  h.step();
  EXPECT_EQ(h.value("Main.u"), 3410065408);
  EXPECT_EQ(h.value("Main.k"), 205032704);
  EXPECT_EQ(h.value("Main.d"), 1410065408);   // 10^10 mod 2^32, below 2^31
  EXPECT_EQ(h.value("Main.e"), -1530494976);  // 1410065408 * 100000 mod 2^32 = 2764472320, read as DINT
  EXPECT_EQ(h.value("Main.s"), 0);            // DINT's 1410065408 = 16#540BE400, its low byte into SINT
  EXPECT_EQ(h.value("Main.w"), 0);
  h.set("a", -3);
  h.set("b", 1431655766);
  h.step();
  EXPECT_EQ(h.value("Main.d"), -2);           // -4294967298 + 2^32
  EXPECT_EQ(h.value("Main.w"), (1431655766 + 3) % 65536);
}

TEST(StIntegers, typed_literals_take_a_base) {
  const std::string src =
      "PROGRAM Main\nVAR\n  w : WORD;\n  d : DINT;\n  b : BYTE;\nEND_VAR\n"
      "  w := SHL(WORD#16#F0F0, 3) XOR 16#FF;\n  d := DINT#2#1010 + INT#-3;\n  b := BYTE#8#377;\nEND_PROGRAM\n";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", src);
  h.step();
  EXPECT_EQ(h.value("Main.w"), 0x877F);  // 16#F0F0 shifted 3 within 16 bits = 16#8780
  EXPECT_EQ(h.value("Main.d"), 7);
  EXPECT_EQ(h.value("Main.b"), 255);
}

// A TIME variable takes its value on the nanosecond grid: ten sums of T#100ms
// are T#1s exactly (ten double additions of 0.1 give 0.9999999999999999).
TEST(StIntegers, time_sums_do_not_drift) {
  const std::string src =
      "PROGRAM Main\nVAR\n  t : TIME;\n  hit : BOOL;\n  hits : INT;\n  u : TIME;\nEND_VAR\n"
      "  t := t + T#100ms;\n  hit := t = T#1s;\n  IF hit THEN hits := hits + 1; END_IF;\n"
      "  u := T#0.1s + T#0.2s;\nEND_PROGRAM\n";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", src);
  h.step(9);
  EXPECT_EQ(h.value("Main.hit"), 0);
  h.step();
  EXPECT_EQ(h.value("Main.t"), 1.0);
  EXPECT_EQ(h.value("Main.hit"), 1);
  h.step(90);
  EXPECT_EQ(h.value("Main.t"), 10.0);
  EXPECT_EQ(h.value("Main.hits"), 1);
  EXPECT_EQ(h.value("Main.u"), 0.3);  // folded onto the grid too (0.1 + 0.2 is 0.30000000000000004)
  EXPECT_EQ(int_math::snap_time(0.1 + 0.2), 0.3);
  EXPECT_EQ(int_math::snap_time(-1.5e-9), -2e-9);  // the tie goes to the even nanosecond
}

TEST(StIntegers, a_folded_constant_that_overflows_is_refused_where_it_is_assigned) {
  const std::string src =
      "PROGRAM Main\nVAR\n  y : REAL;\n  d : DINT;\nEND_VAR\n  d := 5;\n  y := 1e300 * 1e300;\nEND_PROGRAM\n";
  const CompileResult r = compile_source(src);
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.diags.items().size(), 1u) << r.diags.render("o.st", src);
  const Diagnostic& d = r.diags.items()[0];
  EXPECT_EQ(d.pos.line, 7u);
  EXPECT_EQ(d.pos.col, 3u);
  EXPECT_NE(d.message.find("'y' is a constant expression that overflows"), std::string::npos) << d.message;
}

// BCD conversions (IEC 61131-3 ed. 2 table 22, as MatIEC's library does them):
// one decimal digit per nibble; a nibble above 9 is no BCD and gives 0, a
// negative number has no BCD and gives 0. Worked by hand: 16#1234 is 1234.
TEST(StIntegers, bcd_conversions_read_and_write_one_digit_per_nibble) {
  const char* src = R"(PROGRAM Main
VAR
  w : WORD := 16#1234; bad : WORD := 16#12A4; b : BYTE := 16#99;
  i, j, k, m : INT; n : INT := 9876; neg : INT := -5;
  v, z : WORD; u : DWORD; q : BYTE;
END_VAR
  i := BCD_TO_INT(w);
  j := BCD_TO_INT(bad);
  k := WORD_BCD_TO_INT(16#0042);
  m := BCD_TO_INT(b);
  v := INT_TO_BCD(n);
  z := INT_TO_BCD(neg);
  u := INT_TO_BCD_DWORD(1234);
  q := USINT_TO_BCD(USINT#123);
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("b.st", src);
  h.step();
  EXPECT_EQ(h.value("Main.i"), 1234);
  EXPECT_EQ(h.value("Main.j"), 0);
  EXPECT_EQ(h.value("Main.k"), 42);
  EXPECT_EQ(h.value("Main.m"), 99);
  EXPECT_EQ(h.value("Main.v"), 0x9876);
  EXPECT_EQ(h.value("Main.z"), 0);
  EXPECT_EQ(h.value("Main.u"), 0x1234);
  EXPECT_EQ(h.value("Main.q"), 0x23);  // two nibbles: the hundreds are dropped
  // A literal (64 bits) and an INT (16 bits, its width) as the operand.
  const char* wide = R"(PROGRAM Main
VAR raw AT %IW0 : INT; a, b, c : DINT; END_VAR
  a := BCD_TO_DINT(16#1234);
  b := BCD_TO_DINT(raw);
  c := LWORD_BCD_TO_DINT(16#98765432);
END_PROGRAM
)";
  FbdHarness w(wide, 0.01, true, true);
  ASSERT_TRUE(w.ok()) << w.result().diags.render("w.st", wide);
  w.set("raw", 0x4321);
  w.step();
  EXPECT_EQ(w.value("Main.a"), 1234);
  EXPECT_EQ(w.value("Main.b"), 4321);
  EXPECT_EQ(w.value("Main.c"), 98765432);
}

}  // namespace
}  // namespace rtplc::lang
