// Loading and planning the plan of a link (see link_plan.h).
#include "fieldbus/link_plan.h"

#include "fieldbus/plan_file.h"

namespace rtplc::fieldbus {

const LoopPlan* LinkPlan::loop(const std::string& name) const {
  for (const LoopPlan& l : plan.loops) {
    if (l.name == name) return &l;
  }
  return nullptr;
}

std::string LinkPlan::loop_names() const {
  std::string out;
  for (const LoopPlan& l : plan.loops) out += (out.empty() ? "" : ", ") + l.name;
  return out.empty() ? "none" : out;
}

Result<LinkPlan> load_link_plan(const std::string& path) {
  PlanFile pf = load_plan_file(path);
  if (!pf.design) return make_error(pf.render());
  LinkPlan lp;
  lp.file = path;
  lp.design = std::move(*pf.design);
  lp.plan = plan(lp.design);
  if (lp.plan.feasible) return lp;
  std::string why = "the plan " + path + " cannot work:";
  for (const Failure& f : lp.plan.failures) {
    SourcePos at{1, 1};
    for (const LoopSpec& l : lp.design.loops) {
      if (!f.loop.empty() && l.name == f.loop && l.pos.line) at = l.pos;
    }
    why += "\n  " + path + ":" + std::to_string(at.line) + ":" + std::to_string(at.col) + ": " +
           to_string(f.condition) + ": " + f.message;
  }
  return make_error(why);
}

const LinkPlanCache::Loaded& LinkPlanCache::get(const std::string& path) {
  auto it = plans_.find(path);
  if (it != plans_.end()) return it->second;
  Result<LinkPlan> lp = load_(path);
  Loaded p = lp ? Loaded(std::make_shared<const LinkPlan>(std::move(*lp))) : Loaded(make_error(lp.error()));
  return plans_.emplace(path, std::move(p)).first->second;
}

}  // namespace rtplc::fieldbus
