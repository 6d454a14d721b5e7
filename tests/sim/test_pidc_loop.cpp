// The commissioning PID `pidc` in closed loop (issue: "recovery after saturation
// within a bound"): the flow loop of examples/plant.yaml (first order 0.5 s plus
// 50 ms dead time, valve 0..100 %) driven to saturation by an unreachable
// set-point, then dropped. The seed's PI behind a limiter winds up and keeps the
// valve wide open for seconds; pidc leaves saturation at once. And manual -> auto
// on the example program examples/flow_pidc.fbd moves the valve by no more than
// one cycle's control action.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "io/drivers/sim/plant.h"
#include "lang/compiler.h"
#include "sim/sim_loop.h"

namespace rtplc::io {
namespace {

const std::string kSrc = RTPLC_SOURCE_DIR;

SimTrace run(const lang::CompileResult& r, std::vector<SetpointStep> steps, double duration) {
  EXPECT_TRUE(r.ok()) << r.diags.render("program", "");
  auto p = make_plant("fopdt:K=1,T=0.5,L=0.05");
  EXPECT_TRUE(p.ok());
  SimOptions o;
  o.duration = duration;
  o.steps = std::move(steps);
  auto t = run_closed_loop(*r.image, **p, o);
  EXPECT_TRUE(t.ok()) << t.error();
  return std::move(t).value();
}

SimTrace saturate_then_drop(const std::string& controller) {
  const std::string src =
      "%%\nstime(0.01)\nF1 = dai(p0, d0, c0, \"FT\")\nF2 = asp(d0, c0, 20, \"SP\")\n" + controller +
      "dao(F4, p0, d0, c0, \"FV\")\nEND\n";
  return run(lang::compile_source(src), {{"SP", 150, 1}, {"SP", 20, 11}}, 20);
}

// Seconds after `from` until column `col` first satisfies `pred` (and, with
// `stays`, keeps satisfying it to the end); -1 if never.
template <class Pred>
double time_until(const SimTrace& t, int col, double from, Pred pred, bool stays) {
  double found = -1;
  for (const auto& row : t.rows) {
    if (row[0] < from) continue;
    const bool ok = pred(row[static_cast<size_t>(col)]);
    if (ok && found < 0) found = row[0] - from;
    if (!ok && stays) found = -1;
  }
  return found;
}

TEST(PidcLoop, recovers_from_saturation_at_once_where_the_seeds_pi_winds_up) {
  const SimTrace seed = saturate_then_drop("F3 = pi(F2, F1, 2, 0.5)\nF4 = lim(F3, 0, 100)\n");
  const SimTrace ours = saturate_then_drop("F4 = pidc(F2, F1, F4, 2, 0.5, 0, 0, 100)\n");
  ASSERT_GE(seed.mv_column, 0);
  ASSERT_GE(ours.mv_column, 0);
  // Both were saturated at the drop: the valve wide open, the flow near 100.
  auto at = [](const SimTrace& t, double when, int col) -> double {
    for (const auto& row : t.rows) {
      if (row[0] >= when - 1e-9) return row[static_cast<size_t>(col)];
    }
    return NAN;
  };
  EXPECT_EQ(at(seed, 10.99, seed.mv_column), 100);
  EXPECT_EQ(at(ours, 10.99, ours.mv_column), 100);
  EXPECT_GT(at(ours, 10.99, ours.pv_column), 99);

  auto open = [](double v) { return v < 100; };
  const double seed_leaves = time_until(seed, seed.mv_column, 11, open, false);
  const double ours_leaves = time_until(ours, ours.mv_column, 11, open, false);
  // The seed's integral holds 2*(50 + 50*10/0.5) and unwinds 2*80*0.01/0.5 per cycle:
  // about 6 s with the valve open after the set-point fell.
  EXPECT_GT(seed_leaves, 5.5);
  EXPECT_LT(ours_leaves, 0.015);  // the first cycle after the drop (or the next)

  auto settled = [](double pv) {
    return std::fabs(pv - 20) < 2.6;
  };  // the 2 % band of the 130 step
  const double seed_settles = time_until(seed, seed.pv_column, 11, settled, true);
  const double ours_settles = time_until(ours, ours.pv_column, 11, settled, true);
  EXPECT_GT(seed_settles, 6.0);
  EXPECT_GT(ours_settles, 0);
  EXPECT_LT(ours_settles, 1.5);  // a bound: plant lag, dead time and the PI's own dynamics
  EXPECT_EQ(ours.block_errors, 0u);
}

TEST(PidcLoop, manual_to_auto_on_the_example_is_bumpless) {
  // examples/flow_pidc.fbd: manual at 40 % for 5 s (the flow settles at 40), then auto
  // with the set-point at 30: the valve continues from 40 and moves by at most one
  // cycle's action (P change + one integral step), then the loop pulls the flow to 30.
  const auto r = lang::compile_file(kSrc + "/examples/flow_pidc.fbd");
  const SimTrace t = run(r,
                         {{"FIC_101_AUTO", 0, 0},
                          {"FIC_101_MAN", 40, 0},
                          {"FIC_101_SP", 30, 0},
                          {"FIC_101_AUTO", 1, 5}},
                         10);
  ASSERT_GE(t.mv_column, 0);
  const size_t mv = static_cast<size_t>(t.mv_column), pv = static_cast<size_t>(t.pv_column);
  double before = NAN, worst_step = 0;
  for (size_t i = 1; i < t.rows.size(); ++i) {
    const double now = t.rows[i][0];
    if (now < 4.99) before = t.rows[i][mv];
    if (now >= 4.99 && now <= 5.2)
      worst_step = std::max(worst_step, std::fabs(t.rows[i][mv] - t.rows[i - 1][mv]));
  }
  EXPECT_EQ(before, 40);
  EXPECT_NEAR(t.rows[499][pv], 40, 0.5);  // settled in manual
  // At the switch e = 30 - 40: one integral step is Kp*dt/Ti*10 = 0.4 %, and P changes
  // only as fast as the flow does. A PID without tracking would jump to 2*(-10) + I.
  EXPECT_LT(worst_step, 1.0);
  EXPECT_NEAR(t.rows.back()[pv], 30, 0.6);  // and auto then does its job
}

}  // namespace
}  // namespace rtplc::io
