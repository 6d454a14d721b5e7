// The plan a CAN or Modbus RTU link runs on (docs/fieldbus.md, "Running a link
// on a plan"; spec io-links.md, "Fieldbus bandwidth allocation"): the
// planner's input file, read and planned when the runtime's configuration is
// loaded, so a design that cannot work refuses to start with the planner's
// reason (which condition fails and by how much) at its file:line:col.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>

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

// The plans one driver's links name, each file read and planned once however
// many links name it: the links naming one path share one LinkPlan, or one
// error, which each of them reports at its own position in the config.
class LinkPlanCache {
 public:
  using Loaded = Result<std::shared_ptr<const LinkPlan>>;
  using Loader = std::function<Result<LinkPlan>(const std::string& path)>;
  // `load` is the seam the tests count loads through.
  explicit LinkPlanCache(Loader load = &load_link_plan) : load_(std::move(load)) {}

  // The plan of `path` (resolved, as LinkPlan::file), loaded on its first use.
  const Loaded& get(const std::string& path);

 private:
  Loader load_;
  std::map<std::string, Loaded> plans_;  // node-based: get()'s references stay valid
};

}  // namespace rtplc::fieldbus
