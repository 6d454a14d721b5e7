// The plan a CAN or Modbus RTU link runs on (docs/fieldbus.md, "Running a link
// on a plan"; spec io-links.md, "Fieldbus bandwidth allocation"): the
// planner's input file, read and planned when the runtime's configuration is
// loaded, so a design that cannot work refuses to start with the planner's
// reason (which condition fails and by how much) at its file:line:col.
#pragma once

#include <string>

#include "common/result.h"
#include "fieldbus/design.h"
#include "fieldbus/planner.h"

namespace rtplc::fieldbus {

struct LinkPlan {
  std::string file;  // the plan file as the config named it (resolved)
  Design design;
  Plan plan;

  const LoopPlan* loop(const std::string& name) const;
  // "L1, L2": the loops' names, for "did you mean" style messages.
  std::string loop_names() const;
};

// Reads `path` and plans it. The error is the plan file's positioned
// diagnostics, or one line per failing condition ("PATH:LINE:COL: stability:
// ... by 2.8ms") when the design cannot work.
Result<LinkPlan> load_link_plan(const std::string& path);

}  // namespace rtplc::fieldbus
