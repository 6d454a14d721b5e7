// The IEC 61131-3 primitive blocks (docs/blocks.md, group "IEC 61131-3") against
// their contracts: the timers and counters cycle by cycle against the timing
// diagrams of the standard, the edge detectors' first cycle as MatIEC has it,
// integer wrap-around and the bit-string operations on their edges.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "blocks/int_math.h"
#include "tests/support/fbd_harness.h"

namespace rtplc {
namespace {

using testing::FbdHarness;

// F1, F2 (a, b) and D3, D4, D5 (x, y, z): set-points the tests drive.
using testing::kSetpointInputs;
FbdHarness with(const std::string& body, double dt = 0.1) { return testing::with_inputs(body, dt); }

// Evaluates one-input or two-input blocks on constants: "wrap(F10, 16, 1)".
double eval(const std::string& call, double a, double b = 0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "F10 = const(%.17g)\nF11 = const(%.17g)\nF12 = %s\n", a, b,
                call.c_str());
  FbdHarness h(buf, 0.1);
  if (!h.ok()) return NAN;
  h.step();
  return h.value("F12");
}

TEST(IecCompare, gives_one_or_zero_for_each_relation) {
  auto h = with(
      "D10 = gt(F1, F2)\nD11 = ge(F1, F2)\nD12 = lt(F1, F2)\nD13 = le(F1, F2)\n"
      "D14 = eq(F1, F2)\nD15 = ne(F1, F2)\n");
  ASSERT_TRUE(h.ok());
  struct Row {
    double a, b;
    int gt, ge, lt, le, eq, ne;
  };
  for (Row r : {Row{1, 2, 0, 0, 1, 1, 0, 1}, Row{2, 2, 0, 1, 0, 1, 1, 0},
                Row{3, 2, 1, 1, 0, 0, 0, 1}, Row{-0.0, 0.0, 0, 1, 0, 1, 1, 0}}) {
    h.set("a", r.a);
    h.set("b", r.b);
    h.step();
    EXPECT_EQ(h.value("D10"), r.gt) << r.a << " " << r.b;
    EXPECT_EQ(h.value("D11"), r.ge) << r.a << " " << r.b;
    EXPECT_EQ(h.value("D12"), r.lt) << r.a << " " << r.b;
    EXPECT_EQ(h.value("D13"), r.le) << r.a << " " << r.b;
    EXPECT_EQ(h.value("D14"), r.eq) << r.a << " " << r.b;
    EXPECT_EQ(h.value("D15"), r.ne) << r.a << " " << r.b;
  }
}

TEST(IecConst, produces_its_value_and_converts_kinds) {
  auto h =
      with("F10 = const(-2.5)\nD11 = dconst(1)\nF12 = d2a(D11)\nD13 = a2d(F10)\nD14 = a2d(F1)\n");
  ASSERT_TRUE(h.ok());
  h.step();
  EXPECT_EQ(h.value("F10"), -2.5);
  EXPECT_EQ(h.value("D11"), 1);
  EXPECT_EQ(h.value("F12"), 1);
  EXPECT_EQ(h.value("D13"), 1);
  EXPECT_EQ(h.value("D14"), 0);
}

TEST(IecArithmetic, mod_keeps_the_dividends_sign_and_mod_zero_is_zero) {
  EXPECT_EQ(eval("mod(F10, F11)", 7, 2), 1);
  EXPECT_EQ(eval("mod(F10, F11)", -7, 2), -1);
  EXPECT_EQ(eval("mod(F10, F11)", 7, -2), 1);
  EXPECT_EQ(eval("mod(F10, F11)", -7, -2), -1);
  EXPECT_EQ(eval("mod(F10, F11)", 7, 0), 0);
  EXPECT_EQ(eval("mod(F10, F11)", 5.5, 2), 1.5);
}

TEST(IecArithmetic, trunc_rounds_toward_zero_and_round_sends_an_exact_half_to_the_even_neighbour) {
  EXPECT_EQ(eval("trunc(F10)", -2.7), -2);
  EXPECT_EQ(eval("trunc(F10)", 2.7), 2);
  EXPECT_EQ(eval("round(F10)", 2.5), 2);
  EXPECT_EQ(eval("round(F10)", -2.5), -2);
  EXPECT_EQ(eval("round(F10)", 3.5), 4);
  EXPECT_EQ(eval("round(F10)", 1.4999), 1);
  EXPECT_EQ(eval("neg(F10)", 4), -4);
  for (const auto& [x, want] : {std::pair{0.5, 0.0}, {1.5, 2.0}, {2.5, 2.0}, {3.5, 4.0}, {-2.5, -2.0},
                                {-3.5, -4.0}, {2.4999999999999996, 2.0}, {2.6, 3.0}, {-0.5, -0.0},
                                {4503599627370497.0, 4503599627370497.0}}) {
    EXPECT_EQ(int_math::round_half_even(x), want) << x;
  }
}

// imul: the product in 64-bit integers, wrapped as wrap does (hand-worked).
TEST(IecArithmetic, imul_is_exact_to_sixty_four_bits_and_holds_on_garbage) {
  struct Case {
    double a, b;
    int bits;
    bool is_signed;
    double want;
  };
  for (const Case& c : {Case{4000000000, 3, 32, false, 3410065408},
                        Case{-1, -1, 32, false, 1},
                        Case{-1, 1, 32, false, 4294967295},
                        Case{65535, 65535, 16, true, 1},  // 0xFFFE0001 mod 2^16
                        Case{32767, 2, 16, true, -2},
                        Case{std::ldexp(1.0, 62), 4, 64, true, 0},  // 2^64 wraps to 0
                        Case{std::ldexp(1.0, 62), 2, 64, true, -std::ldexp(1.0, 63)},
                        Case{std::ldexp(1.0, 62), 2, 64, false, std::ldexp(1.0, 63)},
                        Case{2.9, -2.9, 8, true, -4}}) {  // operands truncated first
    const double m = int_math::type_modulus(c.bits), half = int_math::type_half(c.bits, c.is_signed);
    EXPECT_EQ(int_math::wrapped_product(c.a, c.b, m, half), c.want) << c.a << " * " << c.b << " in " << c.bits;
  }
  EXPECT_TRUE(std::isnan(int_math::wrapped_product(NAN, 1, 256, 128)));
  EXPECT_TRUE(std::isnan(int_math::wrapped_product(int_math::kTwo64, 1, 256, 128)));
  EXPECT_TRUE(std::isnan(int_math::wrapped_product(3, 1, 0, 0)));  // a crafted modulus

  // In a task, where a double product would have lost the low bits.
  EXPECT_EQ(eval("imul(F10, F11, 32, 0)", 4000000000, 3), 3410065408);
  EXPECT_EQ(eval("imul(F10, F11, 32, 0)", 1103515245, 3554416254), 2802055078);
  auto h = with("F10 = imul(F1, F2, 32, 1)\n");
  ASSERT_TRUE(h.ok());
  h.set("a", 100000);
  h.set("b", 100000);
  h.step();
  EXPECT_EQ(h.value("F10"), 1410065408);
  h.set("b", 1e300);  // not a number below 2^64: the output holds, one error
  h.step();
  EXPECT_EQ(h.value("F10"), 1410065408);
  EXPECT_EQ(h.errors("F10"), 1u);
}

TEST(IecArithmetic, expt_ln_log_exp_and_their_domain_errors) {
  EXPECT_EQ(eval("expt(F10, F11)", 2, 10), 1024);
  EXPECT_NEAR(eval("ln(F10)", std::exp(1.0)), 1, 1e-15);
  EXPECT_NEAR(eval("log(F10)", 1000), 3, 1e-15);
  EXPECT_EQ(eval("exp(F10)", 0), 1);
  auto h = with("F10 = expt(F1, F2)\nF11 = ln(F1)\nF12 = log(F1)\nF13 = exp(F2)\n");
  h.set("a", 4);
  h.set("b", 0.5);
  h.step();
  EXPECT_EQ(h.value("F10"), 2);
  const double ln4 = h.value("F11");
  h.set("a", -8);    // (-8)^0.5 and ln(-8): held, counted
  h.set("b", 1000);  // e^1000 overflows: held, counted
  h.step();
  EXPECT_EQ(h.value("F10"), 2);
  EXPECT_EQ(h.value("F11"), ln4);
  EXPECT_EQ(h.errors("F10"), 1u);
  EXPECT_EQ(h.errors("F11"), 1u);
  EXPECT_EQ(h.errors("F12"), 1u);
  EXPECT_EQ(h.errors("F13"), 1u);
}

TEST(IecIntegers, wrap_brings_a_value_into_the_types_range) {
  EXPECT_EQ(eval("wrap(F10, 16, 1)", 32767), 32767);
  EXPECT_EQ(eval("wrap(F10, 16, 1)", 32768), -32768);  // INT overflow
  EXPECT_EQ(eval("wrap(F10, 16, 1)", -32769), 32767);
  EXPECT_EQ(eval("wrap(F10, 16, 0)", 65536), 0);        // UINT
  EXPECT_EQ(eval("wrap(F10, 16, 0)", 65535.7), 65535);  // truncated first
  EXPECT_EQ(eval("wrap(F10, 8, 0)", -1), 255);          // USINT
  EXPECT_EQ(eval("wrap(F10, 8, 1)", 300), 44);          // SINT
  EXPECT_EQ(eval("wrap(F10, 8, 1)", -1.9), -1);
  EXPECT_EQ(eval("wrap(F10, 32, 1)", 2147483648.0), -2147483648.0);  // DINT
  EXPECT_EQ(eval("wrap(F10, 32, 0)", -1), 4294967295.0);             // UDINT
  EXPECT_EQ(eval("wrap(F10, 64, 1)", 9007199254740993.0),
            9007199254740992.0);                       // 2^53+1 is not a double
  EXPECT_EQ(eval("wrap(F10)", 40000), 40000 - 65536);  // default: 16 bits, signed
}

TEST(IecIntegers, an_int_counter_wraps_like_a_plcs) {
  // x := x + 1 as an INT, from 32766: 32767, -32768, -32767.
  // Seed the loop at 32766 through a one-cycle load: F13 reads F12 from the last cycle.
  auto g = with(
      "F10 = const(1)\nF14 = const(32766)\nF15 = amux(F12, F14, D3)\nF11 = add(F15, F10)\n"
      "F12 = wrap(F11, 16, 1)\n");
  ASSERT_TRUE(g.ok());
  g.set("x", 1);
  g.step();
  EXPECT_EQ(g.value("F12"), 32767);
  g.set("x", 0);
  g.step();
  EXPECT_EQ(g.value("F12"), -32768);
  g.step();
  EXPECT_EQ(g.value("F12"), -32767);
}

TEST(IecBits, and_or_xor_not_on_bit_strings) {
  EXPECT_EQ(eval("band(F10, F11, 8)", 12, 10), 8);
  EXPECT_EQ(eval("bor(F10, F11, 8)", 12, 10), 14);
  EXPECT_EQ(eval("bxor(F10, F11, 8)", 12, 10), 6);
  EXPECT_EQ(eval("bnot(F10, 8)", 0), 255);
  EXPECT_EQ(eval("bnot(F10, 16)", 0x00FF), 0xFF00);
  EXPECT_EQ(eval("bnot(F10, 8)", -1), 0);  // -1 is 255 as a BYTE
  EXPECT_EQ(eval("band(F10, F11, 32)", 4294967295.0, 65536), 65536);
  EXPECT_EQ(eval("bnot(F10, 32)", 0), 4294967295.0);
}

TEST(IecBits, shifts_and_rotations_stay_within_the_width) {
  EXPECT_EQ(eval("shl(F10, F11, 8)", 0x81, 1), 0x02);
  EXPECT_EQ(eval("shr(F10, F11, 8)", 0x81, 1), 0x40);
  EXPECT_EQ(eval("rol(F10, F11, 8)", 0x81, 1), 0x03);
  EXPECT_EQ(eval("ror(F10, F11, 8)", 0x81, 1), 0xC0);
  EXPECT_EQ(eval("rol(F10, F11, 8)", 0x81, 9), 0x03);  // n mod 8
  EXPECT_EQ(eval("ror(F10, F11, 16)", 1, 0), 1);
  EXPECT_EQ(eval("shl(F10, F11, 16)", 1, 16), 0);  // shifted out
  EXPECT_EQ(eval("shl(F10, F11, 16)", 1, 15), 32768);
  EXPECT_EQ(eval("shr(F10, F11, 16)", 0x8000, 15), 1);
  EXPECT_EQ(eval("shl(F10, F11, 16)", 3, -2), 3);  // a negative count shifts by 0
  EXPECT_EQ(eval("rol(F10, F11, 32)", 2147483648.0, 1), 1);
  EXPECT_EQ(eval("shl(F10, F11, 64)", 1, 52), 4503599627370496.0);
}

// Drives x cycle by cycle and checks one digital and (optionally) one analog column.
void expect_trace(FbdHarness& h, const std::vector<int>& x, const char* q,
                  const std::vector<int>& want_q, const char* et = nullptr,
                  const std::vector<double>& want_et = {}) {
  ASSERT_TRUE(h.ok());
  ASSERT_EQ(x.size(), want_q.size());
  for (size_t c = 0; c < x.size(); ++c) {
    h.set("x", x[c]);
    h.step();
    EXPECT_EQ(h.value(q), want_q[c]) << q << " at cycle " << c;
    if (et != nullptr) {
      EXPECT_NEAR(h.value(et), want_et[c], 1e-12) << et << " at cycle " << c;
    }
  }
}

TEST(IecEdges, r_trig_pulses_on_a_rising_edge_and_on_a_true_first_cycle) {
  auto h = with("D10 = rtrig(D3)\n");
  expect_trace(h, {1, 1, 0, 1, 0, 0, 1}, "D10", {1, 0, 0, 1, 0, 0, 1});
}

TEST(IecEdges, f_trig_pulses_on_a_falling_edge_and_on_a_false_first_cycle) {
  // The standard's body (M starts FALSE): a FALSE input in the first cycle is a pulse.
  auto h = with("D10 = ftrig(D3)\n");
  expect_trace(h, {0, 0, 1, 0, 1, 1, 0}, "D10", {1, 0, 0, 1, 0, 0, 1});
}

TEST(IecBistables, sr_is_set_dominant_and_rs_reset_dominant) {
  auto h = with("D10 = sr(D3, D4)\nD11 = rs(D3, D4)\n");
  ASSERT_TRUE(h.ok());
  struct Row {
    int s, r, sr, rs;
  };
  for (Row w : {Row{0, 0, 0, 0}, Row{1, 0, 1, 1}, Row{0, 0, 1, 1}, Row{0, 1, 0, 0}, Row{1, 1, 1, 0},
                Row{0, 0, 1, 0}, Row{0, 1, 0, 0}}) {
    h.set("x", w.s);
    h.set("y", w.r);
    h.step();
    EXPECT_EQ(h.value("D10"), w.sr) << w.s << w.r;
    EXPECT_EQ(h.value("D11"), w.rs) << w.s << w.r;
  }
}

// The timing diagrams of IEC 61131-3 (TON, TOF, TP) sampled at dt = 0.1 s with PT = 0.3 s.
TEST(IecTimers, ton_follows_the_standards_diagram) {
  auto h = with("D10 = ton(D3, F2)\nF11 = ton_et(D3, F2)\n");
  h.set("b", 0.3);
  expect_trace(h, {0, 1, 1, 1, 1, 1, 0, 1, 1, 0}, "D10", {0, 0, 0, 0, 1, 1, 0, 0, 0, 0}, "F11",
               {0, 0, 0.1, 0.2, 0.3, 0.3, 0, 0, 0.1, 0});
}

TEST(IecTimers, ton_with_pt_zero_passes_in_through) {
  auto h = with("D10 = ton(D3, F2)\n");
  expect_trace(h, {0, 1, 1, 0, 1}, "D10", {0, 1, 1, 0, 1});
}

TEST(IecTimers, tof_follows_the_standards_diagram) {
  auto h = with("D10 = tof(D3, F2)\nF11 = tof_et(D3, F2)\n");
  h.set("b", 0.3);
  expect_trace(h, {0, 1, 1, 0, 0, 0, 0, 0, 1, 0, 1}, "D10", {0, 1, 1, 1, 1, 1, 0, 0, 1, 1, 1},
               "F11", {0, 0, 0, 0, 0.1, 0.2, 0.3, 0.3, 0, 0, 0});
}

TEST(IecTimers, tp_gives_a_pulse_of_pt_and_is_not_retriggered) {
  auto h = with("D10 = tp(D3, F2)\nF11 = tp_et(D3, F2)\n");
  h.set("b", 0.3);
  expect_trace(h, {0, 1, 0, 1, 0, 0, 0, 1, 1, 1, 1, 1, 0, 1}, "D10",
               {0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 0, 0, 0, 1}, "F11",
               {0, 0, 0.1, 0.2, 0, 0, 0, 0, 0.1, 0.2, 0.3, 0.3, 0, 0});
}

TEST(IecTimers, pt_is_an_input_read_every_cycle) {
  auto h = with("D10 = ton(D3, F2)\n");
  ASSERT_TRUE(h.ok());
  h.set("b", 10);
  h.set("x", 1);
  h.step(5);  // 0.4 s elapsed
  EXPECT_EQ(h.value("D10"), 0);
  h.set("b", 0.4);  // lowering PT below the elapsed time ends the delay now
  h.step();
  EXPECT_EQ(h.value("D10"), 1);
}

TEST(IecTimers, a_decimal_pt_is_reached_on_the_cycle_it_names_at_a_long_run) {
  // 1 s at dt = 0.1 s: n*dt, not a sum of 0.1s (which would reach 0.99999999999999989).
  auto h = with("D10 = ton(D3, F2)\n");
  h.set("b", 1.0);
  h.set("x", 1);
  h.step(10);  // elapsed 0.9
  EXPECT_EQ(h.value("D10"), 0);
  h.step();
  EXPECT_EQ(h.value("D10"), 1);
}

TEST(IecCounters, ctu_counts_rising_edges_up_to_pvmax_and_resets) {
  auto h = with("F10 = ctu(D3, D4, 3)\nD11 = ge(F10, F2)\n");
  ASSERT_TRUE(h.ok());
  h.set("b", 2);  // PV
  const std::vector<int> cu = {1, 0, 1, 0, 1, 0, 1, 0};
  const std::vector<double> cv = {1, 1, 2, 2, 3, 3, 3, 3};
  for (size_t c = 0; c < cu.size(); ++c) {
    h.set("x", cu[c]);
    h.step();
    EXPECT_EQ(h.value("F10"), cv[c]) << c;
    EXPECT_EQ(h.value("D11"), cv[c] >= 2 ? 1 : 0) << c;
  }
  h.set("x", 1);
  h.set("y", 1);  // reset wins over the edge
  h.step();
  EXPECT_EQ(h.value("F10"), 0);
  h.set("y", 0);  // CU still high: no edge
  h.step();
  EXPECT_EQ(h.value("F10"), 0);
  h.set("x", 0);
  h.step();
  h.set("x", 1);
  h.step();
  EXPECT_EQ(h.value("F10"), 1);
}

TEST(IecCounters, ctd_loads_pv_and_counts_down_to_pvmin) {
  auto h = with("F10 = ctd(D3, D4, F2, -1)\nF20 = const(0)\nD11 = le(F10, F20)\n");
  ASSERT_TRUE(h.ok());
  h.set("b", 3);
  h.set("y", 1);
  h.step();
  EXPECT_EQ(h.value("F10"), 3);
  h.set("y", 0);
  const std::vector<int> cd = {1, 0, 1, 0, 1, 0, 1, 0, 1};
  const std::vector<double> cv = {2, 2, 1, 1, 0, 0, -1, -1, -1};
  for (size_t c = 0; c < cd.size(); ++c) {
    h.set("x", cd[c]);
    h.step();
    EXPECT_EQ(h.value("F10"), cv[c]) << c;
    EXPECT_EQ(h.value("D11"), cv[c] <= 0 ? 1 : 0) << c;
  }
}

TEST(IecCounters, ctud_counts_both_ways_and_ignores_simultaneous_edges) {
  auto h = with("F10 = updn(D3, D4)\nF11 = ctud(F10, D5, F2, -2, 2)\n");
  ASSERT_TRUE(h.ok());
  struct Row {
    int cu, cd, ld;
    double cv;
  };
  h.set("b", 1);  // PV
  for (Row w :
       {Row{1, 0, 0, 1}, Row{0, 0, 0, 1}, Row{1, 0, 0, 2}, Row{0, 0, 0, 2}, Row{1, 0, 0, 2},
        Row{0, 0, 0, 2}, Row{1, 1, 0, 2}, Row{0, 0, 0, 2}, Row{0, 1, 0, 1}, Row{0, 0, 0, 1},
        Row{0, 1, 0, 0}, Row{0, 0, 0, 0}, Row{0, 1, 0, -1}, Row{0, 0, 0, -1}, Row{0, 1, 0, -2},
        Row{0, 0, 0, -2}, Row{0, 1, 0, -2}, Row{0, 0, 1, 1}, Row{1, 0, 1, 1}}) {
    h.set("x", w.cu);
    h.set("y", w.cd);
    h.set("z", w.ld);
    h.step();
    EXPECT_EQ(h.value("F11"), w.cv) << w.cu << w.cd << w.ld;
  }
}

TEST(IecBlocks, refuse_a_width_outside_one_to_64_bits) {
  lang::CompileResult r = lang::compile_source(
      std::string("%%\n") + kSetpointInputs + "F10 = wrap(F1, 65, 1)\nF11 = band(F1, F2, 0)\nEND\n");
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.diags.error_count(), 2u);
}

}  // namespace
}  // namespace rtplc
