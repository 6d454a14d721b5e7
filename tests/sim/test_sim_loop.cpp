// The closed-loop simulation of the seed's example 2 (section 6.4): set-point 50,
// PID macro (4, 3, 1) around 1/(s^2 + s + 1), RK4 at 0.01 s, control at 0.1 s.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "sim/sim_loop.h"
#include "lang/compiler.h"

namespace rtplc::io {
namespace {

const std::string kSrc = RTPLC_SOURCE_DIR;

SimTrace run_seed(double duration, std::vector<SetpointStep> steps = {}) {
  auto r = lang::compile_file(kSrc + "/examples/seed_pid.fbd");
  EXPECT_TRUE(r.ok());
  auto p = make_plant(kDefaultPlant);
  SimOptions o;
  o.duration = duration;
  o.steps = std::move(steps);
  auto t = run_closed_loop(*r.image, **p, o);
  EXPECT_TRUE(t.ok()) << t.error();
  return std::move(t).value();
}

TEST(SimLoop, seed_pid_settles_to_the_setpoint_after_an_overshoot) {
  SimTrace t = run_seed(30);
  ASSERT_EQ(t.columns, (std::vector<std::string>{"t", "ProcVal", "Setpoint", "ManiVal"}));
  ASSERT_EQ(t.rows.size(), 301u);  // t = 0 .. 30 s at 0.1 s
  EXPECT_DOUBLE_EQ(t.rows.back()[0], 30.0);
  const double pv_end = t.rows.back()[1];
  EXPECT_NEAR(pv_end, 50.0, 0.25);  // within 0.5 % at 30 s
  const std::vector<StepMetrics> steps = step_metrics(t);
  ASSERT_EQ(steps.size(), 1u);  // the step at t = 0: ProcVal starts at 0, Setpoint is 50
  const StepMetrics& m = steps[0];
  EXPECT_DOUBLE_EQ(m.at, 0);
  EXPECT_DOUBLE_EQ(m.setpoint_from, 0);
  EXPECT_DOUBLE_EQ(m.setpoint, 50);
  EXPECT_GT(m.overshoot_pct, 5.0);  // it does overshoot ...
  EXPECT_LT(m.overshoot_pct, 40.0);  // ... and stays stable
  EXPECT_GT(m.settling_time, 0);
  EXPECT_LT(m.settling_time, 30);
  EXPECT_LT(m.final_error_pct, 0.5);
  EXPECT_EQ(t.block_errors, 0u);
  // The first cycle sees PV = 0: u = 4*(50 + 50*0.1/3) and no derivative kick.
  EXPECT_NEAR(t.rows[0][3], 4 * (50 + 50 * 0.1 / 3), 1e-12);
}

TEST(SimLoop, a_setpoint_step_moves_the_loop_to_the_new_value) {
  SimTrace t = run_seed(60, {{"Setpoint", 60, 30}});
  EXPECT_EQ(t.rows[299][2], 50);
  EXPECT_EQ(t.rows[300][2], 60);
  EXPECT_NEAR(t.rows.back()[1], 60, 0.3);
  const std::vector<StepMetrics> steps = step_metrics(t);
  ASSERT_EQ(steps.size(), 2u);  // 0 -> 50 at t = 0, 50 -> 60 at 30 s
  EXPECT_DOUBLE_EQ(steps[1].at, 30);
  EXPECT_DOUBLE_EQ(steps[1].setpoint_from, 50);
  EXPECT_NEAR(steps[1].initial, 50, 0.3);  // analysed from the change
  // Times are after the step: the second response peaks as fast as the first.
  EXPECT_NEAR(steps[1].peak_time, steps[0].peak_time, 0.2);
  EXPECT_LT(steps[1].settling_time, 30);
  EXPECT_FALSE(steps[0].last);
  EXPECT_TRUE(steps[1].last);
}

// A hand-worked trace: the measurement steps straight to the set-point after
// one sample, overshoots by a quarter of the step once, then sits on it.
TEST(SimLoop, step_figures_of_a_hand_worked_trace) {
  SimTrace t;
  t.columns = {"t", "PV", "SP"};
  t.pv_column = 1;
  t.sp_column = 2;
  //            t    PV     SP
  t.rows = {{0.0, 0.0, 0.0}, {1.0, 0.0, 10.0}, {2.0, 5.0, 10.0}, {3.0, 12.5, 10.0},
            {4.0, 10.0, 10.0}, {5.0, 10.0, 10.0}};
  const std::vector<StepMetrics> steps = step_metrics(t);
  ASSERT_EQ(steps.size(), 1u);  // at t = 0 the PV sits on the SP: no step there
  const StepMetrics& m = steps[0];
  EXPECT_DOUBLE_EQ(m.at, 1.0);
  EXPECT_DOUBLE_EQ(m.setpoint_from, 0.0);
  EXPECT_DOUBLE_EQ(m.overshoot_pct, 25.0);   // (12.5 - 10) / 10
  EXPECT_DOUBLE_EQ(m.peak_time, 2.0);        // at t = 3 s, 2 s after the step
  EXPECT_DOUBLE_EQ(m.rise_time, 1.0);        // 10 % at t = 2 (5 >= 1), 90 % at t = 3
  EXPECT_DOUBLE_EQ(m.settling_time, 3.0);    // within 2 % from t = 4 s on
  EXPECT_DOUBLE_EQ(m.final_error_pct, 0.0);
  const std::string text = format_metrics(t, steps);
  EXPECT_NE(text.find("step at 1 s, SP 0 -> 10: PV 0 -> 10"), std::string::npos) << text;
  EXPECT_NE(text.find("2 s after the step"), std::string::npos) << text;
  // Without a set-point there are no step figures, and the summary says why.
  t.sp_column = -1;
  EXPECT_TRUE(step_metrics(t).empty());
  EXPECT_NE(format_metrics(t, {}).find("no step figures"), std::string::npos);
}

TEST(SimLoop, wiring_errors_name_the_channels_the_program_has) {
  auto r = lang::compile_file(kSrc + "/examples/seed_pid.fbd");
  auto p = make_plant(kDefaultPlant);
  SimOptions o;
  o.plant_input = "p1.d0.c0";
  auto t = run_closed_loop(*r.image, **p, o);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("p0.d0.c0 (\"ManiVal\")"), std::string::npos) << t.error();
  o = {};
  o.steps = {{"Nope", 1, 1}};
  t = run_closed_loop(*r.image, **p, o);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("Nope"), std::string::npos);
}

TEST(SimLoop, csv_has_the_header_and_one_row_per_cycle) {
  SimTrace t = run_seed(1);
  const std::string path = ::testing::TempDir() + "/sim.csv";
  ASSERT_TRUE(write_csv(t, path).ok());
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);
  EXPECT_EQ(line, "t,ProcVal,Setpoint,ManiVal");
  int rows = 0;
  while (std::getline(f, line)) ++rows;
  EXPECT_EQ(rows, 11);
  std::remove(path.c_str());
}

TEST(SimLoop, the_seed_pid_on_an_unstable_tf_plant_is_flagged_as_diverged) {
  auto r = lang::compile_file(kSrc + "/examples/seed_pid.fbd");
  ASSERT_TRUE(r.ok());
  auto p = make_plant("tf:2,1/1,3,1");
  ASSERT_TRUE(p.ok()) << p.error();
  SimOptions o;
  auto t = run_closed_loop(*r.image, **p, o);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_GE(t->diverged_at, 0);
  EXPECT_TRUE(!std::isfinite(t->diverged_value) || std::fabs(t->diverged_value) > kDivergenceFactor * 50);
  // The stable default plant is not.
  EXPECT_LT(run_seed(30).diverged_at, 0);
}

// A sequence that reads a level but drives no valve (a PLCopen SFC, say):
// nothing drives a plant, so it runs open loop with the level at 0.
TEST(SimLoop, a_program_that_reads_a_dai_but_drives_no_dao_runs_open_loop) {
  auto r = lang::compile_source(
      "%%\nstime(0.1)\nF1 = dai(p0, d0, c0, \"Level\")\nF2 = const(50)\nD3 = gt(F1, F2)\n"
      "ddo(D3, p0, d0, c1, \"High\")\nEND\n%%\n");
  ASSERT_TRUE(r.ok()) << r.diags.render("level", "");
  auto p = make_plant(kDefaultPlant);
  SimOptions o;
  o.duration = 1;
  EXPECT_FALSE(runs_open_loop(*r.image, o));  // a plant asked for by name: refused
  EXPECT_FALSE(run_closed_loop(*r.image, **p, o).ok());
  o.open_loop_if_unwired = true;
  EXPECT_FALSE(has_plant_input(*r.image, o));
  EXPECT_TRUE(runs_open_loop(*r.image, o));
  auto t = run_closed_loop(*r.image, **p, o);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_TRUE(t->open_loop);
  EXPECT_EQ(t->rows.back().back(), 0);  // Level stays 0: High never set
}

TEST(SimLoop, a_program_without_plant_channels_runs_open_loop_only_when_allowed) {
  auto r = lang::compile_source(
      "%%\nstime(0.1)\nD1 = dsp(d0, c0, 0, \"Start\")\nD2 = time(D1, 1)\n"
      "ddo(D2, p0, d0, c1, \"Motor\")\nEND\n%%\n");
  ASSERT_TRUE(r.ok()) << r.diags.render("logic", "");
  auto p = make_plant(kDefaultPlant);
  SimOptions o;
  o.duration = 3;
  o.steps = {{"Start", 1, 1}};
  EXPECT_FALSE(run_closed_loop(*r.image, **p, o).ok());  // asked for a plant: refused
  EXPECT_FALSE(runs_open_loop(*r.image, o));
  o.open_loop_if_unwired = true;
  EXPECT_TRUE(runs_open_loop(*r.image, o));
  auto t = run_closed_loop(*r.image, **p, o);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_TRUE(t->open_loop);
  EXPECT_EQ(t->pv_column, -1);
  EXPECT_EQ(t->rows.back().back(), 1);  // Motor on 1 s after Start
  EXPECT_EQ(t->rows[15].back(), 0);     // not before
}

}  // namespace
}  // namespace rtplc::io
