// The planner's report (docs/fieldbus.md, "Reading the report"; spec
// io-links.md, "Fieldbus bandwidth allocation": print the schedule and the
// largest non-RT packet, or which condition fails and by how much). Text for
// people, JSON (all times in seconds) for scripts and the tests.
#pragma once

#include <string>

#include "fieldbus/design.h"
#include "fieldbus/planner.h"

namespace rtplc::fieldbus {

std::string render_plan_text(const Design& d, const Plan& p, const std::string& file);
// `simulation`, when not empty, is a JSON object added as the member "simulation".
std::string render_plan_json(const Design& d, const Plan& p, const std::string& simulation = "");

// JSON helpers shared with the simulation report.
std::string json_string(const std::string& s);
std::string json_seconds(Nanos t);  // "0.000585714"

}  // namespace rtplc::fieldbus
