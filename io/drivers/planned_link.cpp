// The link row of a planned link (see planned_link.h).
#include "io/drivers/planned_link.h"

#include <filesystem>

#include "common/text.h"
#include "fieldbus/units.h"

namespace rtplc::io {

void describe_planned_link(LinkStatus& ls, const fieldbus::LinkPlan& lp) {
  using fieldbus::format_time;
  const fieldbus::Plan& p = lp.plan;
  const std::string line = std::filesystem::path(lp.file).filename().string() + ": T1 " + format_time(p.t1) +
                           ", gamma " + std::to_string(p.gamma) + ", Ln " + format_time(p.ln_max);
  copy_text(ls.plan, sizeof ls.plan, line);
  const int64_t delay_bound[kLinkClasses] = {p.transfer_bound, p.t1, 0};
  const int64_t packet_bound[kLinkClasses] = {lp.design.periodic_packet, lp.design.rt_packet, p.ln_max};
  const auto r = std::memory_order_relaxed;
  for (size_t c = 0; c < kLinkClasses; ++c) {
    LinkClassStatus& cs = ls.classes[c];
    copy_text(cs.name, sizeof cs.name, fieldbus::to_string(static_cast<fieldbus::TrafficClass>(c)));
    cs.delay_bound_ns.store(delay_bound[c], r);
    cs.packet_bound_ns.store(packet_bound[c], r);
  }
}

void publish_planned_link(LinkStatus& ls, const fieldbus::LinkScheduler& s) noexcept {
  publish_planned_link(ls, s.figures());
}

void publish_planned_link(LinkStatus& ls, const fieldbus::LinkFigures& f) noexcept {
  const auto r = std::memory_order_relaxed;
  for (size_t c = 0; c < kLinkClasses; ++c) {
    LinkClassStatus& cs = ls.classes[c];
    cs.count.store(f[c].count, r);
    cs.missed.store(f[c].missed, r);
    cs.delay_p99_ns.store(f[c].delay_p99, r);
    cs.delay_max_ns.store(f[c].delay_max, r);
    cs.packet_max_ns.store(f[c].packet_max, r);
  }
}

}  // namespace rtplc::io
