// Every primitive block against its contract (docs/blocks.md), through the real
// compiler and executor: edges, domain errors, timers and counters, analytic
// step responses of the filters, and PID against a hand computation.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tests/support/fbd_harness.h"

namespace rtplc {
namespace {

using testing::FbdHarness;

// F1, F2 (a, b) and D3, D4, D5 (x, y, z): set-points the tests drive.
using testing::kSetpointInputs;
FbdHarness with(const std::string& body, double dt = 0.1) { return testing::with_inputs(body, dt); }

TEST(Arithmetic, computes_with_the_optional_gain) {
  auto h = with(
      "F10 = add(F1, F2)\nF11 = add(F1, F2, 2)\nF12 = sub(F1, F2)\nF13 = sub(F1, F2, -1)\n"
      "F14 = mult(F1, F2)\nF15 = mult(F1, F2, 0.5)\nF16 = div(F1, F2)\nF17 = div(F1, F2, 3)\n"
      "F18 = scale(F1, 2, 1)\nF19 = max(F1, F2)\nF20 = min(F1, F2)\nF21 = abs(F2)\n");
  ASSERT_TRUE(h.ok());
  h.set("a", 6);
  h.set("b", -4);
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F10"), 2);
  EXPECT_DOUBLE_EQ(h.value("F11"), 4);
  EXPECT_DOUBLE_EQ(h.value("F12"), 10);
  EXPECT_DOUBLE_EQ(h.value("F13"), -10);
  EXPECT_DOUBLE_EQ(h.value("F14"), -24);
  EXPECT_DOUBLE_EQ(h.value("F15"), -12);
  EXPECT_DOUBLE_EQ(h.value("F16"), -1.5);
  EXPECT_DOUBLE_EQ(h.value("F17"), -4.5);
  EXPECT_DOUBLE_EQ(h.value("F18"), 13);
  EXPECT_DOUBLE_EQ(h.value("F19"), 6);
  EXPECT_DOUBLE_EQ(h.value("F20"), -4);
  EXPECT_DOUBLE_EQ(h.value("F21"), 4);
}

TEST(Arithmetic, trigonometry_is_in_radians) {
  auto h = with("F10 = sin(F1)\nF11 = cos(F1)\nF12 = tan(F1)\nF13 = asin(F2)\nF14 = acos(F2)\n"
                "F15 = atan(F2)\nF16 = sqrt(F2)\nF17 = inv(F2)\n");
  h.set("a", M_PI / 6);
  h.set("b", 0.5);
  h.step();
  EXPECT_NEAR(h.value("F10"), 0.5, 1e-15);
  EXPECT_NEAR(h.value("F11"), std::sqrt(3.0) / 2, 1e-15);
  EXPECT_NEAR(h.value("F12"), 1 / std::sqrt(3.0), 1e-15);
  EXPECT_NEAR(h.value("F13"), M_PI / 6, 1e-15);
  EXPECT_NEAR(h.value("F14"), M_PI / 3, 1e-15);
  EXPECT_NEAR(h.value("F15"), std::atan(0.5), 1e-15);
  EXPECT_NEAR(h.value("F16"), std::sqrt(0.5), 1e-15);
  EXPECT_DOUBLE_EQ(h.value("F17"), 2);
}

// Domain errors hold the previous output, count an error, and never store NaN/Inf.
TEST(Arithmetic, domain_errors_hold_the_previous_output_and_count) {
  auto h = with("F10 = div(F1, F2)\nF11 = sqrt(F2)\nF12 = asin(F2)\nF13 = acos(F2)\n"
                "F14 = inv(F2)\nF15 = mult(F1, F1)\nF16 = add(F1, F1)\nF17 = scale(F1, 1e300, 0)\n");
  h.set("a", 4);
  h.set("b", 0.25);
  h.step();
  const double div_ok = h.value("F10"), inv_ok = h.value("F14");
  EXPECT_DOUBLE_EQ(div_ok, 16);
  for (const char* n : {"F10", "F11", "F12", "F13", "F14"}) EXPECT_EQ(h.errors(n), 0u) << n;

  h.set("b", 0);  // division by zero, inv(0)
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F10"), div_ok);
  EXPECT_DOUBLE_EQ(h.value("F14"), inv_ok);
  EXPECT_EQ(h.errors("F10"), 1u);
  EXPECT_EQ(h.errors("F14"), 1u);
  const double sqrt_ok = h.value("F11"), asin_ok = h.value("F12"), acos_ok = h.value("F13");
  EXPECT_EQ(sqrt_ok, 0.0);

  h.set("b", -2);  // sqrt of a negative, asin/acos outside [-1, 1]
  h.step(2);
  EXPECT_DOUBLE_EQ(h.value("F11"), sqrt_ok);
  EXPECT_DOUBLE_EQ(h.value("F12"), asin_ok);
  EXPECT_DOUBLE_EQ(h.value("F13"), acos_ok);
  EXPECT_EQ(h.errors("F11"), 2u);
  EXPECT_EQ(h.errors("F12"), 2u);
  EXPECT_EQ(h.errors("F13"), 2u);
  EXPECT_DOUBLE_EQ(h.value("F10"), 4 / -2.0);  // recovers as soon as the input is valid

  h.set("a", 1e200);  // overflow to infinity
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F15"), 16);
  EXPECT_EQ(h.errors("F15"), 1u);
  EXPECT_DOUBLE_EQ(h.value("F16"), 2e200);
  EXPECT_EQ(h.errors("F17"), 1u);
  for (double v : h.arena().values) EXPECT_TRUE(std::isfinite(v));
  // 2 (b = 0) + 6 (two cycles at b = -2) + 5 (overflows, and b is still -2)
  EXPECT_EQ(h.arena().total_errors, 2u + 6u + 5u);
}

TEST(Logic, truth_tables_with_two_and_three_inputs) {
  auto h = with("D10 = and(D3, D4)\nD11 = and(D3, D4, D5)\nD12 = or(D3, D4)\nD13 = or(D3, D4, D5)\n"
                "D14 = not(D3)\nD15 = exor(D3, D4)\n");
  for (int m = 0; m < 8; ++m) {
    const bool x = m & 1, y = m & 2, z = m & 4;
    h.set("x", x);
    h.set("y", y);
    h.set("z", z);
    h.step();
    EXPECT_EQ(h.value("D10"), x && y) << m;
    EXPECT_EQ(h.value("D11"), x && y && z) << m;
    EXPECT_EQ(h.value("D12"), x || y) << m;
    EXPECT_EQ(h.value("D13"), x || y || z) << m;
    EXPECT_EQ(h.value("D14"), !x) << m;
    EXPECT_EQ(h.value("D15"), x != y) << m;
  }
}

TEST(Logic, on_delay_timer_rises_after_T_and_falls_with_its_input) {
  auto h = with("D10 = time(D3, 0.3)\nD11 = time(D3, 0)\n");
  std::vector<int> out, pass;
  const int in[] = {0, 1, 1, 1, 1, 1, 0, 1, 1, 0, 1, 1, 1, 1};
  for (int v : in) {
    h.set("x", v);
    h.step();
    out.push_back(static_cast<int>(h.value("D10")));
    pass.push_back(static_cast<int>(h.value("D11")));
  }
  // True once the input has been true for 0.3 s = 3 cycles after the cycle it rose.
  EXPECT_EQ(out, (std::vector<int>{0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 1}));
  EXPECT_EQ(pass, std::vector<int>(std::begin(in), std::end(in)));
}

TEST(Logic, counter_counts_rising_edges_and_reset_has_priority) {
  auto h = with("D10 = cnt(D3, D4, 3)\n");
  auto cycle = [&](int in, int reset) {
    h.set("x", in);
    h.set("y", reset);
    h.step();
    return static_cast<int>(h.value("D10"));
  };
  // Three rising edges -> true; holding the input high counts nothing more.
  EXPECT_EQ(cycle(1, 0), 0);  // edge 1 (edge memory starts false)
  EXPECT_EQ(cycle(1, 0), 0);
  EXPECT_EQ(cycle(0, 0), 0);
  EXPECT_EQ(cycle(1, 0), 0);  // edge 2
  EXPECT_EQ(cycle(0, 0), 0);
  EXPECT_EQ(cycle(1, 0), 1);  // edge 3
  EXPECT_EQ(cycle(1, 1), 0);  // reset clears the count
  // While reset is true no edge counts, but the edge memory still follows the input:
  EXPECT_EQ(cycle(0, 1), 0);
  EXPECT_EQ(cycle(1, 1), 0);  // an edge during reset is not counted
  EXPECT_EQ(cycle(1, 0), 0);  // input still high after reset: no new edge
  EXPECT_EQ(cycle(0, 0), 0);
  EXPECT_EQ(cycle(1, 0), 0);  // edge 1
  EXPECT_EQ(cycle(0, 0), 0);
  EXPECT_EQ(cycle(1, 0), 0);  // edge 2
  EXPECT_EQ(cycle(0, 0), 0);
  EXPECT_EQ(cycle(1, 0), 1);  // edge 3
  // Simultaneous edge and reset: reset wins.
  auto h2 = with("D10 = cnt(D3, D4, 1)\n");
  h2.set("x", 1);
  h2.set("y", 1);
  h2.step();
  EXPECT_EQ(h2.value("D10"), 0);
}

TEST(Control, limit_and_dead_zone) {
  auto h = with("F10 = lim(F1, -1, 2)\nF11 = dzon(F1, 0.5)\n");
  const double in[] = {-3, -1, 0, 1.5, 2, 7, 0.5, -0.5, 0.7, -0.7};
  const double lim[] = {-1, -1, 0, 1.5, 2, 2, 0.5, -0.5, 0.7, -0.7};
  const double dz[] = {-2.5, -0.5, 0, 1, 1.5, 6.5, 0, 0, 0.2, -0.2};
  for (int i = 0; i < 10; ++i) {
    h.set("a", in[i]);
    h.step();
    EXPECT_DOUBLE_EQ(h.value("F10"), lim[i]) << in[i];
    EXPECT_NEAR(h.value("F11"), dz[i], 1e-15) << in[i];
  }
}

TEST(Control, delay_outputs_the_input_of_n_samples_ago) {
  auto h = with("F10 = dely(F1, 3)\nF11 = dely(F1, 0)\nF12 = dely(F1, 1)\n");
  std::vector<double> d3, d1;
  for (int k = 1; k <= 8; ++k) {
    h.set("a", k);
    h.step();
    d3.push_back(h.value("F10"));
    d1.push_back(h.value("F12"));
    EXPECT_DOUBLE_EQ(h.value("F11"), k);
  }
  EXPECT_EQ(d3, (std::vector<double>{0, 0, 0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(d1, (std::vector<double>{0, 1, 2, 3, 4, 5, 6, 7}));
}

TEST(Control, integrator_and_derivative) {
  auto h = with("F10 = intg(F1, 2)\nF11 = derv(F1, 0.5)\nF12 = deriv(F1, 0.5)\n");
  h.set("a", 3);
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F10"), 3 * 0.1 / 2);
  EXPECT_DOUBLE_EQ(h.value("F11"), 0);  // first cycle: no previous input, no kick
  h.set("a", 5);
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F10"), (3 + 5) * 0.1 / 2);
  EXPECT_DOUBLE_EQ(h.value("F11"), 0.5 * (5 - 3) / 0.1);
  EXPECT_DOUBLE_EQ(h.value("F12"), h.value("F11"));
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F11"), 0);
}

TEST(Control, filter_follows_its_analytic_step_response) {
  const double dt = 0.01, T = 0.5;
  auto h = with("F10 = filt(F1, 0.5)\n", dt);
  h.set("a", 1);
  const double r = T / (T + dt);
  for (int k = 1; k <= 300; ++k) {
    h.step();
    // Exact discrete solution of y += dt/(T+dt)*(1 - y) from 0.
    EXPECT_NEAR(h.value("F10"), 1 - std::pow(r, k), 1e-12) << k;
    // And close to the continuous 1 - exp(-t/T) it discretises.
    EXPECT_NEAR(h.value("F10"), 1 - std::exp(-k * dt / T), 0.01) << k;
  }
}

TEST(Control, lead_lag_matches_the_continuous_step_response) {
  // (T1 s + 1)/(T2 s + 1), step at t = 0: y(t) = 1 - (1 - T1/T2) exp(-t/T2).
  const double dt = 0.001, T1 = 2, T2 = 0.5;
  auto h = with("F10 = ldlg(F1, 2, 0.5)\n", dt);
  h.step();  // one cycle at rest
  h.set("a", 1);
  for (int k = 0; k <= 3000; ++k) {
    h.step();
    // Tustin treats the sampled step as starting half a period earlier.
    const double t = (k + 0.5) * dt;
    EXPECT_NEAR(h.value("F10"), 1 - (1 - T1 / T2) * std::exp(-t / T2), 1e-5) << t;
  }
  EXPECT_NEAR(h.value("F10"), 1.0, 1e-2);  // DC gain 1
}

TEST(Control, pi_and_epi_match_a_hand_computation) {
  auto h = with("F10 = pi(F1, F2, 2, 4)\nF11 = sub(F1, F2)\nF12 = epi(F11, 2, 4)\nF13 = pi(F1, F2, 2, 0)\n");
  // Hand computation: I_k = I_{k-1} + e_k*dt/Ti; u_k = Kp*(e_k + I_k), dt = 0.1.
  const double sp[] = {1, 1, 3, 3, -2}, pv[] = {0, 0.5, 0.5, 3, 0};
  double integ = 0;
  for (int k = 0; k < 5; ++k) {
    h.set("a", sp[k]);
    h.set("b", pv[k]);
    h.step();
    const double e = sp[k] - pv[k];
    integ += e * 0.1 / 4;
    EXPECT_NEAR(h.value("F10"), 2 * (e + integ), 1e-12) << k;
    EXPECT_NEAR(h.value("F12"), 2 * (e + integ), 1e-12) << k;
    EXPECT_NEAR(h.value("F13"), 2 * e, 1e-12) << k;  // Ti = 0: no integral
  }
}

TEST(Control, pid_and_epid_match_a_hand_computation) {
  auto h = with("F10 = pid(F1, F2, 1.5, 2, 0.3)\nF11 = sub(F1, F2)\nF12 = epid(F11, 1.5, 2, 0.3)\n");
  const double sp[] = {10, 10, 10, 12, 12, 0}, pv[] = {0, 2, 5, 7, 11, 1};
  // Kp = 1.5, Ti = 2, Td = 0.3, dt = 0.1:
  // u_k = Kp*(e_k + I_k + Td*(e_k - e_{k-1})/dt), I_k = I_{k-1} + e_k*dt/Ti, no D on cycle 0.
  const double expected[] = {
      1.5 * (10 + 0.5),                                    // e=10, I=0.5
      1.5 * (8 + 0.9 + 0.3 * (8 - 10) / 0.1),              // e=8,  I=0.9
      1.5 * (5 + 1.15 + 0.3 * (5 - 8) / 0.1),              // e=5,  I=1.15
      1.5 * (5 + 1.4 + 0.3 * (5 - 5) / 0.1),               // e=5,  I=1.4
      1.5 * (1 + 1.45 + 0.3 * (1 - 5) / 0.1),              // e=1,  I=1.45
      1.5 * (-1 + 1.4 + 0.3 * (-1 - 1) / 0.1),             // e=-1, I=1.4
  };
  for (int k = 0; k < 6; ++k) {
    h.set("a", sp[k]);
    h.set("b", pv[k]);
    h.step();
    EXPECT_NEAR(h.value("F10"), expected[k], 1e-12) << k;
    EXPECT_NEAR(h.value("F12"), expected[k], 1e-12) << k;
  }
}

TEST(Control, ramp_moves_at_most_rate_times_dt_per_cycle) {
  auto h = with("F10 = ramp(F1, 5)\n");  // 0.5 per cycle at dt = 0.1
  h.set("a", 2);
  std::vector<double> y;
  for (int k = 0; k < 6; ++k) {
    h.step();
    y.push_back(h.value("F10"));
  }
  EXPECT_EQ(y, (std::vector<double>{0.5, 1.0, 1.5, 2.0, 2.0, 2.0}));
  h.set("a", 1.2);
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F10"), 1.5);
  h.step();
  EXPECT_DOUBLE_EQ(h.value("F10"), 1.2);
}

TEST(Control, analog_multiplexer_selects_b_when_sel_is_true) {
  auto h = with("F10 = amux(F1, F2, D3)\n");
  h.set("a", 1);
  h.set("b", 2);
  h.step();
  EXPECT_EQ(h.value("F10"), 1);
  h.set("x", 1);
  h.step();
  EXPECT_EQ(h.value("F10"), 2);
}

TEST(Io, inputs_and_outputs_pass_through_their_channels) {
  FbdHarness h(
      "F1 = dai(p0, d0, c0, \"ai\")\nD2 = ddi(p0, d1, c0, \"di\")\nF3 = dpi(p0, d2, c0, \"pulses\")\n"
      "F4 = prr(p1, d0, c7, \"reg\")\nD5 = erd(p0, d3, c0, \"eth\")\n"
      "dao(F1, p0, d0, c0, \"ao\")\nddo(D2, p0, d1, c0, \"do\")\npwr(F4, p1, d0, c8, \"wr\")\n"
      "ewd(D5, p0, d3, c1, \"ew\")\ntwa(F3, p2, d0, c0, \"drive\")\n");
  ASSERT_TRUE(h.ok());
  h.set("ai", 3.5);
  h.set("di", 7);  // any non-zero is true, normalised to 1
  h.set("pulses", 42);
  h.set("reg", -1);
  h.set("eth", 1);
  h.step();
  EXPECT_EQ(h.out("ao"), 3.5);
  EXPECT_EQ(h.out("do"), 1);
  EXPECT_EQ(h.out("wr"), -1);
  EXPECT_EQ(h.out("ew"), 1);
  EXPECT_EQ(h.out("drive"), 42);
  h.set("ai", NAN);  // a driver's NaN never reaches the blocks
  h.step();
  EXPECT_EQ(h.out("ao"), 3.5);
  EXPECT_EQ(h.errors("F1"), 1u);
}

TEST(Delays, forward_and_self_references_read_last_cycles_value) {
  // F10 reads F11 before F11 runs; F12 reads itself: both are one-cycle delays.
  auto h = with("F10 = add(F11, F1)\nF11 = add(F1, F2)\nF12 = add(F12, F1)\n");
  h.set("a", 1);
  h.set("b", 10);
  h.step();
  EXPECT_EQ(h.value("F10"), 0 + 1);   // F11 was 0 in the first cycle
  EXPECT_EQ(h.value("F12"), 1);
  h.step();
  EXPECT_EQ(h.value("F10"), 11 + 1);  // last cycle's F11
  EXPECT_EQ(h.value("F12"), 2);       // an accumulator
}

}  // namespace
}  // namespace rtplc
