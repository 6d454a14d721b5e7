// The commissioning PID `pidc` against a hand computation, cycle by cycle:
// set-point weights, the filtered derivative on the measurement, conditional
// integration at the limits, and tracking of the applied output (bumpless
// manual -> auto). The closed-loop tests are in tests/sim/test_pidc_loop.cpp.
#include <gtest/gtest.h>

#include <string>

#include "tests/support/fbd_harness.h"

namespace rtplc {
namespace {

using testing::FbdHarness;

const char* kInputs =
    "F1 = asp(d0, c0, 0, \"sp\")\n"
    "F2 = asp(d0, c1, 0, \"pv\")\n"
    "F4 = asp(d0, c2, 0, \"man\")\n"
    "D6 = dsp(d0, c3, 0, \"auto\")\n";

TEST(Pidc, matches_a_hand_computation_with_weights_filter_and_limits) {
  // dt 0.1, Kp 2, Ti 1, Td 0.5, N 5 (Tf 0.1), b 0.5, c 0, output -10..10; fb = itself.
  // ki = Kp*dt/Ti = 0.2, ad = Tf/(Tf+dt) = 0.5, bd = Kp*Td/(Tf+dt) = 5.
  FbdHarness h(std::string(kInputs) + "F3 = pidc(F1, F2, F3, 2, 1, 0.5, -10, 10, 5, 0.5, 0)\n",
               0.1);
  ASSERT_TRUE(h.ok());
  h.set("sp", 1);
  h.set("pv", 0);
  h.step();  // P = 2*(0.5 - 0) = 1, I = 0.2, D = 0 (first cycle: no kick)
  EXPECT_NEAR(h.value("F3"), 1.2, 1e-12);
  h.set("pv", 0.5);
  h.step();  // P = 0, I = 0.3, D = 5*(-0.5 - 0) = -2.5
  EXPECT_NEAR(h.value("F3"), -2.2, 1e-12);
  h.step();  // P = 0, I = 0.4, D = 0.5*-2.5 = -1.25
  EXPECT_NEAR(h.value("F3"), -0.85, 1e-12);
  h.set("pv", -20);
  h.step();  // P = 41, D = 0.5*-1.25 + 5*20.5 = 101.875: beyond 10, I holds at 0.4
  EXPECT_EQ(h.value("F3"), 10);
  h.step();  // D = 50.9375: still beyond, I still 0.4
  EXPECT_EQ(h.value("F3"), 10);
  h.set("pv", 0.5);
  h.step();  // P = 0, D = 0.5*50.9375 + 5*(-0.5 - 20) = -77.03125, I = 0.4 + 0.1 = 0.5: below -10
  EXPECT_EQ(h.value("F3"), -10);
  h.step();  // D = -38.515625; I = 0.6: integrating back toward the range is allowed
  EXPECT_EQ(h.value("F3"), -10);
  h.step();  // D = -19.2578125, I = 0.7
  EXPECT_EQ(h.value("F3"), -10);
  h.step();  // D = -9.62890625, I = 0.8: back in range
  EXPECT_NEAR(h.value("F3"), -8.82890625, 1e-12);
  h.step();  // D = -4.814453125, I = 0.9
  EXPECT_NEAR(h.value("F3"), -3.914453125, 1e-12);
  EXPECT_EQ(h.errors("F3"), 0u);
}

TEST(Pidc, the_integral_does_not_wind_up_while_the_output_is_saturated) {
  FbdHarness h(std::string(kInputs) + "F3 = pidc(F1, F2, F3, 1, 1, 0, 0, 100)\n", 0.1);
  h.set("sp", 500);  // unreachable
  h.step(1000);      // 100 s at the limit
  EXPECT_EQ(h.value("F3"), 100);
  h.set("sp", 50);
  h.set("pv", 60);  // error -10: P = -10, and I was frozen at the limit
  h.step();
  EXPECT_LT(h.value("F3"), 100);  // leaves saturation in the first cycle
}

TEST(Pidc, manual_to_auto_is_bumpless_when_fb_reads_the_selector) {
  // Kp 2, Ti 1, no D; F5 = the value sent to the actuator (manual `man` or the PID).
  FbdHarness h(
      std::string(kInputs) + "F3 = pidc(F1, F2, F5, 2, 1, 0, -100, 100)\nF5 = amux(F4, F3, D6)\n",
      0.1);
  ASSERT_TRUE(h.ok());
  h.set("sp", 1);
  h.set("man", 7);
  h.step();  // fb = 0 (first cycle): P 2, I 0.2 -> 2.2; the actuator gets 7
  EXPECT_NEAR(h.value("F3"), 2.2, 1e-12);
  EXPECT_EQ(h.value("F5"), 7);
  h.step();  // I moves by fb - u' = 7 - 2.2 to 5, then + 0.2: u = 7.2
  EXPECT_NEAR(h.value("F3"), 7.2, 1e-12);
  h.step();  // tracking holds it at the applied value plus one cycle's action
  EXPECT_NEAR(h.value("F3"), 7.2, 1e-12);
  h.set("auto", 1);
  h.step();  // auto: the actuator goes 7 -> 7.2, one cycle's integral, no bump
  EXPECT_NEAR(h.value("F5"), 7.2, 1e-12);
  h.step();
  EXPECT_NEAR(h.value("F5"), 7.4, 1e-12);
  h.set("auto", 0);  // back to manual: the actuator takes `man` at once ...
  h.step();
  EXPECT_EQ(h.value("F5"), 7);
  h.set("auto", 1);  // ... and auto continues from what the actuator had
  h.step();
  h.step();
  EXPECT_NEAR(h.value("F5"), 7.4, 1e-12);
}

TEST(Pidc, tracks_an_external_limit_wired_to_fb) {
  // The valve only takes 0..40 (a lim after the PID); fb reads it: back-calculation.
  FbdHarness h(
      std::string(kInputs) + "F3 = pidc(F1, F2, F5, 1, 1, 0, 0, 100)\nF5 = lim(F3, 0, 40)\n", 0.1);
  ASSERT_TRUE(h.ok());
  h.set("sp", 80);
  h.step(200);
  EXPECT_EQ(h.value("F5"), 40);
  EXPECT_LT(h.value("F3"),
            40 + 80 + 8.0 + 1e-9);  // P + one cycle's integral past the valve's limit
  h.set("pv", 100);                 // error -20: leaves the valve's limit at once
  h.step();
  EXPECT_LT(h.value("F5"), 40);
}

TEST(Pidc, refuses_limits_in_the_wrong_order) {
  lang::CompileResult r = lang::compile_source(std::string("%%\n") + kInputs +
                                               "F3 = pidc(F1, F2, F3, 1, 1, 0, 10, 0)\nEND\n");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.diags.render("t", "").find("lowest output 10 is above the highest output 0"),
            std::string::npos)
      << r.diags.render("t", "");
}

}  // namespace
}  // namespace rtplc
