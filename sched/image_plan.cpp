// Planning the process image (see image_plan.h).
#include "sched/image_plan.h"

#include <algorithm>
#include <set>

#include "common/capacities.h"
#include "common/text.h"

namespace rtplc::sched {

io::ChannelDesc channel_desc(const std::string& label, const std::string& key, io::ChannelDir dir,
                             uint8_t kind, uint32_t region, uint32_t index) {
  io::ChannelDesc d{};
  copy_text(d.label, sizeof d.label, label);
  copy_text(d.key, sizeof d.key, key);
  d.dir = static_cast<uint8_t>(dir);
  d.kind = kind;
  d.region = static_cast<uint16_t>(region);
  d.index = index;
  return d;
}

io::ChannelDesc channel_desc(const Binding& b, const std::string& label, const std::string& key, io::ChannelDir dir,
                             uint32_t region, uint32_t index) {
  io::ChannelDesc d = channel_desc(label, key, dir, static_cast<uint8_t>(b.kind), region, index);
  d.hmi = (b.flags & kBindingHmi) != 0 ? 1 : 0;
  return d;
}

int64_t input_max_age_ns(const config::DriverConfig& dc, const config::ChannelClaim& claim) {
  if (dc.max_age_s) return static_cast<int64_t>(*dc.max_age_s * 1e9);
  if (claim.max_age_ns > 0) return claim.max_age_ns;
  // Three driver periods, not less than 100 ms: a 1 ms bridge a loaded machine
  // runs a few cycles late is not frozen; one that stopped is stale within 0.1 s.
  return std::max<int64_t>(3 * static_cast<int64_t>(dc.period_s * 1e9), 100000000);
}

void set_output_policy(const config::TaskConfig& task, const std::string& label, io::ChannelDesc& d) {
  for (const config::OnBadPolicy& p : task.on_bad) {
    if (p.label == label) d.on_bad = static_cast<uint8_t>(p.policy);
  }
  for (const config::SafeOutput& so : task.safe_outputs) {
    if (so.label == label) d.safe_value = so.value;
  }
}

int64_t output_max_age_ns(int64_t task_period_ns) {
  return std::max<int64_t>(3 * task_period_ns, 1000000000);
}

std::string limits_text(const std::optional<double>& min, const std::optional<double>& max) {
  if (min && max) return "[" + format_number(*min) + ", " + format_number(*max) + "]";
  if (min) return ">= " + format_number(*min);
  if (max) return "<= " + format_number(*max);
  return "any finite number";
}

std::vector<int> rate_monotonic_priorities(const config::RuntimeConfig& cfg,
                                           std::span<const int64_t> periods) {
  const size_t n = cfg.tasks.size();
  std::vector<int64_t> distinct(periods.begin(), periods.end());
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  std::vector<int> prio(n);
  for (size_t t = 0; t < n; ++t) {
    if (cfg.tasks[t].priority) {
      prio[t] = *cfg.tasks[t].priority;
      continue;
    }
    const auto rank = std::lower_bound(distinct.begin(), distinct.end(), periods[t]) - distinct.begin();
    int p = cfg.band_hi - static_cast<int>(rank);
    // Rate-monotonic also against priorities the user set: never above a task
    // with a shorter period, never below one with a longer period.
    for (size_t u = 0; u < n; ++u) {
      if (!cfg.tasks[u].priority) continue;
      if (periods[u] < periods[t]) p = std::min(p, *cfg.tasks[u].priority - 1);
    }
    for (size_t u = 0; u < n; ++u) {
      if (!cfg.tasks[u].priority) continue;
      if (periods[u] > periods[t]) p = std::max(p, std::min(*cfg.tasks[u].priority + 1, cfg.band_hi));
    }
    prio[t] = std::clamp(p, cfg.band_lo, cfg.band_hi);
  }
  return prio;
}

bool plan_image(const config::RuntimeConfig& cfg, const std::string& name,
                std::span<const TaskImage> images, std::span<const config::DriverClaims> claims,
                PlanDiagnostics diags, ImagePlan& out) {
  DiagnosticList& cdiag = *diags.config;
  const size_t n_tasks = cfg.tasks.size();
  bool ok = true;

  for (const TaskImage& img : images) out.periods_ns.push_back(img.header().period_ns);
  out.priorities = rate_monotonic_priorities(cfg, out.periods_ns);

  // Regions: one per task's outputs, per driver, the set-points, unwired inputs.
  io::ImageLayout& layout = out.layout;
  layout.name = name;
  for (size_t t = 0; t < n_tasks; ++t) {
    layout.regions.push_back({"task:" + cfg.tasks[t].name, io::RegionKind::kTask,
                              static_cast<uint32_t>(t), images[t].header().n_io_out + kSpareOutputs});
  }
  struct Produced {
    uint32_t region;
    uint32_t index;
    std::string label;
    int64_t max_age_ns;
  };
  std::map<std::string, Produced> produced;  // input channels a driver writes
  const int driver_prio = std::min(cfg.band_hi + 1, config::kMaxFifoPriority);
  for (size_t d = 0; d < cfg.drivers.size(); ++d) {
    const config::DriverConfig& dc = cfg.drivers[d];
    const config::DriverClaims& c = claims[d];
    DriverPlan dp;
    dp.region = static_cast<uint32_t>(layout.regions.size());
    dp.n_provides = static_cast<uint32_t>(c.provides.size());
    dp.first_link = layout.n_links;
    dp.priority = dc.priority ? *dc.priority : driver_prio;
    dp.helper_priority = std::max(1, cfg.band_lo - 1);
    layout.n_links += c.links;
    for (uint32_t i = 0; i < c.provides.size(); ++i) {
      // Two sources of one input were refused when the config loaded.
      produced.emplace(c.provides[i].key, Produced{dp.region, i, c.provides[i].label, input_max_age_ns(dc, c.provides[i])});
    }
    const size_t capacity = c.provides.size() + c.consumes.size();
    layout.regions.push_back({"driver:" + dc.name, io::RegionKind::kDriver, static_cast<uint32_t>(d),
                              static_cast<uint32_t>(std::max<size_t>(capacity, 1))});
    out.drivers.push_back(std::move(dp));
  }
  out.setpoint_region = static_cast<uint32_t>(layout.regions.size());
  layout.regions.push_back({"setpoints", io::RegionKind::kSetpoints, 0, 0});
  out.unwired_region = static_cast<uint32_t>(layout.regions.size());
  layout.regions.push_back({"unwired", io::RegionKind::kUnwired, 0, 0});

  // Channels from every program's bindings.
  std::vector<io::ChannelDesc>& descs = out.channels;
  std::map<std::string, uint32_t>& by_key = out.channel_by_key;
  std::map<std::string, std::pair<std::string, size_t>> label_owner;  // label -> key, task
  uint32_t n_setpoints = 0, n_unwired = 0;
  out.task_output_keys.assign(n_tasks, {});
  for (size_t t = 0; t < n_tasks; ++t) {
    const TaskImage& img = images[t];
    DiagnosticList& pdiag = *diags.programs[t];
    out.task_output_keys[t].assign(img.header().n_io_out, "");
    for (const Binding& b : img.bindings()) {
      const std::string key = binding_key(b);
      const std::string label = img.str(b.label);
      const SourcePos at{b.line, 1};
      auto lab = label_owner.find(label);
      if (lab != label_owner.end() && lab->second.first != key) {
        pdiag.error(at, "label \"" + label + "\" already names channel " + lab->second.first +
                            " in task " + cfg.tasks[lab->second.second].name +
                            "; labels name one channel in the whole runtime");
        ok = false;
        continue;
      }
      label_owner.emplace(label, std::make_pair(key, t));
      auto existing = by_key.find(key);
      if (b.dir == BindingDir::kOutput) {
        if (existing != by_key.end()) {
          const io::ChannelDesc& e = descs[existing->second];
          pdiag.error(at, "output " + key + " is already written by task " +
                              cfg.tasks[e.region].name + ": each output has one writer");
          ok = false;
          continue;
        }
        out.task_output_keys[t][b.io_index] = key;
        by_key[key] = static_cast<uint32_t>(descs.size());
        descs.push_back(channel_desc(b, label, key, io::ChannelDir::kOutput, static_cast<uint32_t>(t), b.io_index));
        descs.back().max_age_ns = output_max_age_ns(img.header().period_ns);
        set_output_policy(cfg.tasks[t], label, descs.back());
      } else if (existing == by_key.end()) {
        io::ChannelDesc d = channel_desc(b, label, key, io::ChannelDir::kInput, 0, 0);
        if (b.dir == BindingDir::kSetpoint) {
          d.dir = static_cast<uint8_t>(io::ChannelDir::kSetpoint);
          d.region = static_cast<uint16_t>(out.setpoint_region);
          d.index = n_setpoints++;
          d.init = b.init;
          d.retain = 1;
        } else if (auto pr = produced.find(key); pr != produced.end()) {
          d.region = static_cast<uint16_t>(pr->second.region);
          d.index = pr->second.index;
          d.max_age_ns = pr->second.max_age_ns;
        } else {
          d.region = static_cast<uint16_t>(out.unwired_region);
          d.index = n_unwired++;
          pdiag.warning(at, "no driver provides input " + key + " (\"" + label +
                                "\"): it reads 0 with bad quality");
        }
        by_key[key] = static_cast<uint32_t>(descs.size());
        descs.push_back(d);
      }
    }
  }

  // Which tasks use each channel (ChannelDesc::users).
  for (size_t t = 0; t < n_tasks && t < 16; ++t) {
    for (const Binding& b : images[t].bindings()) {
      if (auto it = by_key.find(binding_key(b)); it != by_key.end()) descs[it->second].users |= uint16_t(1u << t);
    }
  }

  // Driver inputs nobody reads still show in the monitor; what a driver
  // consumes must be some task's output.
  for (size_t d = 0; d < cfg.drivers.size(); ++d) {
    const config::DriverConfig& dc = cfg.drivers[d];
    const config::DriverClaims& c = claims[d];
    DriverPlan& dp = out.drivers[d];
    for (const config::ChannelClaim& p : c.provides) {
      if (by_key.count(p.key)) continue;
      const Produced& pr = produced[p.key];
      by_key[p.key] = static_cast<uint32_t>(descs.size());
      descs.push_back(channel_desc(pr.label, p.key, io::ChannelDir::kInput, 0, pr.region, pr.index));
      descs.back().max_age_ns = pr.max_age_ns;
    }
    for (uint32_t j = 0; j < c.consumes.size(); ++j) {
      const config::ChannelClaim& q = c.consumes[j];
      auto it = by_key.find(q.key);
      if (it == by_key.end() || descs[it->second].dir != static_cast<uint8_t>(io::ChannelDir::kOutput)) {
        cdiag.error(q.pos, "no task writes " + q.key + ", which driver " + dc.name + " sends");
        ok = false;
        dp.consumes.push_back({out.unwired_region, 0});
        continue;
      }
      io::ChannelDesc& o = descs[it->second];
      dp.consumes.push_back({o.region, o.index, o.max_age_ns, static_cast<config::OnBad>(o.on_bad), o.safe_value});
      if (!o.has_delivery) {
        // The first driver that sends an output reports how its delivery goes.
        o.has_delivery = 1;
        o.delivery_region = static_cast<uint16_t>(dp.region);
        o.delivery_index = dp.n_provides + j;
      }
    }
  }

  // Safe outputs and on_bad policies name outputs of their own task.
  for (size_t t = 0; t < n_tasks; ++t) {
    auto check_output = [&](const std::string& label, SourcePos pos) {
      for (const Binding& b : images[t].bindings()) {
        if (b.dir == BindingDir::kOutput && label == images[t].str(b.label)) return;
      }
      cdiag.error(pos, "task " + cfg.tasks[t].name + " has no output labelled \"" + label + "\"");
      ok = false;
    };
    for (const config::OnBadPolicy& p : cfg.tasks[t].on_bad) check_output(p.label, p.pos);
    for (const config::SafeOutput& so : cfg.tasks[t].safe_outputs) check_output(so.label, so.pos);
  }
  // Set-point limits name set-points of their own task, hold its init value,
  // and are given once per label (a set-point is one channel, however many
  // tasks read it).
  std::map<std::string, SourcePos> limits_at;
  for (size_t t = 0; t < n_tasks; ++t) {
    for (const config::SetpointLimits& lim : cfg.tasks[t].setpoint_limits) {
      const Binding* sp = nullptr;
      for (const Binding& b : images[t].bindings()) {
        if (b.dir == BindingDir::kSetpoint && lim.label == images[t].str(b.label)) sp = &b;
      }
      if (auto [first, fresh] = limits_at.emplace(lim.label, lim.pos); !fresh) {
        cdiag.error(lim.pos, "the limits of set-point \"" + lim.label + "\" are given twice");
        cdiag.note(first->second, "first given here");
        ok = false;
        continue;
      }
      if (sp == nullptr) {
        bool other = false;  // the label names an input or output: a mistake
        for (const Binding& b : images[t].bindings()) other |= lim.label == images[t].str(b.label);
        if (other) {
          cdiag.error(lim.pos, "\"" + lim.label + "\" is not a set-point of task " + cfg.tasks[t].name);
          ok = false;
        } else {
          // Limits for a set-point a later program (a hot swap) adds.
          cdiag.warning(lim.pos, "task " + cfg.tasks[t].name + " has no set-point labelled \"" + lim.label +
                                     "\" yet: its limits apply once a swapped-in program adds it");
        }
        continue;
      }
      if ((lim.min && sp->init < *lim.min) || (lim.max && sp->init > *lim.max)) {
        cdiag.error(lim.pos, "set-point \"" + lim.label + "\" starts at " + format_number(sp->init) +
                                 " (its init value in the program), outside " + limits_text(lim.min, lim.max));
        ok = false;
      }
    }
  }
  // Engineering ranges name inputs or outputs of their own task, once per label.
  std::map<std::string, SourcePos> ranges_at;
  for (size_t t = 0; t < n_tasks; ++t) {
    for (const config::SetpointLimits& r : cfg.tasks[t].channel_ranges) {
      const Binding* io = nullptr;
      bool setpoint = false;
      for (const Binding& b : images[t].bindings()) {
        if (r.label != images[t].str(b.label)) continue;
        if (b.dir == BindingDir::kInput || b.dir == BindingDir::kOutput) io = &b;
        setpoint |= b.dir == BindingDir::kSetpoint;
      }
      if (io == nullptr) {
        cdiag.error(r.pos, setpoint ? "\"" + r.label + "\" is a set-point: its range goes under `setpoints`"
                                    : "task " + cfg.tasks[t].name + " has no input or output labelled \"" + r.label + "\"");
        ok = false;
        continue;
      }
      if (auto [first, fresh] = ranges_at.emplace(r.label, r.pos); !fresh) {
        cdiag.error(r.pos, "the range of \"" + r.label + "\" is given twice");
        cdiag.note(first->second, "first given here");
        ok = false;
      }
    }
  }
  if (descs.size() > kMaxChannels) {
    cdiag.error(SourcePos{}, "more than " + std::to_string(kMaxChannels) + " channels");
    ok = false;
  }
  layout.regions[out.setpoint_region].capacity = n_setpoints + kSpareSetpoints;
  layout.regions[out.unwired_region].capacity = n_unwired + kSpareUnwired;
  layout.channel_capacity = static_cast<uint32_t>(std::min<size_t>(kMaxChannels, descs.size() + 256));
  layout.n_tasks = static_cast<uint32_t>(n_tasks);
  return ok;
}

}  // namespace rtplc::sched
