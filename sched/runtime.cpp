// Loading, starting and operating the runtime (see runtime.h).
#include "sched/runtime.h"

#include <grp.h>
#include <pwd.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <new>
#include <set>
#include <thread>

#include "blocks/registry.h"
#include "common/capacities.h"
#include "common/files.h"
#include "common/text.h"
#include "kernel_rt/clock.h"
#include "config/values.h"
#include "kernel_rt/rt_kernel.h"
#include "kernel_rt/rt_thread.h"
#include "lang/compiler.h"
#include "sched/stats_source.h"

static_assert(rtplc::config::kDefaultLoopBudget == rtplc::kDefaultLoopBudget,
              "the config's default loop budget is the executor's");

namespace rtplc::sched {
namespace {


std::string read_file(const std::string& path) {
  std::string err;
  auto t = lang::read_text_file(path, &err);
  return t ? *t : std::string();
}

}  // namespace

// systemd's $RUNTIME_DIRECTORY / $STATE_DIRECTORY (RuntimeDirectory=,
// StateDirectory= of a unit; several are separated by ':'): the first one.
static std::string systemd_directory(const char* var) {
  const char* v = std::getenv(var);
  if (v == nullptr || *v == '\0') return "";
  const std::string all = v;
  return all.substr(0, all.find(':'));
}

std::string default_socket_path(const std::string& name) {
  // A folder of our own, checked before use (ensure_private_folder): the one
  // systemd made for the unit, root's /run/rtplc, a user's runtime folder or /tmp.
  if (const std::string d = systemd_directory("RUNTIME_DIRECTORY"); !d.empty()) return d + "/" + name + ".sock";
  if (geteuid() == 0) return "/run/rtplc/" + name + ".sock";
  if (const char* x = std::getenv("XDG_RUNTIME_DIR"); x && *x) {
    return std::string(x) + "/rtplc/" + name + ".sock";
  }
  return "/tmp/rtplc-" + std::to_string(geteuid()) + "/" + name + ".sock";
}

std::string default_retain_path(const std::string& name) {
  if (const std::string d = systemd_directory("STATE_DIRECTORY"); !d.empty()) return d + "/" + name + ".retain";
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

std::string Runtime::no_task_text(const std::string& name) const {
  std::string list;
  for (const auto& t : tasks_) list += (list.empty() ? "" : ", ") + t->params().name;
  return "no task named " + name + (list.empty() ? std::string("; this runtime has no tasks")
                                                  : "; the tasks are " + list);
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
  // Whose state this is: the runtime's own, or (check) the runtime it previews.
  rt->state_name_ = opt.state_name.empty() ? rt->name_ : opt.state_name;
  rt->retain_ = RetainStore(!opt.retain_override.empty() ? opt.retain_override
                            : !cfg.retain_path.empty()   ? cfg.retain_path
                                                         : default_retain_path(rt->state_name_));
  rt->programs_ = ProgramStore(folder_of(rt->retain_.path()) + "/" + rt->state_name_ + ".programs");
  rt->state_path_ = folder_of(rt->retain_.path()) + "/" + rt->state_name_ + ".state";
  rt->api_ = std::make_unique<OperatorApi>(*rt);
  rt->retain_every_ns_ = std::llround(cfg.retain_every_s * 1e9);
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
  // One runtime of a name at a time, decided by a lock in the runtime's own
  // folder (the socket's, which must be private to us), never by a pid in
  // shared memory that anyone could have written.
  const std::string folder = folder_of(rt->socket_path_);
  if (auto r = ensure_private_folder(folder, !cfg.operators.empty()); !r) {
    report.files[0].diags.error(cfg.socket_pos, "control socket folder: " + r.error());
    report.ok = false;
    return nullptr;
  }
  // The state folder: what the runtime boots from must be nobody else's to write.
  if (auto r = ensure_state_folder(folder_of(rt->retain_.path()), !opt.check_only); !r) {
    report.files[0].diags.error(cfg.retain_pos, "retain folder: " + r.error());
    report.ok = false;
    return nullptr;
  }
  auto lock = opt.check_only ? Result<FileLock>(FileLock{}) : FileLock::acquire(folder + "/" + rt->name_ + ".lock");
  if (!lock) {
    report.files[0].diags.error(cfg.name_pos, "runtime '" + rt->name_ + "' is " + lock.error() +
                                                  "; stop it or choose another runtime name");
    report.ok = false;
    return nullptr;
  }
  rt->lock_ = std::move(lock).value();
  if (!cfg.monitor_group.empty()) {
    const group* g = getgrnam(cfg.monitor_group.c_str());
    if (g == nullptr) {
      report.files[0].diags.error(cfg.monitor_group_pos, "no group named '" + cfg.monitor_group + "' on this machine");
      report.ok = false;
      return nullptr;
    }
    rt->monitor_gid_ = static_cast<int>(g->gr_gid);
  }
  // runtime.operators: names to ids now, so a typo fails the start, not a request.
  for (const config::OperatorGrant& o : cfg.operators) {
    const bool digits = !o.who.empty() && o.who.find_first_not_of("0123456789") == std::string::npos;
    std::optional<uint32_t> id;
    if (o.group) {
      if (const group* gr = getgrnam(o.who.c_str())) id = static_cast<uint32_t>(gr->gr_gid);
    } else if (digits && o.who.size() <= 9) {
      id = static_cast<uint32_t>(std::stoul(o.who));
    } else if (const passwd* pw = getpwnam(o.who.c_str())) {
      id = static_cast<uint32_t>(pw->pw_uid);
    }
    if (!id) {
      report.files[0].diags.error(o.pos, std::string("operators: no ") + (o.group ? "group" : "user") + " named '" +
                                             o.who + "' on this machine");
      report.ok = false;
      return nullptr;
    }
    rt->grants_.push_back(Grant{o.group, *id, o.role});
  }
  // Drivers keep pointers into their config entries: the runtime owns a copy.
  rt->config_ = cfg;
  if (!rt->build(rt->config_, report)) {
    report.ok = false;
    return nullptr;
  }
  report.ok = true;
  return rt;
}

bool Runtime::build(const config::RuntimeConfig& cfg, LoadReport& report) {
  DiagnosticList& cdiag = report.files[0].diags;
  const size_t n_tasks = cfg.tasks.size();

  // 0. What only this machine can say, said by `check` as by `run`: a CPU to pin
  // to must be one this process may run on.
  bool machine_ok = true;
  auto check_cpu = [&](const std::optional<unsigned>& cpu, SourcePos pos, const std::string& who) {
    if (!cpu || kernel_rt::cpu_allowed(*cpu)) return;
    cdiag.error(pos, who + ": CPU " + std::to_string(*cpu) + " is not available on this machine (this process may use " +
                         std::to_string(kernel_rt::allowed_cpu_count()) + " CPUs)");
    machine_ok = false;
  };
  for (const config::TaskConfig& tc : cfg.tasks) check_cpu(tc.cpu, tc.cpu_pos, "task " + tc.name);
  for (const config::DriverConfig& dc : cfg.drivers) check_cpu(dc.cpu, dc.cpu_pos, "driver " + dc.name);
  if (!machine_ok) return false;

  // 1. Compile every program; a program's problems are reported against its text.
  std::vector<TaskImage> images;
  std::vector<std::string> sources;
  std::vector<size_t> file_of(n_tasks, 0);
  bool ok = true;
  if (auto r = programs_.load(); !r) {
    cdiag.warning(SourcePos{}, "the saved programs are ignored: " + r.error() + "; running the config's files");
  }
  origins_.assign(n_tasks, "");
  for (size_t t = 0; t < n_tasks; ++t) {
    const config::TaskConfig& tc = cfg.tasks[t];
    lang::CompileOptions o;
    o.name = tc.name;
    o.entry = tc.program_instance;
    o.semantics = lang::parse_editor_semantics(tc.semantics).value_or(lang::EditorSemantics::kFromHeader);
    if (tc.period_s) o.period_override = *tc.period_s;
    // The boot program: what this task ran last, unless the config says otherwise.
    std::optional<ProgramVersion> saved = cfg.programs_from_config ? std::nullopt : programs_.current(tc.name);
    std::optional<lang::CompileResult> from_store;
    if (saved) {
      auto text = programs_.source(saved->hash);
      const std::string config_text = read_file(tc.program);
      if (!text) {
        cdiag.warning(tc.program_pos, "task " + tc.name + ": " + text.error() + "; running " + tc.program);
      } else if (ProgramStore::hash_of(config_text) != saved->hash) {
        lang::CompileResult r = lang::compile_source(*text, o);
        if (r.ok()) {
          const std::string label = "saved program " + saved->hash + " of task " + tc.name;
          origins_[t] = saved->origin;
          notices_.push_back("task " + tc.name + " runs the program it ran last (" + saved->origin + ", " +
                             saved->hash + "), not " + tc.program + " as the config names: set "
                             "runtime.programs: config to run the config's file");
          file_of[t] = report.files.size();
          report.files.push_back({label, *text, r.diags});
          images.push_back(std::move(*r.image));
          sources.push_back(*text);
          continue;
        }
        cdiag.warning(tc.program_pos, "task " + tc.name + ": its saved program " + saved->hash +
                                          " no longer compiles; running " + tc.program);
      }
    }
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
    // The config's period replaces the program's stime; say so when they differ
    // (`period: 100` on a 0.1 s program runs it a thousand times slower).
    if (tc.period_s && r.program.period_from_stime &&
        std::abs(r.program.period - *tc.period_s) > 1e-9 * *tc.period_s) {
      cdiag.warning(tc.period_pos, "task " + tc.name + ": period " + config::format_duration(*tc.period_s) +
                                       " replaces the stime " + config::format_duration(r.program.period) +
                                       " of " + tc.program + " (leave 'period' out to run at the program's stime)");
    }
    images.push_back(std::move(*r.image));
    sources.push_back(report.files.back().text);
    origins_[t] = "config " + tc.program;
    // The store always says what runs: the config's file is now the current version.
    const auto cur = programs_.current(tc.name);
    if (!options_.check_only && (!cur || cur->hash != ProgramStore::hash_of(sources.back()))) {
      if (auto p = programs_.push(tc.name, sources.back(), origins_[t]); !p) {
        cdiag.warning(SourcePos{}, "task " + tc.name + ": cannot keep its program for restarts: " + p.error());
      }
    }
  }
  if (!ok) return false;

  // 2. What every driver exchanges, from its kind; then the plan of the image.
  std::vector<config::DriverClaims> claims;
  for (const config::DriverConfig& dc : cfg.drivers) {
    const io::DriverKind* kind = io::find_driver_kind(dc.kind);
    if (kind == nullptr) {
      cdiag.error(dc.kind_pos, "driver kind '" + dc.kind + "' is not built into this rtplc");
      return false;
    }
    claims.push_back(kind->config->claims(dc));
  }
  PlanDiagnostics pd;
  pd.config = &cdiag;
  for (size_t t = 0; t < n_tasks; ++t) pd.programs.push_back(&report.files[file_of[t]].diags);
  if (!plan_image(cfg, name_, images, claims, pd, plan_)) return false;
  plan_.layout.task_stats_bytes = sizeof(CycleStats);
  plan_.layout.monitor_gid = monitor_gid_;
  const std::vector<int64_t>& periods = plan_.periods_ns;
  const std::vector<int>& prio = plan_.priorities;
  const io::ImageLayout& layout = plan_.layout;
  const std::vector<io::ChannelDesc>& descs = plan_.channels;
  channel_by_key_ = plan_.channel_by_key;
  task_output_keys_ = plan_.task_output_keys;
  task_entries_.clear();
  for (const config::TaskConfig& tc : cfg.tasks) {
    task_entries_.push_back(tc.program_instance);
    task_semantics_.push_back(
        lang::parse_editor_semantics(tc.semantics).value_or(lang::EditorSemantics::kFromHeader));
  }
  setpoint_region_ = plan_.setpoint_region;
  unwired_region_ = plan_.unwired_region;
  safe_outputs_.assign(n_tasks, {});
  for (size_t t = 0; t < n_tasks; ++t) safe_outputs_[t] = cfg.tasks[t].safe_outputs;

  // 3. The shared memory itself.
  auto img = io::ProcessImage::create(layout);
  if (!img) {
    cdiag.error(SourcePos{}, img.error());
    return false;
  }
  image_ = std::move(img).value();
  if (socket_path_.size() < sizeof image_.header().socket_path) {
    std::memcpy(image_.header().socket_path, socket_path_.c_str(), socket_path_.size() + 1);
  }
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

  // 4. Set-points start at their init value, or at the value retained last time.
  for (const config::TaskConfig& tc : cfg.tasks) {
    for (const config::SetpointLimits& lim : tc.setpoint_limits) setpoint_limits_[lim.label] = lim;
    for (const config::SetpointLimits& r : tc.channel_ranges) channel_ranges_[r.label] = r;
  }
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
      const auto lim = setpoint_limits_.find(d.label);
      if (d.kind == static_cast<uint8_t>(Kind::kDigital) && kept != 0 && kept != 1) {
        cdiag.warning(SourcePos{}, std::string("retained value of digital set-point ") + d.label +
                                       " is not 0 or 1; using its init value");
      } else if (lim != setpoint_limits_.end() && ((lim->second.min && kept < *lim->second.min) ||
                                                   (lim->second.max && kept > *lim->second.max))) {
        cdiag.warning(lim->second.pos, std::string("retained value ") + format_number(kept) + " of set-point " +
                                           d.label + " is outside its limits " +
                                           limits_text(lim->second.min, lim->second.max) +
                                           "; using its init value " + format_number(d.init));
      } else {
        v = kept;
      }
    }
    setpoint_values_[d.index] = v;
  }
  publish_setpoints();

  // 5. Tasks and their first programs.
  previous_.resize(n_tasks);
  for (uint32_t t = 0; t < n_tasks; ++t) {
    std::vector<std::string> unknown;
    (void)retained_blocks(images[t], cfg.tasks[t].retain_all, cfg.tasks[t].retain_blocks, &unknown);
    if (!unknown.empty()) {
      std::string list;
      for (const std::string& u : unknown) list += (list.empty() ? "'" : ", '") + u + "'";
      cdiag.error(cfg.tasks[t].retain_pos, "task " + cfg.tasks[t].name + ": 'retain' names " + list +
                                               ", not a block of its program");
      return false;
    }
    auto prog = make_program(t, std::move(images[t]), sources[t], cfg.tasks[t].program, nullptr);
    if (!prog) {
      cdiag.error(cfg.tasks[t].pos, prog.error());
      return false;
    }
    {
      std::lock_guard setpoints(setpoint_mu_);
      commit_new_channels(t, **prog);
    }
    TaskParams p;
    p.name = cfg.tasks[t].name;
    p.period_ns = periods[t];
    p.priority = prio[t];
    p.cpu = cfg.tasks[t].cpu ? static_cast<int>(*cfg.tasks[t].cpu) : -1;
    p.overrun = cfg.tasks[t].overrun;
    p.watchdog = cfg.tasks[t].watchdog;
    p.loop_budget = cfg.tasks[t].loop_budget;
    p.count_faults = options_.count_faults;
    p.back_to_back = options_.back_to_back;
    // Four snapshots per state-file write: the file is at most 1.25 retain_every old.
    const int64_t every = retain_every_ns_ / 4 / std::max<int64_t>(periods[t], 1);
    p.snapshot_every = static_cast<uint32_t>(std::clamp<int64_t>(every, 1, UINT32_MAX));
    p.watch_every = static_cast<uint32_t>(std::clamp<int64_t>(100'000'000 / std::max<int64_t>(periods[t], 1), 1, UINT32_MAX));
    tasks_.push_back(std::make_unique<Task>(std::move(p), image_, t, t, setpoint_region_,
                                            std::move(prog).value()));
  }

  // 6. Retained block state: a warm start continues where the last run left off.
  restore_state(cfg, cdiag);

  // 7. Drivers.
  return create_drivers(cfg, cdiag);
}

bool Runtime::create_drivers(const config::RuntimeConfig& cfg, DiagnosticList& cdiag) {
  for (size_t d = 0; d < cfg.drivers.size(); ++d) {
    const config::DriverConfig& dc = cfg.drivers[d];
    const DriverPlan& dp = plan_.drivers[d];
    io::DriverSetup setup;
    setup.config = &dc;
    setup.image = &image_;
    setup.region = dp.region;
    setup.n_provides = dp.n_provides;
    setup.consumes = dp.consumes;
    setup.first_link = dp.first_link;
    setup.period_ns = std::llround(dc.period_s * 1e9);
    setup.priority = dp.priority;
    setup.helper_priority = dp.helper_priority;
    setup.cpu = dc.cpu ? static_cast<int>(*dc.cpu) : -1;
    setup.events = &events_;
    // A driver that writes set-points (an HMI over Modbus) is a caller of the
    // operator API of its own, with the operator's role: set-points within
    // their limits, audited, saved coalesced (no fsync per network write).
    setup.set_point = [this, who = "driver " + dc.name + " (" + dc.kind + ")"](const std::string& label, double value) -> Result<std::string> {
      const ApiAnswer a = api_->set_point(Caller{who, static_cast<uint32_t>(geteuid()), Role::kOperator}, label, value,
                                          false);
      if (!a.ok) return make_error(a.message);
      return a.result.value("text", std::string());
    };
    setup.state_prefix = folder_of(state_path_) + "/" + state_name_;
    auto drv = io::find_driver_kind(dc.kind)->create(setup);
    if (!drv) {
      cdiag.error(dc.pos, "driver " + dc.name + ": " + drv.error());
      return false;
    }
    drivers_.push_back(std::move(drv).value());
  }
  return true;
}

Result<std::unique_ptr<LoadedProgram>> Runtime::make_program(uint32_t t, TaskImage image,
                                                              std::string source, std::string file,
                                                              const LoadedProgram* running,
                                                              const std::vector<std::string>& drop_outputs,
                                                              bool compile_native_code) {
  // Native code is compiled first, outside the lock: it takes the compiler's
  // time. Not for `rtplc check` nor a swap's check: only code that will run.
  std::shared_ptr<const NativeCode> native;
  if (config_.tasks[t].native && compile_native_code && !options_.check_only) {
    // The housekeeping goes on while the compiler runs (seconds for a large
    // program): retained state and set-points saved, driver events logged. On
    // the control thread only (a swap, a rollback); tick() never makes a program,
    // and no lock is held here. A stop of the runtime stops the compile.
    NativeOptions opt;
    opt.while_waiting = [this] {
      if (tick_log_) tick(tick_log_);
      return !(stopping_ && stopping_());
    };
    auto n = compile_native(image, opt);
    if (!n) return make_error("task '" + config_.tasks[t].name + "' (native: true): " + n.error());
    native = std::move(*n);
  }
  // New set-points of a swap take their value under the lock set_value() holds.
  std::lock_guard setpoints(setpoint_mu_);
  auto p = std::make_unique<LoadedProgram>();
  p->image = std::move(image);
  p->native = std::move(native);
  p->arena.resize_for(p->image);
  p->lane.resize_for(p->image);
  // A swapped-in program retains the blocks its task's `retain` selects; a
  // listed name it no longer has is simply not there (checked at load only).
  p->snapshot.prepare(retained_blocks(p->image, config_.tasks[t].retain_all, config_.tasks[t].retain_blocks));
  p->watch.prepare(watched_blocks(p->image));
  p->source = std::move(source);
  p->file = std::move(file);
  p->errors_reported.assign(p->image.header().n_instr, 0);
  const io::RegionDesc& out_region = image_.region(t);
  if (p->image.header().n_io_out > out_region.capacity) {
    return make_error("the new program has " + std::to_string(p->image.header().n_io_out) +
                      " outputs, more than the " + std::to_string(out_region.capacity) +
                      " this task's region can hold; restart the runtime to grow it");
  }
  std::map<uint32_t, size_t> group_of;  // region -> index in p->inputs
  // Channels this program adds (a swap) are planned here and enter the image
  // only in commit_new_channels(), once nothing can refuse the program: a
  // refused swap leaves no channel, set-point or label behind.
  auto planned = [&](const std::string& key) -> const io::ChannelDesc* {
    for (const LoadedProgram::NewChannel& n : p->new_channels) {
      if (n.key == key) return &n.desc;
    }
    return nullptr;
  };
  auto label_taken = [&](const std::string& label) {
    if (image_.find_channel(label) >= 0) return true;
    for (const LoadedProgram::NewChannel& n : p->new_channels) {
      if (label == n.desc.label) return true;
    }
    return false;
  };
  for (const Binding& b : p->image.bindings()) {
    if (b.dir == BindingDir::kQuality) continue;  // after every value input, below
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
      if (label_taken(label)) return make_error("label \"" + label + "\" already names another channel");
      LoadedProgram::NewChannel n;
      n.desc = channel_desc(b, label, key, io::ChannelDir::kOutput, t, b.io_index);
      n.desc.max_age_ns = output_max_age_ns(p->image.header().period_ns);
      set_output_policy(config_.tasks[t], label, n.desc);
      n.key = key;
      p->new_channels.push_back(std::move(n));
      continue;
    }
    const io::ChannelDesc* dp = it != channel_by_key_.end() ? &image_.channel(it->second) : planned(key);
    if (dp == nullptr) {
      // A new input or set-point (hot swap).
      io::ChannelDesc d = channel_desc(b, label, key, io::ChannelDir::kInput, 0, 0);
      if (label_taken(label)) return make_error("label \"" + label + "\" already names another channel");
      const uint32_t region = b.dir == BindingDir::kSetpoint ? setpoint_region_ : unwired_region_;
      uint32_t used = 0;
      for (uint32_t c = 0; c < image_.channel_count(); ++c) used += image_.channel(c).region == region;
      for (const LoadedProgram::NewChannel& n : p->new_channels) used += n.desc.region == region;
      if (used >= image_.region(region).capacity) {
        return make_error("no room for new channel " + key + "; restart the runtime to add it");
      }
      d.region = static_cast<uint16_t>(region);
      d.index = used;
      LoadedProgram::NewChannel n;
      if (b.dir == BindingDir::kSetpoint) {
        d.dir = static_cast<uint8_t>(io::ChannelDir::kSetpoint);
        d.init = b.init;
        d.retain = 1;
        // The same checks as a boot set-point's: its kind and its limits
        // (the config's `setpoints` may name labels a later program adds).
        auto start = new_setpoint_value(label, static_cast<Kind>(b.kind), b.init);
        if (!start) return make_error(start.error());
        n.setpoint_value = *start;
      } else {
        d.dir = static_cast<uint8_t>(io::ChannelDir::kInput);
      }
      n.desc = d;
      n.key = key;
      p->new_channels.push_back(std::move(n));
      dp = &p->new_channels.back().desc;
    }
    const io::ChannelDesc& d = *dp;
    if (d.kind != static_cast<uint8_t>(b.kind)) {
      return make_error("channel " + key + " is " + (d.kind ? "digital" : "analog") +
                        " in the running image");
    }
    if (b.dir == BindingDir::kSetpoint) {
      double v = d.index < setpoint_values_.size() ? setpoint_values_[d.index] : 0.0;
      for (const LoadedProgram::NewChannel& n : p->new_channels) {
        if (n.key == key) v = n.setpoint_value;
      }
      p->arena.io_in[b.io_index] = v;
    }
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
      ig.max_age_ns.push_back(d.max_age_ns);
    }
  }
  // `good` blocks: the quality of a channel the program also reads as a value
  // (the checks make its input an input block), so it is already in a group.
  // A channel no driver feeds keeps 0: nobody vouches for it.
  for (const Binding& b : p->image.bindings()) {
    if (b.dir != BindingDir::kQuality) continue;
    const std::string key = binding_key(b);
    auto it = channel_by_key_.find(key);
    const io::ChannelDesc* dp = it != channel_by_key_.end() ? &image_.channel(it->second) : planned(key);
    if (dp == nullptr) return make_error("internal: quality of " + key + " has no channel");
    const io::ChannelDesc& d = *dp;
    auto g = group_of.find(d.region);
    if (g == group_of.end()) continue;  // unwired
    InputGroup& ig = p->inputs[g->second];
    const auto at = std::find(ig.src.begin(), ig.src.end(), d.index);
    if (at == ig.src.end()) return make_error("internal: quality of " + key + " without its value");
    ig.quality_pos.push_back(static_cast<uint32_t>(at - ig.src.begin()));
    ig.quality_dst.push_back(b.io_index);
  }
  // What `good` loads is a status, known even when the value is not: good itself.
  for (const Binding& b : p->image.bindings()) {
    if (b.dir == BindingDir::kQuality) p->lane.in[b.io_index] = static_cast<uint8_t>(Lane::kGood);
  }
  for (InputGroup& ig : p->inputs) ig.size_buffers();
  const uint32_t n_out = p->image.header().n_io_out;
  p->output_slots.resize(n_out);
  p->safe_values.assign(n_out, 0.0);
  for (uint32_t k = 0; k < n_out; ++k) p->output_slots[k] = k;  // the layout is kept (see swap)
  p->outputs_in_place = true;
  auto safe_value_of = [&](const std::string& label) {
    for (const config::SafeOutput& so : safe_outputs_[t]) {
      if (so.label == label) return so.value;
    }
    return 0.0;
  };
  p->output_quality.assign(out_region.capacity, static_cast<uint8_t>(Quality::kBad));
  for (const Binding& b : p->image.bindings()) {
    if (b.dir != BindingDir::kOutput) continue;
    p->safe_values[b.io_index] = safe_value_of(p->image.str(b.label));
    p->output_quality[b.io_index] = static_cast<uint8_t>(Quality::kGood);
  }
  p->region_quality = p->output_quality;
  if (running != nullptr) {
    // An output the running program writes and this one does not would keep
    // its last value in the image, looking current, and drivers would go on
    // sending it: refused, unless the operator asked for exactly that drop.
    std::vector<std::string> unasked;
    std::vector<bool> used(drop_outputs.size(), false);
    std::set<std::string> written;  // the new program's output keys
    for (const Binding& nb : p->image.bindings()) {
      if (nb.dir == BindingDir::kOutput) written.insert(binding_key(nb));
    }
    for (const Binding& b : running->image.bindings()) {
      if (b.dir != BindingDir::kOutput) continue;
      const std::string key = binding_key(b);
      if (written.count(key)) continue;
      const std::string label = running->image.str(b.label);
      const auto asked = std::find(drop_outputs.begin(), drop_outputs.end(), label);
      if (asked == drop_outputs.end()) {
        unasked.push_back(label + " (" + key + ")");
        continue;
      }
      used[static_cast<size_t>(asked - drop_outputs.begin())] = true;
      p->dropped.push_back({b.io_index, safe_value_of(label), label});
    }
    // Outputs dropped before stay dropped until a program writes them again.
    for (const LoadedProgram::Dropped& d : running->dropped) {
      if (p->output_quality[d.index] == static_cast<uint8_t>(Quality::kGood)) continue;
      p->dropped.push_back(d);
    }
    if (!unasked.empty()) {
      std::string names, labels;
      for (size_t i = 0; i < unasked.size(); ++i) {
        names += (i ? ", " : "") + unasked[i];
        labels += " --drop-output " + unasked[i].substr(0, unasked[i].find(' '));
      }
      return make_error("the new program no longer writes output" + std::string(unasked.size() > 1 ? "s " : " ") +
                        names + ". Its last value would stay in the image and keep being sent. To drop it "
                        "on purpose (it goes to its safe value with bad quality, and drivers stop sending "
                        "it), swap again with" + labels);
    }
    for (size_t i = 0; i < drop_outputs.size(); ++i) {
      if (!used[i]) {
        return make_error("--drop-output " + drop_outputs[i] + ": the running program of task " +
                          image_.task_info(t).name + " has no output labelled \"" + drop_outputs[i] +
                          "\" that the new program leaves out");
      }
    }
    p->migration = plan_migration(running->image, p->image);
  } else if (!drop_outputs.empty()) {
    return make_error("--drop-output applies to a swap only");
  }
  return p;
}

Result<double> Runtime::new_setpoint_value(const std::string& label, Kind kind, double init) const {
  const auto lim = setpoint_limits_.find(label);
  auto outside = [&](double v) {
    return lim != setpoint_limits_.end() &&
           ((lim->second.min && v < *lim->second.min) || (lim->second.max && v > *lim->second.max));
  };
  auto unfit = [&](double v) { return !std::isfinite(v) || (kind == Kind::kDigital && v != 0 && v != 1); };
  if (unfit(init)) {
    return make_error("set-point \"" + label + "\" is digital: its init value must be 0 or 1, not " + format_number(init));
  }
  if (outside(init)) {
    return make_error("set-point \"" + label + "\" starts at " + format_number(init) +
                      " (its init value in the program), outside its `setpoints` limits " +
                      limits_text(lim->second.min, lim->second.max));
  }
  // A value retained from an earlier run of a program with this label, if it still fits.
  if (retain_.has(label)) {
    const double kept = retain_.get(label);
    if (!unfit(kept) && !outside(kept)) return kept;
  }
  return init;
}

void Runtime::commit_new_channels(uint32_t t, LoadedProgram& p) {
  std::vector<std::string>& out_keys = task_output_keys_[t];
  bool setpoints = false;
  for (const LoadedProgram::NewChannel& n : p.new_channels) {
    // Checked when planned (room, label, kind); the table has room for them.
    auto added = image_.add_channel(n.desc);
    if (!added) continue;
    channel_by_key_[n.key] = *added;
    if (n.desc.dir == static_cast<uint8_t>(io::ChannelDir::kOutput)) {
      if (out_keys.size() <= n.desc.index) out_keys.resize(n.desc.index + 1);
      out_keys[n.desc.index] = n.key;
    } else if (n.desc.dir == static_cast<uint8_t>(io::ChannelDir::kSetpoint)) {
      if (n.desc.index < setpoint_values_.size()) setpoint_values_[n.desc.index] = n.setpoint_value;
      setpoints = true;
    }
  }
  p.new_channels.clear();
  if (setpoints) publish_setpoints();
  // Which channels this task's program uses now (ChannelDesc::users).
  if (t < 16) {
    const uint16_t bit = static_cast<uint16_t>(1u << t);
    std::vector<bool> used(image_.channel_count(), false);
    for (const Binding& b : p.image.bindings()) {
      if (auto it = channel_by_key_.find(binding_key(b)); it != channel_by_key_.end() && it->second < used.size()) {
        used[it->second] = true;
      }
    }
    for (uint32_t c = 0; c < used.size(); ++c) {
      const uint16_t was = image_.channel_users(c);
      const uint16_t now = used[c] ? (was | bit) : (was & ~bit);
      if (now != was) image_.set_channel_users(c, now);
    }
  }
}

void Runtime::publish_setpoints() {
  const uint32_t k = image_.begin_write(setpoint_region_);
  const int64_t now = kernel_rt::monotonic_now_ns();
  for (size_t i = 0; i < setpoint_values_.size(); ++i) {
    image_.put(setpoint_region_, k, static_cast<uint32_t>(i), setpoint_values_[i], Quality::kGood, now);
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
  notices.insert(notices.end(), notices_.begin(), notices_.end());
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
  start_heartbeat();
  return notices;
}

void Runtime::start_heartbeat() {
  if (!image_.valid() || !image_.writable() || beat_thread_.joinable()) return;
  beat_stop_.store(false, std::memory_order_relaxed);
  kernel_rt::ThreadSpec spec;
  spec.name = "rtplc:beat";
  auto t = kernel_rt::start_thread(spec, [this] {
    // A tenth of a second between beats, far inside kHeartbeatTimeoutNs.
    int64_t next = kernel_rt::monotonic_now_ns();
    while (!beat_stop_.load(std::memory_order_relaxed)) {
      image_.beat();
      next += 100000000;
      kernel_rt::sleep_until_ns(next);
    }
  });
  // Without the thread the control thread's tick() still beats.
  if (t) beat_thread_ = std::move(*t);
}

void Runtime::stop_heartbeat() {
  beat_stop_.store(true, std::memory_order_relaxed);
  if (beat_thread_.joinable()) beat_thread_.join();
}

void Runtime::stop() {
  const bool was_started = started_;
  for (auto& t : tasks_) t->request_stop();
  for (auto& t : tasks_) t->join();
  if (was_started) {
    reap();  // a swap the task took is the active program now
    // The threads are joined: their arenas are ours now. One last snapshot of
    // each, so the file holds the state at the stop, not up to retain_every before.
    const int64_t now = kernel_rt::monotonic_now_ns();
    for (auto& t : tasks_) t->last_run().snapshot.take(t->last_run().arena, now);
    if (std::string err; !persist_state(&err)) stop_state_error_ = err;
  }
  // Tasks have set their outputs safe: each driver's last cycle sends those.
  for (auto& d : drivers_) d->request_stop();
  for (auto& d : drivers_) d->join();
  // The drivers are joined: no more network writes; save the last of them.
  if (std::string err; !flush_setpoints(&err) && stop_state_error_.empty()) stop_state_error_ = err;
  stop_heartbeat();
  if (image_.valid() && image_.writable()) image_.header().state.store(2, std::memory_order_release);
  started_ = false;
}

void Runtime::tick(const std::function<void(bool, const std::string&)>& log) {
  if (image_.valid() && image_.writable() && !beat_thread_.joinable()) image_.beat();  // before start
  if (started_) {
    const int64_t now = kernel_rt::monotonic_now_ns();
    if (now - last_persist_ns_ >= retain_every_ns_) {
      last_persist_ns_ = now;
      std::string err;
      if (!persist_state(&err)) {
        // Said once per distinct problem, not every second (a full disk stays full).
        if (err != persist_error_said_) log(true, err);
        persist_error_said_ = err;
      } else if (!persist_error_said_.empty()) {
        log(false, "retained block state is written again to " + state_path_);
        persist_error_said_.clear();
      }
    }
  }
  if (std::string err; !flush_setpoints(&err)) {
    if (err != flush_error_said_) log(true, err);
    flush_error_said_ = err;
  } else {
    flush_error_said_.clear();
  }
  expire_traces(log);
  report_block_errors(log);
  io::LinkEvent e;
  while (events_.pop(e)) {
    log(e.level == io::LinkEvent::Level::kError || e.level == io::LinkEvent::Level::kWarning,
        std::string("driver ") + e.driver + ": " + e.text);
  }
  if (const uint64_t dropped = events_.dropped(); dropped != events_dropped_said_) {
    log(true, std::to_string(dropped - events_dropped_said_) + " driver events were not logged (queue full)");
    events_dropped_said_ = dropped;
  }
}

void Runtime::report_block_errors(const std::function<void(bool, const std::string&)>& log) {
  last_block_error_.resize(tasks_.size());
  for (auto& t : tasks_) {
    BlockErrorReport r;
    while (t->pop_block_error(r)) {
      const LoadedProgram& now = t->active();
      const bool same = now.image.header().source_hash == r.source_hash;
      if (r.runaway_loop) {
        const std::string where = (same ? now.file : std::string("an earlier program")) + ":" +
                                  std::to_string(r.line) + ":" + std::to_string(r.col);
        log(true, "RUNAWAY LOOP: task " + t->params().name + " STOPPED: the loop at " + where +
                      " took more than its loop_budget of " + std::to_string(r.budget) +
                      " iterations in one cycle; the cycle was cut short and its outputs are at their safe "
                      "values. Swap in fixed code (rtplc swap " + t->params().name +
                      " FILE) to restart it, or raise loop_budget in the task's config.");
        last_block_error_[t->index()] = where + ", " + format_utc(kernel_rt::realtime_now_ns()) +
                                        ": runaway loop, task stopped";
        continue;
      }
      const BlockSpec* spec = find_block(r.block);
      const std::string why = spec != nullptr && spec->errors[0] != '\0' ? spec->errors : "see docs/blocks.md";
      const std::string where = std::string(r.name) + " (" + r.block + ") at " +
                                (same ? now.file : std::string("an earlier program")) + ":" + std::to_string(r.line) +
                                ":" + std::to_string(r.col);
      const std::string text = "task " + t->params().name + ": block " + where + ": " + std::to_string(r.new_errors) +
                               " error" + (r.new_errors == 1 ? "" : "s") + " (" + std::to_string(r.count) +
                               " in all; " + why + ")";
      log(true, text);
      last_block_error_[t->index()] = where + ", " + format_utc(kernel_rt::realtime_now_ns()) + ": " + why;
    }
  }
}

void Runtime::reap() {
  for (auto& t : tasks_) {
    if (auto old = t->collect()) graveyard_.push_back(std::move(old));
  }
  graveyard_.clear();
}


}  // namespace rtplc::sched
