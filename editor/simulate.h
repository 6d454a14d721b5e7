// Simulation from the editor page (docs/editor.md, "Simulation"): the diagram
// the page holds, compiled by the real compiler, run in closed loop against a
// plant model of `rtplc sim` in virtual time, with the same step-response
// figures and the same CSV. Runs in the console's process, never in the
// runtime: nothing here touches a task.
#pragma once

#include <nlohmann/json.hpp>

#include "common/result.h"
#include "editor/diagram.h"

namespace rtplc::editor {

// The longest run the page may ask for, in plant seconds, and the most cycles:
// one request holds one of the console's worker threads for its run.
inline constexpr double kMaxSimSeconds = 3600;
inline constexpr size_t kMaxSimCycles = 200000;
// The rows sent for the plot (every k-th cycle and the last); the CSV has all.
inline constexpr size_t kPlotRows = 1500;

// `request`: {"plant": SPEC (default the seed's second-order), "duration": S,
// "steps": [{"label", "value", "at"}], "plant_input", "plant_output"}.
// Answers {"compiles": false, verdict...} when the diagram does not compile,
// else {"compiles": true, "plant", "period_s", "cycles", "columns",
// "is_output", "pv", "mv", "sp", "rows" (plot rows), "metrics": [...],
// "figures" (as rtplc sim prints them), "csv", "block_errors", "open_loop",
// "diverged_at"}. A bad request (plant spec, step) is an error naming it.
Result<nlohmann::json> simulate(const Diagram& d, const nlohmann::json& request);

}  // namespace rtplc::editor
