// Closed-loop simulation in virtual time (issue "Simulation", seed 6.4): one task
// image against a simulated plant wired to a dao (plant input) and a dai (plant
// measurement), the plant integrated by RK4 between control cycles. What
// `rtplc sim` runs, and what the tests use to close real loops.
#pragma once

#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "blocks/executor.h"
#include "blocks/image.h"
#include "common/result.h"
#include "io/drivers/sim/plant.h"

namespace rtplc::io {

// A set-point change during a run: `label` takes `value` at time `at` (seconds).
struct SetpointStep {
  std::string label;
  double value = 0;
  double at = 0;
};

struct SimOptions {
  double duration = 30;              // seconds of plant time
  std::string plant_input = "p0.d0.c0";   // the dao channel that drives the plant
  std::string plant_output = "p0.d0.c0";  // the dai channel that measures it
  std::vector<SetpointStep> steps;
  bool realtime = false;             // pace cycles to the wall clock
  // A program with neither the dao nor the dai above (a logic test) runs open
  // loop, without the plant, instead of being refused.
  bool open_loop_if_unwired = false;
  // Blocks whose output is traced as a column of its own name, after the
  // I/O columns (a PLCopen program's variables, "instance0.level").
  std::vector<std::string> probes;
  std::string file;  // the program's source, for positioned errors (a runaway loop)
  uint64_t loop_budget = kDefaultLoopBudget;
  // Native code compiled from this image (blocks/native.h), or null.
  RtplcNativeCycle native = nullptr;
};

struct SimTrace {
  std::vector<std::string> columns;  // "t", then one label per input, set-point, output
  std::vector<std::vector<double>> rows;
  std::vector<bool> is_output;       // per column: written by the program
  // STRING variables (docs/st.md, "Strings"): per column its index in each
  // row of `texts`, or -1; such a column's number in `rows` is its length.
  std::vector<int> text_index;
  std::vector<std::vector<std::string>> texts;
  std::string plant;                 // description
  double dt = 0;
  double plant_step = 0;
  int pv_column = -1;                // the plant measurement
  int mv_column = -1;                // the plant input
  int sp_column = -1;                // the set-point when the program has exactly one analog one
  uint64_t block_errors = 0;
  bool open_loop = false;            // ran without a plant (nothing wired to it)
  // The loop diverged: the measurement left every sensible range (not finite,
  // or beyond kDivergenceFactor times the largest set-point). -1 = it did not.
  double diverged_at = -1;
  double diverged_value = 0;
};

inline constexpr double kDivergenceFactor = 1e6;

Result<SimTrace> run_closed_loop(const TaskImage& image, Plant& plant, const SimOptions& opt);
// The dai measuring and the dao driving the plant (opt.plant_output / plant_input),
// each nullptr when the program has none.
std::pair<const Binding*, const Binding*> plant_bindings(const TaskImage& image, const SimOptions& opt);
// Whether run_closed_loop will run `image` open loop (nothing wired to the plant).
bool runs_open_loop(const TaskImage& image, const SimOptions& opt);

// True when the program has the dao that drives the plant (--plant-input).
bool has_plant_input(const TaskImage& image, const SimOptions& opt);

// Step-response figures of the measurement against its set-point, from the last
// set-point change (or t = 0) to the end of the run.
// The response to one set-point step: the step at t = 0 (the measurement starts
// away from the set-point) and every later change of the set-point, each
// analysed up to the next one. Times are after the step, not from t = 0.
struct StepMetrics {
  double at = 0;                // when the set-point took its new value (s of the run)
  double setpoint_from = 0;     // the set-point before the step (the measurement's start at t = 0)
  double setpoint = 0;          // ... and after it
  double initial = 0;           // the measurement when the step came
  double final_value = 0;       // ... at the end of the segment
  double final_error_pct = 0;   // |final - setpoint| / |setpoint - initial| * 100
  double overshoot_pct = 0;     // beyond the set-point, relative to the step size
  double peak = 0;
  double peak_time = 0;         // after the step
  double rise_time = -1;        // 10% -> 90% of the step; -1 if never reached
  double settling_time = -1;    // after the step: enters and stays within 2% of it; -1 if never
  bool last = false;            // the segment runs to the end of the run
};

// One entry per step of the loop's set-point; none when the trace has no
// single analog set-point to compare the measurement with (or no measurement).
std::vector<StepMetrics> step_metrics(const SimTrace& trace);
std::string format_metrics(const SimTrace& trace, const std::vector<StepMetrics>& steps);

Result<void> write_csv(const SimTrace& trace, const std::string& path);
// The CSV layout `rtplc sim` and `rtplc trace` share: a header naming the
// columns (t first), then one row per task cycle. Lines starting with '#' (a
// trace's notes) are comments to gnuplot and to CSV readers told so.
// Each returns one line with its '\n'.
std::string csv_header_line(const std::vector<std::string>& columns);
std::string csv_row_line(const double* row, size_t n);

// Draws the signals with gnuplot into a PNG: measurement and set-points on top,
// outputs below. `csv_path` must hold the trace (write_csv first).
Result<void> write_plot(const SimTrace& trace, const std::string& csv_path,
                        const std::string& png_path, const std::string& title);

}  // namespace rtplc::io
