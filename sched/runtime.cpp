// Loading, starting and operating the runtime (see runtime.h).
#include "sched/runtime.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <new>
#include <set>
#include <thread>

#include "common/capacities.h"
#include "common/text.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/rt_kernel.h"
#include "lang/compiler.h"
#include "io/s7/engine.h"
#include "sched/stats_source.h"

namespace rtplc::sched {
namespace {

constexpr uint32_t kSpareOutputs = 32;     // room for outputs a hot swap adds
constexpr uint32_t kSpareSetpoints = 64;   // ... and set-points
constexpr uint32_t kSpareUnwired = 64;     // ... and inputs no driver provides


std::string fmt_ms(int64_t ns) { return format_number(static_cast<double>(ns) / 1e6) + " ms"; }


// A channel table entry; init and retain are set by the caller for set-points.
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

std::string read_file(const std::string& path) {
  std::string err;
  auto t = lang::read_text_file(path, &err);
  return t ? *t : std::string();
}

}  // namespace

std::string default_socket_path(const std::string& name) {
  if (geteuid() == 0) return "/run/rtplc/" + name + ".sock";
  if (const char* x = std::getenv("XDG_RUNTIME_DIR"); x && *x) {
    return std::string(x) + "/rtplc-" + name + ".sock";
  }
  return "/tmp/rtplc-" + std::to_string(geteuid()) + "/" + name + ".sock";
}

std::string default_retain_path(const std::string& name) {
  if (geteuid() == 0) return "/var/lib/rtplc/" + name + ".retain";
  if (const char* x = std::getenv("XDG_STATE_HOME"); x && *x) {
    return std::string(x) + "/rtplc/" + name + ".retain";
  }
  if (const char* h = std::getenv("HOME"); h && *h) {
    return std::string(h) + "/.local/state/rtplc/" + name + ".retain";
  }
  return "/tmp/rtplc-" + std::to_string(geteuid()) + "/" + name + ".retain";
}

std::string LoadReport::render(bool color) const {
  std::string out;
  for (const File& f : files) out += f.diags.render(f.name, f.text, color);
  return out;
}

Runtime::~Runtime() { stop(); }

Task* Runtime::find_task(const std::string& name) {
  for (auto& t : tasks_) {
    if (t->params().name == name) return t.get();
  }
  return nullptr;
}

// ---------------------------------------------------------------------------
// Loading

std::unique_ptr<Runtime> Runtime::load(const config::RuntimeConfig& cfg, const RuntimeOptions& opt,
                                       LoadReport& report) {
  std::unique_ptr<Runtime> rt(new Runtime());
  rt->options_ = opt;
  rt->name_ = opt.name_override.empty() ? cfg.name : opt.name_override;
  rt->socket_path_ = !opt.socket_override.empty() ? opt.socket_override
                     : !cfg.socket_path.empty()   ? cfg.socket_path
                                                  : default_socket_path(rt->name_);
  rt->retain_ = RetainStore(!opt.retain_override.empty() ? opt.retain_override
                            : !cfg.retain_path.empty()   ? cfg.retain_path
                                                         : default_retain_path(rt->name_));
  rt->lock_memory_ = cfg.lock_memory && opt.lock_memory;
  rt->cpu_dma_latency_ = cfg.cpu_dma_latency;
  // build_channels keeps a reference to the config file's entry while it adds one
  // entry per program: reserve so the vector never moves under it.
  report.files.reserve(report.files.size() + 1 + cfg.tasks.size());
  report.files.push_back({cfg.file, read_file(cfg.file), {}});
  if (cfg.tasks.size() > kMaxTasks) {
    report.files[0].diags.error(SourcePos{}, "more than " + std::to_string(kMaxTasks) + " tasks");
    report.ok = false;
    return nullptr;
  }
  if (!rt->build_channels(cfg, report)) {
    report.ok = false;
    return nullptr;
  }
  report.ok = true;
  return rt;
}

bool Runtime::build_channels(const config::RuntimeConfig& cfg, LoadReport& report) {
  DiagnosticList& cdiag = report.files[0].diags;
  const size_t n_tasks = cfg.tasks.size();

  // 1. Compile every program; a program's problems are reported against its text.
  std::vector<TaskImage> images;
  std::vector<std::string> sources;
  std::vector<size_t> file_of(n_tasks, 0);
  bool ok = true;
  for (size_t t = 0; t < n_tasks; ++t) {
    const config::TaskConfig& tc = cfg.tasks[t];
    lang::CompileOptions o;
    o.name = tc.name;
    if (tc.period_s) o.period_override = *tc.period_s;
    lang::CompileResult r = lang::compile_file(tc.program, o);
    file_of[t] = report.files.size();
    report.files.push_back({tc.program, read_file(tc.program), r.diags});
    if (!r.ok()) {
      cdiag.error(tc.program_pos, "task " + tc.name + ": its program does not compile (errors below)");
      ok = false;
      images.emplace_back();
      sources.emplace_back();
      continue;
    }
    images.push_back(std::move(*r.image));
    sources.push_back(report.files.back().text);
  }
  if (!ok) return false;

  // 2. Rate-monotonic priorities: shorter period, higher priority, inside the band.
  std::vector<int64_t> periods;
  for (const TaskImage& img : images) periods.push_back(img.header().period_ns);
  std::vector<int64_t> distinct = periods;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  std::vector<int> prio(n_tasks);
  for (size_t t = 0; t < n_tasks; ++t) {
    if (cfg.tasks[t].priority) {
      prio[t] = *cfg.tasks[t].priority;
      continue;
    }
    const auto rank = std::lower_bound(distinct.begin(), distinct.end(), periods[t]) - distinct.begin();
    int p = cfg.band_hi - static_cast<int>(rank);
    // Rate-monotonic also against priorities the user set: never above a task
    // with a shorter period, never below one with a longer period.
    for (size_t u = 0; u < n_tasks; ++u) {
      if (!cfg.tasks[u].priority) continue;
      if (periods[u] < periods[t]) p = std::min(p, *cfg.tasks[u].priority - 1);
    }
    for (size_t u = 0; u < n_tasks; ++u) {
      if (!cfg.tasks[u].priority) continue;
      if (periods[u] > periods[t]) p = std::max(p, std::min(*cfg.tasks[u].priority + 1, cfg.band_hi));
    }
    prio[t] = std::clamp(p, cfg.band_lo, cfg.band_hi);
  }

  // 3. Regions: one per task's outputs, per driver, the set-points, unwired inputs.
  io::ImageLayout layout;
  layout.name = name_;
  for (size_t t = 0; t < n_tasks; ++t) {
    layout.regions.push_back({"task:" + cfg.tasks[t].name, io::RegionKind::kTask,
                              static_cast<uint32_t>(t),
                              images[t].header().n_io_out + kSpareOutputs});
  }
  struct Produced {
    uint32_t region;
    uint32_t index;
    SourcePos pos;
    std::string label;
  };
  std::map<std::string, Produced> produced;  // input channels a driver writes
  for (size_t d = 0; d < cfg.drivers.size(); ++d) {
    const config::DriverConfig& dc = cfg.drivers[d];
    const auto region = static_cast<uint32_t>(layout.regions.size());
    driver_regions_.push_back(region);
    for (size_t p = 0; p < dc.plants.size(); ++p) {
      const std::string key = "in/DIO/" + dc.plants[p].output;
      auto [it, fresh] = produced.emplace(
          key, Produced{region, static_cast<uint32_t>(p), dc.plants[p].output_pos,
                        dc.name + "." + dc.plants[p].output});
      if (!fresh) {
        cdiag.error(dc.plants[p].output_pos, "input channel " + dc.plants[p].output +
                                                 " is already written by another plant (line " +
                                                 std::to_string(it->second.pos.line) + ")");
        ok = false;
      }
    }
    size_t capacity = dc.plants.size();
    if (const auto* s7 = std::any_cast<config::S7DriverSettings>(&dc.settings)) {
      // era/erd channels this driver provides, in its read-map order.
      for (size_t i = 0; i < s7->reads.size(); ++i) {
        const config::S7ChannelMap& m = s7->reads[i];
        const std::string key = "in/ETH/" + m.channel;
        auto [it, fresh] = produced.emplace(
            key, Produced{region, static_cast<uint32_t>(i), m.channel_pos, dc.name + "." + m.channel});
        if (!fresh) {
          cdiag.error(m.channel_pos, "input channel " + m.channel + " is already provided (line " +
                                         std::to_string(it->second.pos.line) + ")");
          ok = false;
        }
      }
      capacity = s7->reads.size();
      layout.n_links += static_cast<uint32_t>(s7->plcs.size());
    }
    layout.regions.push_back({"driver:" + dc.name, io::RegionKind::kDriver, static_cast<uint32_t>(d),
                              static_cast<uint32_t>(std::max<size_t>(capacity, 1))});
  }
  setpoint_region_ = static_cast<uint32_t>(layout.regions.size());
  layout.regions.push_back({"setpoints", io::RegionKind::kSetpoints, 0, 0});
  unwired_region_ = static_cast<uint32_t>(layout.regions.size());
  layout.regions.push_back({"unwired", io::RegionKind::kUnwired, 0, 0});

  // 4. Channels from every program's bindings.
  std::vector<io::ChannelDesc> descs;
  std::map<std::string, std::pair<std::string, size_t>> label_owner;  // label -> key, task
  uint32_t n_setpoints = 0, n_unwired = 0;
  task_output_keys_.assign(n_tasks, {});
  for (size_t t = 0; t < n_tasks; ++t) {
    const TaskImage& img = images[t];
    DiagnosticList& pdiag = report.files[file_of[t]].diags;
    task_output_keys_[t].assign(img.header().n_io_out, "");
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
      auto existing = channel_by_key_.find(key);
      if (b.dir == BindingDir::kOutput) {
        if (existing != channel_by_key_.end()) {
          const io::ChannelDesc& e = descs[existing->second];
          pdiag.error(at, "output " + key + " is already written by task " +
                              cfg.tasks[e.region].name + ": each output has one writer");
          ok = false;
          continue;
        }
        task_output_keys_[t][b.io_index] = key;
        channel_by_key_[key] = static_cast<uint32_t>(descs.size());
        descs.push_back(channel_desc(label, key, io::ChannelDir::kOutput, static_cast<uint8_t>(b.kind),
                                     static_cast<uint32_t>(t), b.io_index));
      } else if (existing == channel_by_key_.end()) {
        io::ChannelDesc d = channel_desc(label, key, io::ChannelDir::kInput, static_cast<uint8_t>(b.kind), 0, 0);
        if (b.dir == BindingDir::kSetpoint) {
          d.dir = static_cast<uint8_t>(io::ChannelDir::kSetpoint);
          d.region = static_cast<uint16_t>(setpoint_region_);
          d.index = n_setpoints++;
          d.init = b.init;
          d.retain = 1;
        } else {
          d.dir = static_cast<uint8_t>(io::ChannelDir::kInput);
          auto pr = produced.find(key);
          if (pr != produced.end()) {
            d.region = static_cast<uint16_t>(pr->second.region);
            d.index = pr->second.index;
          } else {
            d.region = static_cast<uint16_t>(unwired_region_);
            d.index = n_unwired++;
            pdiag.warning(at, "no driver provides input " + key + " (\"" + label +
                                  "\"): it reads 0 with bad quality");
          }
        }
        channel_by_key_[key] = static_cast<uint32_t>(descs.size());
        descs.push_back(d);
      }
    }
  }
  // Plant outputs nobody reads still show in the monitor; plant inputs must be driven.
  for (size_t d = 0; d < cfg.drivers.size(); ++d) {
    const config::DriverConfig& dc = cfg.drivers[d];
    for (size_t p = 0; p < dc.plants.size(); ++p) {
      const std::string in_key = "in/DIO/" + dc.plants[p].output;
      if (!channel_by_key_.count(in_key)) {
        const Produced& pr = produced[in_key];
        channel_by_key_[in_key] = static_cast<uint32_t>(descs.size());
        descs.push_back(channel_desc(pr.label, in_key, io::ChannelDir::kInput, 0, pr.region, pr.index));
      }
      const std::string out_key = "out/DIO/" + dc.plants[p].input;
      if (!channel_by_key_.count(out_key)) {
        cdiag.error(dc.plants[p].input_pos, "no task writes dao " + dc.plants[p].input +
                                                 ", the input of this plant");
        ok = false;
      }
    }
  }
  // S7 items nobody reads still show in the monitor; S7 writes need a task's output.
  for (size_t d = 0; d < cfg.drivers.size(); ++d) {
    const config::DriverConfig& dc = cfg.drivers[d];
    const auto* s7 = std::any_cast<config::S7DriverSettings>(&dc.settings);
    if (s7 == nullptr) continue;
    for (const config::S7ChannelMap& m : s7->reads) {
      const std::string key = "in/ETH/" + m.channel;
      if (channel_by_key_.count(key)) continue;
      const Produced& pr = produced[key];
      channel_by_key_[key] = static_cast<uint32_t>(descs.size());
      descs.push_back(channel_desc(pr.label, key, io::ChannelDir::kInput, 0, pr.region, pr.index));
    }
    for (const config::S7ChannelMap& m : s7->writes) {
      if (!channel_by_key_.count("out/ETH/" + m.channel)) {
        cdiag.error(m.channel_pos, "no task writes ewa/ewd " + m.channel + " to send to PLC " + m.plc);
        ok = false;
      }
    }
  }
  // Safe outputs name outputs of their own task.
  safe_outputs_.assign(n_tasks, {});
  for (size_t t = 0; t < n_tasks; ++t) {
    for (const config::SafeOutput& so : cfg.tasks[t].safe_outputs) {
      bool found = false;
      for (const Binding& b : images[t].bindings()) {
        found |= b.dir == BindingDir::kOutput && so.label == images[t].str(b.label);
      }
      if (!found) {
        cdiag.error(so.pos, "task " + cfg.tasks[t].name + " has no output labelled \"" + so.label + "\"");
        ok = false;
      }
    }
    safe_outputs_[t] = cfg.tasks[t].safe_outputs;
  }
  if (!ok) return false;
  if (descs.size() > kMaxChannels) {
    cdiag.error(SourcePos{}, "more than " + std::to_string(kMaxChannels) + " channels");
    return false;
  }

  layout.regions[setpoint_region_].capacity = n_setpoints + kSpareSetpoints;
  layout.regions[unwired_region_].capacity = n_unwired + kSpareUnwired;
  layout.channel_capacity =
      static_cast<uint32_t>(std::min<size_t>(kMaxChannels, descs.size() + 256));
  layout.n_tasks = static_cast<uint32_t>(n_tasks);
  layout.task_stats_bytes = sizeof(CycleStats);

  // 5. The shared memory itself.
  auto img = io::ProcessImage::create(layout);
  if (!img) {
    cdiag.error(SourcePos{}, img.error());
    return false;
  }
  image_ = std::move(img).value();
  for (const io::ChannelDesc& d : descs) {
    if (auto r = image_.add_channel(d); !r) {
      cdiag.error(SourcePos{}, r.error());
      return false;
    }
  }
  for (uint32_t t = 0; t < n_tasks; ++t) {
    new (image_.task_stats(t)) CycleStats();
    io::TaskInfo& ti = image_.task_info(t);
    copy_text(ti.name, sizeof ti.name, cfg.tasks[t].name);
    copy_text(ti.program, sizeof ti.program, cfg.tasks[t].program);
    ti.period_ns = periods[t];
    ti.priority = prio[t];
    ti.cpu = cfg.tasks[t].cpu ? static_cast<int32_t>(*cfg.tasks[t].cpu) : -1;
    ti.n_blocks = images[t].header().n_instr;
  }

  // 6. Set-points start at their init value, or at the value retained last time.
  setpoint_values_.assign(layout.regions[setpoint_region_].capacity, 0.0);
  if (auto r = retain_.load(); !r) {
    cdiag.warning(SourcePos{}, "retained values ignored: " + r.error());
  }
  for (uint32_t c = 0; c < image_.channel_count(); ++c) {
    const io::ChannelDesc& d = image_.channel(c);
    if (d.dir != static_cast<uint8_t>(io::ChannelDir::kSetpoint)) continue;
    double v = d.init;
    if (retain_.has(d.label)) {
      const double kept = retain_.get(d.label);
      if (d.kind == static_cast<uint8_t>(Kind::kDigital) && kept != 0 && kept != 1) {
        cdiag.warning(SourcePos{}, std::string("retained value of digital set-point ") + d.label +
                                       " is not 0 or 1; using its init value");
      } else {
        v = kept;
      }
    }
    setpoint_values_[d.index] = v;
  }
  publish_setpoints();

  // 7. Tasks and their first programs.
  previous_.resize(n_tasks);
  for (uint32_t t = 0; t < n_tasks; ++t) {
    auto prog = make_program(t, std::move(images[t]), sources[t], cfg.tasks[t].program, nullptr);
    if (!prog) {
      cdiag.error(cfg.tasks[t].pos, prog.error());
      return false;
    }
    TaskParams p;
    p.name = cfg.tasks[t].name;
    p.period_ns = periods[t];
    p.priority = prio[t];
    p.cpu = cfg.tasks[t].cpu ? static_cast<int>(*cfg.tasks[t].cpu) : -1;
    p.overrun = cfg.tasks[t].overrun == config::OverrunPolicy::kStop ? OverrunPolicy::kStop
                                                                     : OverrunPolicy::kSkip;
    p.watchdog = cfg.tasks[t].watchdog;
    p.count_faults = options_.count_faults;
    p.back_to_back = options_.back_to_back;
    tasks_.push_back(std::make_unique<Task>(std::move(p), image_, t, t, setpoint_region_,
                                            std::move(prog).value()));
  }

  // 8. Drivers.
  uint32_t next_link = 0;
  for (size_t d = 0; d < cfg.drivers.size(); ++d) {
    const config::DriverConfig& dc = cfg.drivers[d];
    const int prio_d = dc.priority ? *dc.priority : std::min(cfg.band_hi + 1, config::kMaxFifoPriority);
    if (const auto* s7 = std::any_cast<config::S7DriverSettings>(&dc.settings)) {
      std::vector<S7WriteWiring> wiring;
      for (const config::S7ChannelMap& m : s7->writes) {
        const io::ChannelDesc& out = image_.channel(channel_by_key_.at("out/ETH/" + m.channel));
        wiring.push_back({out.region, out.index});
      }
      // The engine thread only moves bytes: below every task, so it never delays one.
      const int engine_prio = std::max(1, cfg.band_lo - 1);
      auto drv = std::make_unique<S7Driver>(dc.name, image_, driver_regions_[d],
                                            std::llround(dc.period_s * 1e9), prio_d, engine_prio,
                                            dc.cpu ? static_cast<int>(*dc.cpu) : -1, *s7,
                                            std::move(wiring), next_link);
      next_link += static_cast<uint32_t>(s7->plcs.size());
      if (auto r = drv->prepare(); !r) {
        cdiag.error(dc.pos, r.error());
        return false;
      }
      s7_drivers_.push_back(std::move(drv));
      continue;
    }
    std::vector<SimPlantWiring> wiring;
    for (size_t p = 0; p < dc.plants.size(); ++p) {
      auto plant = io::make_plant(dc.plants[p].model);
      if (!plant) {
        cdiag.error(dc.plants[p].model_pos, plant.error());
        return false;
      }
      const io::ChannelDesc& in = image_.channel(channel_by_key_.at("out/DIO/" + dc.plants[p].input));
      SimPlantWiring w;
      w.plant = std::move(plant).value();
      w.input_region = in.region;
      w.input_index = in.index;
      w.output_index = static_cast<uint32_t>(p);
      wiring.push_back(std::move(w));
    }
    drivers_.push_back(std::make_unique<SimDriver>(
        dc.name, image_, driver_regions_[d], std::llround(dc.period_s * 1e9), prio_d,
        dc.cpu ? static_cast<int>(*dc.cpu) : -1, std::move(wiring)));
  }
  return true;
}

Result<std::unique_ptr<LoadedProgram>> Runtime::make_program(uint32_t t, TaskImage image,
                                                              std::string source, std::string file,
                                                              const LoadedProgram* running) {
  auto p = std::make_unique<LoadedProgram>();
  p->image = std::move(image);
  p->arena.resize_for(p->image);
  p->source = std::move(source);
  p->file = std::move(file);
  const io::RegionDesc& out_region = image_.region(t);
  if (p->image.header().n_io_out > out_region.capacity) {
    return make_error("the new program has " + std::to_string(p->image.header().n_io_out) +
                      " outputs, more than the " + std::to_string(out_region.capacity) +
                      " this task's region can hold; restart the runtime to grow it");
  }
  std::map<uint32_t, size_t> group_of;  // region -> index in p->inputs
  std::vector<std::string>& out_keys = task_output_keys_[t];
  for (const Binding& b : p->image.bindings()) {
    const std::string key = binding_key(b);
    const std::string label = p->image.str(b.label);
    auto it = channel_by_key_.find(key);
    if (it != channel_by_key_.end() && label != image_.channel(it->second).label) {
      // Labels are how operators, retain files and HMIs name channels: a swap
      // cannot rename one under them.
      return make_error("channel " + key + " is labelled \"" + image_.channel(it->second).label +
                        "\" in the running runtime, not \"" + label + "\"");
    }
    if (b.dir == BindingDir::kOutput) {
      if (it != channel_by_key_.end()) {
        const io::ChannelDesc& d = image_.channel(it->second);
        if (d.region != t) {
          return make_error("output " + key + " is written by task " +
                            std::string(image_.region(d.region).name).substr(5) +
                            "; each output has one writer");
        }
        if (d.index != b.io_index) return make_error("internal: output " + key + " moved");
        continue;
      }
      // A new output (hot swap): a new channel in this task's spare room.
      if (image_.find_channel(label) >= 0) {
        return make_error("label \"" + label + "\" already names another channel");
      }
      auto added = image_.add_channel(
          channel_desc(label, key, io::ChannelDir::kOutput, static_cast<uint8_t>(b.kind), t, b.io_index));
      if (!added) return make_error(added.error());
      channel_by_key_[key] = *added;
      if (out_keys.size() <= b.io_index) out_keys.resize(b.io_index + 1);
      out_keys[b.io_index] = key;
      continue;
    }
    if (it == channel_by_key_.end()) {
      // A new input or set-point (hot swap).
      io::ChannelDesc d = channel_desc(label, key, io::ChannelDir::kInput, static_cast<uint8_t>(b.kind), 0, 0);
      if (image_.find_channel(label) >= 0) {
        return make_error("label \"" + label + "\" already names another channel");
      }
      uint32_t used = 0;
      const uint32_t region = b.dir == BindingDir::kSetpoint ? setpoint_region_ : unwired_region_;
      for (uint32_t c = 0; c < image_.channel_count(); ++c) used += image_.channel(c).region == region;
      if (used >= image_.region(region).capacity) {
        return make_error("no room for new channel " + key + "; restart the runtime to add it");
      }
      d.region = static_cast<uint16_t>(region);
      d.index = used;
      if (b.dir == BindingDir::kSetpoint) {
        d.dir = static_cast<uint8_t>(io::ChannelDir::kSetpoint);
        d.init = b.init;
        d.retain = 1;
        setpoint_values_[used] = retain_.has(label) ? retain_.get(label) : b.init;
      } else {
        d.dir = static_cast<uint8_t>(io::ChannelDir::kInput);
      }
      auto added = image_.add_channel(d);
      if (!added) return make_error(added.error());
      it = channel_by_key_.emplace(key, *added).first;
      if (b.dir == BindingDir::kSetpoint) publish_setpoints();
    }
    const io::ChannelDesc& d = image_.channel(it->second);
    if (d.kind != static_cast<uint8_t>(b.kind)) {
      return make_error("channel " + key + " is " + (d.kind ? "digital" : "analog") +
                        " in the running image");
    }
    if (b.dir == BindingDir::kSetpoint) p->arena.io_in[b.io_index] = setpoint_values_[d.index];
    if (d.region == unwired_region_) continue;  // nobody writes it: stays 0
    auto g = group_of.find(d.region);
    if (g == group_of.end()) {
      g = group_of.emplace(d.region, p->inputs.size()).first;
      InputGroup ig;
      ig.region = d.region;
      ig.setpoints = d.region == setpoint_region_;
      p->inputs.push_back(std::move(ig));
    }
    InputGroup& ig = p->inputs[g->second];
    // Two blocks may read one channel: one copy per input-buffer entry suffices.
    if (std::find(ig.dst.begin(), ig.dst.end(), b.io_index) == ig.dst.end()) {
      ig.src.push_back(d.index);
      ig.dst.push_back(b.io_index);
    }
  }
  const uint32_t n_out = p->image.header().n_io_out;
  p->output_slots.resize(n_out);
  p->safe_values.assign(n_out, 0.0);
  for (uint32_t k = 0; k < n_out; ++k) p->output_slots[k] = k;  // the layout is kept (see swap)
  p->outputs_in_place = true;
  for (const Binding& b : p->image.bindings()) {
    if (b.dir != BindingDir::kOutput) continue;
    for (const config::SafeOutput& so : safe_outputs_[t]) {
      if (so.label == p->image.str(b.label)) p->safe_values[b.io_index] = so.value;
    }
  }
  if (running != nullptr) p->migration = plan_migration(running->image, p->image);
  return p;
}

void Runtime::publish_setpoints() {
  const uint32_t k = image_.begin_write(setpoint_region_);
  const int64_t now = kernel_rt::monotonic_now_ns();
  for (size_t i = 0; i < setpoint_values_.size(); ++i) {
    image_.put(setpoint_region_, k, static_cast<uint32_t>(i), setpoint_values_[i], io::Quality::kGood, now);
  }
  image_.end_write(setpoint_region_, k, now, 0);
}

// ---------------------------------------------------------------------------
// Running

Result<std::vector<std::string>> Runtime::start() {
  std::vector<std::string> notices;
  if (started_) return notices;
  if (lock_memory_) {
    rt_ = kernel_rt::prepare_process_for_rt();
    notices = rt_.notices;
  } else {
    rt_.rt_kernel = kernel_rt::running_on_rt_kernel();
    if (!rt_.rt_kernel) notices.push_back("the kernel is not PREEMPT_RT: expect wake latencies of a general-purpose kernel");
  }
  image_.header().state.store(1, std::memory_order_release);
  // A common grid: every thread's first release is the same instant, far enough
  // ahead that all threads are waiting for it.
  const int64_t now = kernel_rt::monotonic_now_ns();
  const int64_t first = (now / 1000000 + 100) * 1000000;
  for (auto& d : drivers_) {
    if (auto r = d->start(first); !r) {
      stop();
      return make_error(r.error());
    }
  }
  for (auto& d : s7_drivers_) {
    if (auto r = d->start(first); !r) {
      stop();
      return make_error(r.error());
    }
  }
  // Staggered releases: tasks never wake at the same instant, so one task's
  // wake-up and cycle do not add to another's latency on a shared CPU. The
  // phases spread over the shortest period, so each stays inside its own.
  int64_t min_period = INT64_MAX;
  for (auto& t : tasks_) min_period = std::min(min_period, t->params().period_ns);
  const int64_t phase = tasks_.empty() ? 0 : min_period / static_cast<int64_t>(tasks_.size());
  bool said_other = false;
  int64_t offset = 0;
  for (auto& t : tasks_) {
    auto r = t->start(first + offset);
    offset += phase;
    if (!r) {
      stop();
      return make_error(r.error());
    }
    if (t->fell_back_to_other() && !said_other) {
      said_other = true;
      notices.push_back("tasks run SCHED_OTHER, not SCHED_FIFO: " + t->fallback_reason());
    }
  }
  started_ = true;
  return notices;
}

void Runtime::stop() {
  for (auto& t : tasks_) t->request_stop();
  for (auto& t : tasks_) t->join();
  for (auto& d : drivers_) d->request_stop();
  for (auto& d : drivers_) d->join();
  // Tasks have set their outputs safe: one last exchange sends those to the PLCs
  // (S7Driver's thread ends after a final status publish; its engine stops with it).
  for (auto& d : s7_drivers_) d->request_stop();
  for (auto& d : s7_drivers_) d->join();
  if (image_.valid() && image_.writable()) image_.header().state.store(2, std::memory_order_release);
  started_ = false;
}

void Runtime::reap() {
  for (auto& t : tasks_) {
    if (auto old = t->collect()) graveyard_.push_back(std::move(old));
  }
  graveyard_.clear();
}

// ---------------------------------------------------------------------------
// Operator verbs

Result<std::string> Runtime::set_value(const std::string& label, double value) {
  const int c = image_.find_channel(label);
  if (c < 0) return make_error("no channel is labelled \"" + label + "\"");
  const io::ChannelDesc& d = image_.channel(static_cast<uint32_t>(c));
  if (d.dir != static_cast<uint8_t>(io::ChannelDir::kSetpoint)) {
    return make_error("\"" + label + "\" is " +
                      (d.dir == static_cast<uint8_t>(io::ChannelDir::kInput) ? "an input" : "an output") +
                      "; only set-points (asp, dsp) can be set");
  }
  if (!std::isfinite(value)) return make_error("the value must be a finite number");
  if (d.kind == static_cast<uint8_t>(Kind::kDigital) && value != 0 && value != 1) {
    return make_error("\"" + label + "\" is a digital set-point: 0 or 1");
  }
  const double before = setpoint_values_[d.index];
  if (d.retain) {
    // On disk first: once the operator sees OK, the value survives a crash.
    RetainStore next = retain_;
    next.set(label, value);
    if (auto r = next.save(); !r) return make_error("not changed: cannot retain it: " + r.error());
    retain_ = std::move(next);
  }
  setpoint_values_[d.index] = value;
  publish_setpoints();
  return label + " = " + format_number(value) + " (was " + format_number(before) + ")" +
         (d.retain ? ", retained in " + retain_.path() : "");
}

Result<std::string> Runtime::install(Task& t, std::unique_ptr<LoadedProgram> next, bool keep_previous) {
  const int64_t requested = kernel_rt::monotonic_now_ns();
  const uint64_t swaps_before = image_.task_info(t.index()).swaps.load(std::memory_order_relaxed);
  const Migration summary = next->migration;
  const uint32_t n_blocks = next->image.header().n_instr;
  if (!t.publish(std::move(next))) return make_error("a swap of task " + t.params().name + " is already in progress");
  // The task takes it at its next cycle boundary: wait at most a few periods.
  const int64_t deadline = requested + std::max<int64_t>(10 * t.params().period_ns, 2000000000);
  while (!t.swap_applied()) {
    if (kernel_rt::monotonic_now_ns() > deadline) {
      // Cannot happen while the task runs; say so rather than hang the operator.
      return make_error("task " + t.params().name + " did not take the new program (is it running?)");
    }
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  const int64_t applied = image_.task_info(t.index()).last_swap_ns.load(std::memory_order_relaxed);
  std::unique_ptr<LoadedProgram> old = t.collect();
  if (keep_previous && old) {
    old->arena = TaskArena();  // its state is not needed for a rollback, only its code
    previous_[t.index()] = std::move(old);
  }
  image_.task_info(t.index()).n_blocks = n_blocks;
  (void)swaps_before;
  std::string out = "task " + t.params().name + ": now running " + t.active().file + " (" +
                    std::to_string(n_blocks) + " blocks), applied at a cycle boundary " +
                    fmt_ms(applied - requested) + " after the request\n";
  auto list = [&out](const char* what, const std::vector<std::string>& names) {
    out += std::string("  ") + what + ": " + std::to_string(names.size());
    for (size_t i = 0; i < names.size() && i < 12; ++i) out += (i ? ", " : " (") + names[i];
    if (!names.empty()) out += names.size() > 12 ? ", ...)" : ")";
    out += "\n";
  };
  list("kept state", summary.kept);
  list("reset", summary.reset);
  list("new", summary.added);
  list("removed", summary.removed);
  return out;
}

Result<std::string> Runtime::swap(const std::string& task, const std::string& source,
                                  const std::string& file_label) {
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  Task* t = find_task(task);
  if (t == nullptr) return make_error("no task named " + task);
  lang::CompileOptions o;
  o.name = task;
  o.period_override = static_cast<double>(t->params().period_ns) / 1e9;  // the task keeps its grid
  o.output_layout = task_output_keys_[t->index()];
  lang::CompileResult r = lang::compile_source(source, o);
  if (!r.ok()) {
    return make_error("not swapped, the program has errors:\n" + r.diags.render(file_label, source));
  }
  const int64_t compiled = kernel_rt::monotonic_now_ns();
  auto next = make_program(t->index(), std::move(*r.image), source, file_label, &t->active());
  if (!next) return make_error("not swapped: " + next.error());
  auto res = install(*t, std::move(next).value(), true);
  if (!res) return res;
  std::string warn = r.diags.warning_count() ? r.diags.render(file_label, source) : "";
  return "compiled and verified in " + fmt_ms(compiled - t0) + "\n" + *res + warn;
}

Result<std::string> Runtime::rollback(const std::string& task) {
  Task* t = find_task(task);
  if (t == nullptr) return make_error("no task named " + task);
  const std::unique_ptr<LoadedProgram>& prev = previous_[t->index()];
  if (!prev) return make_error("task " + task + " has no previous program to roll back to");
  auto copy = TaskImage::from_bytes(prev->image.bytes());
  if (!copy) return make_error(copy.error());
  auto next = make_program(t->index(), std::move(copy).value(), prev->source, prev->file, &t->active());
  if (!next) return make_error("not rolled back: " + next.error());
  return install(*t, std::move(next).value(), true);
}

std::string Runtime::status() const {
  std::string s = "runtime " + name_ + " (pid " + std::to_string(getpid()) + "), " +
                  std::to_string(tasks_.size()) + " tasks, " + std::to_string(drivers_.size() + s7_drivers_.size()) +
                  " drivers, " + std::to_string(image_.channel_count()) + " channels\n";
  s += "shared memory " + image_.object_name() + ", control socket " + socket_path_ +
       ", retain file " + retain_.path() + "\n";
  for (uint32_t l = 0; l < image_.link_count(); ++l) {
    const LinkSnapshot ls = link_snapshot(image_.link(l));
    s += "  plc " + ls.name + " (" + ls.driver + ", " + ls.address + "): " + ls.state + ", rtt p50/p99 " +
         std::to_string(ls.rtt_p50_us) + "/" + std::to_string(ls.rtt_p99_us) + " us, " +
         std::to_string(ls.reconnects) + " reconnects, " + std::to_string(ls.timeouts) + " timeouts, " +
         std::to_string(ls.errors) + " errors, writes " + std::to_string(ls.writes_acked) + " acked / " +
         std::to_string(ls.writes_failed) + " failed / " + std::to_string(ls.writes_pending) + " pending\n";
  }
  for (const auto& t : tasks_) {
    const io::TaskInfo& ti = image_.task_info(t->index());
    const auto* st = static_cast<const CycleStats*>(image_.task_stats(t->index()));
    s += "  task " + t->params().name + ": " +
         io::task_state_name(static_cast<io::TaskState>(ti.state.load())) + ", " +
         t->active().file + ", period " + fmt_ms(t->params().period_ns) + ", " +
         (ti.fifo ? "FIFO " + std::to_string(ti.priority) : std::string("OTHER")) + ", " +
         std::to_string(st->cycles()) + " cycles, " + std::to_string(st->overruns()) +
         " overruns, " + std::to_string(ti.swaps.load()) + " swaps, " +
         std::to_string(ti.block_errors.load()) + " block errors\n";
  }
  return s;
}

std::vector<std::string> Runtime::describe() const {
  std::vector<std::string> out;
  for (const auto& t : tasks_) {
    const TaskParams& p = t->params();
    out.push_back("task " + p.name + ": " + t->active().file + ", " +
                  std::to_string(t->active().image.header().n_instr) + " blocks, period " +
                  fmt_ms(p.period_ns) + ", priority " + std::to_string(p.priority) +
                  (p.cpu >= 0 ? ", cpu " + std::to_string(p.cpu) : "") +
                  (p.watchdog ? ", watchdog " + std::to_string(p.watchdog) : ""));
  }
  for (const auto& d : drivers_) out.push_back("driver " + d->name() + " (sim)");
  for (const auto& d : s7_drivers_) out.push_back("driver " + d->name() + " (s7)");
  const double bound = liu_layland_bound(tasks_.size());
  out.push_back("Liu-Layland bound for " + std::to_string(tasks_.size()) + " tasks: " +
                format_number(bound * 100) + "% utilisation");
  return out;
}

std::vector<TaskStatsView> Runtime::stats_views() const { return read_task_stats(image_); }

}  // namespace rtplc::sched
