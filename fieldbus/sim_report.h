// The simulation's report and plot (docs/fieldbus.md, "Simulating the plan";
// spec io-links.md, "Fieldbus bandwidth allocation": per-class delay statistics
// that show the design holds, no lost sample, no vacant sampling).
#pragma once

#include <string>

#include "common/result.h"
#include "fieldbus/planner.h"
#include "fieldbus/simulation.h"

namespace rtplc::fieldbus {

// Whether what the simulation saw stays inside what the plan promised: every
// periodic packet within W, every loop delay within T_i + W, nothing lost, no
// vacant sampling.
bool simulation_holds(const Plan& p, const SimResult& r);

std::string render_sim_text(const Design& d, const Plan& p, const SimResult& r, uint64_t seed);
// A JSON object (no trailing newline) for the "simulation" member of the plan's JSON.
std::string render_sim_json(const Plan& p, const SimResult& r, uint64_t seed);

// Draws the delay distributions (one cumulative curve per class, the plan's
// bounds as vertical lines) with gnuplot into a PNG. Needs keep_samples.
Result<void> write_delay_plot(const Plan& p, const SimResult& r, const std::string& png_path,
                              const std::string& title);

}  // namespace rtplc::fieldbus
