// The operator's verbs on a running runtime (see runtime.h): set-points,
// swap and rollback, status and the start-up summary. Control thread only.
#include "sched/runtime.h"

#include "blocks/string_ops.h"

#include <fmt/format.h>
#include "sched/image_plan.h"

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <optional>
#include <thread>

#include "common/text.h"
#include "kernel_rt/clock.h"
#include "lang/compiler.h"
#include "lang/sfc/builder.h"
#include "sched/stats_source.h"

namespace rtplc::sched {
namespace {

std::string fmt_ms(int64_t ns) { return format_number(static_cast<double>(ns) / 1e6) + " ms"; }

// The steps of an SFC program that were active when a swap took effect, split
// into those the new program kept by name and those it no longer has. An SFC
// step's flag is the block named step.<Step> (docs/sfc.md); FBD names never
// look like that. `old` has stopped running, so its arena may be read here.
void active_steps(const LoadedProgram& old, const Migration& m, std::vector<std::string>& kept,
                  std::vector<std::string>& lost, bool& is_sfc) {
  const auto blocks = old.image.blocks();
  for (size_t i = 0; i < blocks.size(); ++i) {
    const std::string name = old.image.str(blocks[i].name);
    if (name.rfind("step.", 0) != 0 || name.find('.', 5) != std::string::npos) continue;
    is_sfc = true;
    if (old.arena.values.size() <= old.image.code()[i].out ||
        old.arena.values[old.image.code()[i].out] == 0)
      continue;
    const bool carried = std::find(m.kept.begin(), m.kept.end(), name) != m.kept.end();
    (carried ? kept : lost).push_back(name.substr(5));
  }
}

// "  kept state: 2 (F10, F20)": one line of a migration report, at most 12 names.
void list_line(std::string& out, const char* what, const std::vector<std::string>& names) {
  out += std::string("  ") + what + ": " + std::to_string(names.size());
  for (size_t i = 0; i < names.size() && i < 12; ++i) out += (i ? ", " : " (") + names[i];
  if (!names.empty()) out += names.size() > 12 ? ", ...)" : ")";
  out += "\n";
}

// What a swap does to the blocks' state, the same lines for a swap done and
// for one only checked (--check).
void migration_lines(std::string& out, const Migration& m, bool is_sfc, const std::vector<std::string>& steps_kept,
                     const std::vector<std::string>& steps_lost, bool done) {
  list_line(out, "kept state", m.kept);
  list_line(out, "reset", m.reset);
  list_line(out, "new", m.added);
  list_line(out, "removed", m.removed);
  if (!is_sfc) return;
  list_line(out, "active steps kept", steps_kept);
  if (!steps_lost.empty()) {
    list_line(out, done ? "active steps the new chart does not have (now inactive)"
                        : "active steps the new chart does not have (would become inactive)",
              steps_lost);
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// Operator verbs

Result<std::string> Runtime::set_value(const std::string& label, double value, bool durable, double* was) {
  std::lock_guard setpoints(setpoint_mu_);
  const int c = image_.find_channel(label);
  if (c < 0) return make_error("no channel is labelled \"" + label + "\"");
  const io::ChannelDesc& d = image_.channel(static_cast<uint32_t>(c));
  if (d.dir != static_cast<uint8_t>(io::ChannelDir::kSetpoint)) {
    return make_error("\"" + label + "\" is " +
                      (d.dir == static_cast<uint8_t>(io::ChannelDir::kInput) ? "an input" : "an output") +
                      "; only set-points (asp, dsp) can be set");
  }
  if (d.kind == static_cast<uint8_t>(Kind::kDigital) && value != 0 && value != 1) {
    return make_error("not changed: \"" + label + "\" is a digital set-point: 0 or 1, got " + format_number(value));
  }
  const auto lim = setpoint_limits_.find(label);
  const std::optional<double> lo = lim != setpoint_limits_.end() ? lim->second.min : std::nullopt;
  const std::optional<double> hi = lim != setpoint_limits_.end() ? lim->second.max : std::nullopt;
  const char* where = lim == setpoint_limits_.end() ? "" : " (its `setpoints` limits in the config)";
  if (!std::isfinite(value)) {
    const std::string range = lo && hi ? " in " + limits_text(lo, hi) : lo || hi ? " " + limits_text(lo, hi) : "";
    return make_error("not changed: set-point \"" + label + "\" takes a finite number" + range + where + ", got " +
                      format_number(value));
  }
  if ((lo && value < *lo) || (hi && value > *hi)) {
    return make_error("not changed: " + format_number(value) + " is outside the range of set-point \"" + label +
                      "\": " + limits_text(lo, hi) + where);
  }
  const double before = setpoint_values_[d.index];
  if (was != nullptr) *was = before;
  if (d.retain && durable) {
    // On disk first: once the operator sees OK, the value survives a crash.
    // (Saving the whole store also saves what coalesced writes left unsaved.)
    RetainStore next = retain_;
    next.set(label, value);
    if (auto r = next.save(); !r) return make_error("not changed: cannot retain it: " + r.error());
    retain_.set(label, value);  // not a move-assignment: others read retain_.path() unlocked
    setpoints_unsaved_ = false;
  } else if (d.retain) {
    retain_.set(label, value);
    setpoints_unsaved_ = true;
  }
  setpoint_values_[d.index] = value;
  publish_setpoints();
  return label + " = " + format_number(value) + " (was " + format_number(before) + ")" +
         (d.retain ? (durable ? ", retained in " : ", to be retained in ") + retain_.path() : "");
}

// One save for every coalesced write since the last: a SCADA writing a
// set-point ten times a second costs one fsync per tick, not ten.
bool Runtime::flush_setpoints(std::string* error) {
  std::lock_guard setpoints(setpoint_mu_);
  if (!setpoints_unsaved_) return true;
  if (auto r = retain_.save(); !r) {
    if (error != nullptr) *error = "set-points written over the network are not retained yet: " + r.error();
    return false;  // still unsaved: the next tick tries again
  }
  setpoints_unsaved_ = false;
  return true;
}

std::string format_utc(int64_t realtime_ns) {
  const time_t secs = static_cast<time_t>(realtime_ns / 1000000000);
  tm utc{};
  gmtime_r(&secs, &utc);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buf;
}

namespace {
using kernel_rt::realtime_now_ns;

const char* dir_in_prose(uint8_t dir) {
  return dir == static_cast<uint8_t>(io::ChannelDir::kInput)    ? "input"
         : dir == static_cast<uint8_t>(io::ChannelDir::kOutput) ? "output"
                                                                 : "set-point";
}
}  // namespace

Result<std::string> Runtime::force(const std::string& label, double value, uint32_t uid) {
  const int c = image_.find_channel(label);
  if (c < 0) return make_error("not forced: no channel is labelled \"" + label + "\"");
  const io::ChannelDesc& d = image_.channel(static_cast<uint32_t>(c));
  if (d.dir == static_cast<uint8_t>(io::ChannelDir::kSetpoint)) {
    return make_error("not forced: \"" + label + "\" is a set-point; change it with `rtplc set " + label +
                      " VALUE` (forcing is for inputs and outputs)");
  }
  if (d.region == unwired_region_) {
    return make_error("not forced: no driver provides input \"" + label +
                      "\", so no task reads it; wire it to a driver first");
  }
  if (!std::isfinite(value)) return make_error("not forced: the value must be a finite number, got " + format_number(value));
  if (d.kind == static_cast<uint8_t>(Kind::kDigital) && value != 0 && value != 1) {
    return make_error("not forced: \"" + label + "\" is a digital " + dir_in_prose(d.dir) + ": 0 or 1, got " +
                      format_number(value));
  }
  // The channel's engineering range, then what every driver sending it can carry:
  // a force the plant would never see is refused here, not by a driver later.
  if (const auto r = channel_ranges_.find(label); r != channel_ranges_.end()) {
    const config::SetpointLimits& lim = r->second;
    if ((lim.min && value < *lim.min) || (lim.max && value > *lim.max)) {
      return make_error("not forced: " + format_number(value) + " is outside the range of \"" + label + "\": " +
                        limits_text(lim.min, lim.max) + " (its `ranges` in the config)");
    }
  }
  if (d.dir == static_cast<uint8_t>(io::ChannelDir::kOutput)) {
    for (const auto& drv : drivers_) {
      const std::vector<io::OutputSource>& outs = drv->consumed_outputs();
      for (uint32_t j = 0; j < outs.size(); ++j) {
        if (outs[j].region != d.region || outs[j].index != d.index) continue;
        if (Result<void> ok = drv->can_send(j, value); !ok) {
          return make_error("not forced: driver " + drv->name() + " sends \"" + label + "\" and " + ok.error());
        }
      }
    }
  }
  const io::ChannelValue before = image_.read_channel(static_cast<uint32_t>(c));
  image_.force(d.region, d.index, value);
  ForceRecord& rec = forces_[label];
  const bool again = !rec.label.empty();
  rec.label = label;
  rec.dir = dir_in_prose(d.dir);
  rec.value = value;
  rec.uid = uid;
  rec.since_realtime_ns = realtime_now_ns();
  // An output of a task the watchdog stopped stays at its safe value: say so.
  std::string note;
  const io::RegionDesc& rd = image_.region(d.region);
  const auto task_state = rd.owner < tasks_.size() ? static_cast<io::TaskState>(image_.task_info(rd.owner).state.load(
                                                          std::memory_order_relaxed))
                                                    : io::TaskState::kRunning;
  if (rd.kind == static_cast<uint8_t>(io::RegionKind::kTask) &&
      (io::stopped_by_fault(task_state) || task_state == io::TaskState::kStopped)) {
    note = "\nnote: task " + tasks_[rd.owner]->params().name +
           " is not running: its outputs stay at their safe values, the force applies once it runs again";
  }
  return label + " (" + rec.dir + ") FORCED to " + format_number(value) + " (was " + format_number(before.value) +
         (again ? ", already forced" : "") + "); " +
         (d.dir == static_cast<uint8_t>(io::ChannelDir::kInput) ? "every task reads this value"
                                                                 : "every driver sends this value") +
         " until `rtplc unforce " + label + "`" + note;
}

Result<std::string> Runtime::unforce(const std::string& label) {
  const int c = image_.find_channel(label);
  if (c < 0) return make_error("no channel is labelled \"" + label + "\"");
  const io::ChannelDesc& d = image_.channel(static_cast<uint32_t>(c));
  const io::ForcedValue f = image_.forced(d.region, d.index);
  if (!image_.unforce(d.region, d.index)) return make_error("\"" + label + "\" is not forced");
  forces_.erase(label);
  return label + " released (was forced to " + format_number(f.value) + "); its " +
         (d.dir == static_cast<uint8_t>(io::ChannelDir::kInput) ? "driver's" : "task's") + " value applies again";
}

Result<std::string> Runtime::unforce_all() {
  if (forces_.empty()) return std::string("nothing is forced");
  std::string out;
  const std::map<std::string, ForceRecord> all = forces_;
  for (const auto& [label, rec] : all) {
    auto r = unforce(label);
    out += (r ? *r : r.error()) + "\n";
  }
  return out;
}

std::vector<ForceRecord> Runtime::forces() const {
  std::vector<ForceRecord> out;
  for (const auto& [label, rec] : forces_) out.push_back(rec);
  return out;
}

Result<std::string> Runtime::install(Task& t, std::unique_ptr<LoadedProgram> next, bool keep_previous) {
  const int64_t requested = kernel_rt::monotonic_now_ns();
  const uint64_t swaps_before = image_.task_info(t.index()).swaps.load(std::memory_order_relaxed);
  const Migration summary = next->migration;
  const uint32_t n_blocks = next->image.header().n_instr;
  // A rolled-back program ran before: its last snapshot is of then, not of the
  // state it is about to take over, so no persist may read it.
  next->snapshot.forget();
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
  std::vector<std::string> steps_kept, steps_lost;
  bool is_sfc = false;
  if (old) active_steps(*old, summary, steps_kept, steps_lost, is_sfc);
  if (keep_previous && old) {
    old->arena = TaskArena();  // its state is not needed for a rollback, only its code
    previous_[t.index()] = std::move(old);
  }
  image_.task_info(t.index()).n_blocks = n_blocks;
  (void)swaps_before;
  std::string out = "task " + t.params().name + ": now running " + t.active().file + " (" +
                    std::to_string(n_blocks) + " blocks), applied at a cycle boundary " +
                    fmt_ms(applied - requested) + " after the request\n";
  migration_lines(out, summary, is_sfc, steps_kept, steps_lost, true);
  return out;
}

lang::CompileResult Runtime::compile_for(const Task& t, const std::string& source) const {
  lang::CompileOptions o;
  o.name = t.params().name;
  o.period_override = static_cast<double>(t.params().period_ns) / 1e9;  // the task keeps its grid
  o.output_layout = task_output_keys_[t.index()];
  if (t.index() < task_entries_.size()) o.entry = task_entries_[t.index()];
  if (t.index() < task_semantics_.size()) o.semantics = task_semantics_[t.index()];
  return lang::compile_source(source, o);
}

Result<std::string> Runtime::swap_check(const std::string& task, const std::string& source,
                                        const std::string& file_label,
                                        const std::vector<std::string>& drop_outputs) {
  Task* t = find_task(task);
  if (t == nullptr) return make_error(no_task_text(task));
  lang::CompileResult r = compile_for(*t, source);
  if (!r.ok()) return make_error("would not swap, the program has errors:\n" + r.diags.render(file_label, source));
  // The same plan a swap makes (channels, set-points, outputs left out, state
  // carried over), then dropped: nothing enters the image, the store or the task.
  auto next = make_program(t->index(), std::move(*r.image), source, file_label, &t->active(), drop_outputs,
                           /*compile_native_code=*/false);
  if (!next) return make_error("would not swap: " + next.error());
  const LoadedProgram& p = **next;
  std::string out = "task " + task + ": " + file_label + " compiles and verifies (" +
                    std::to_string(p.image.header().n_instr) + " blocks); a swap now would keep or reset:\n";
  // Active steps from the step-flag channels (the running arena is the task's).
  std::vector<std::string> steps_kept, steps_lost;
  const std::vector<std::string> active = active_step_names(*t);
  for (const std::string& step : active) {
    const bool carried = std::find(p.migration.kept.begin(), p.migration.kept.end(), "step." + step) !=
                         p.migration.kept.end();
    (carried ? steps_kept : steps_lost).push_back(step);
  }
  migration_lines(out, p.migration, is_chart(*t), steps_kept, steps_lost, false);
  std::vector<std::string> added, dropped;
  for (const LoadedProgram::NewChannel& n : p.new_channels) added.push_back(n.desc.label);
  for (const LoadedProgram::Dropped& d : p.dropped) dropped.push_back(d.label);
  list_line(out, "new channels", added);
  if (!dropped.empty()) list_line(out, "outputs dropped (to their safe value, bad)", dropped);
  if (r.diags.warning_count()) out += r.diags.render(file_label, source);
  return out + "nothing was changed (a check only)\n";
}

Result<std::string> Runtime::swap(const std::string& task, const std::string& source,
                                  const std::string& file_label,
                                  const std::vector<std::string>& drop_outputs) {
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  Task* t = find_task(task);
  if (t == nullptr) return make_error(no_task_text(task));
  lang::CompileResult r = compile_for(*t, source);
  if (!r.ok()) {
    return make_error("not swapped, the program has errors:\n" + r.diags.render(file_label, source));
  }
  const int64_t compiled = kernel_rt::monotonic_now_ns();
  if (t->swap_in_flight()) return make_error("not swapped: a swap of task " + task + " is already in progress");
  auto next = make_program(t->index(), std::move(*r.image), source, file_label, &t->active(), drop_outputs);
  if (!next) return make_error("not swapped: " + next.error());
  // On disk before the task takes it: once the operator sees OK, a restart
  // (or kill -9) runs this code.
  auto kept = programs_.push(task, source, "swap " + file_label);
  if (!kept) return make_error("not swapped: cannot keep the program for restarts: " + kept.error());
  {
    // Nothing refuses the swap from here on: its new channels enter the image.
    std::lock_guard setpoints(setpoint_mu_);
    commit_new_channels(t->index(), **next);
  }
  auto res = install(*t, std::move(next).value(), true);
  if (!res) {
    (void)programs_.pop(task);
    return res;
  }
  origins_[t->index()] = kept->origin;
  std::string note;
  const double period = static_cast<double>(t->params().period_ns) / 1e9;
  if (r.program.period_from_stime && std::abs(r.program.period - period) > 1e-9 * period) {
    note = "note: " + file_label + " says stime " + format_number(r.program.period) + " s, but task " + task +
           " keeps its period of " + format_number(period) +
           " s (a running task's period never changes). Restart the runtime to change the period.\n";
  }
  std::string warn = r.diags.warning_count() ? r.diags.render(file_label, source) : "";
  return "compiled and verified in " + fmt_ms(compiled - t0) + "\n" + *res + "  kept for restarts as program " +
         kept->hash + "\n" + note + warn;
}

Result<std::string> Runtime::rollback(const std::string& task, const std::vector<std::string>& drop_outputs) {
  Task* t = find_task(task);
  if (t == nullptr) return make_error(no_task_text(task));
  // The version before the current one, from the store (it survives restarts
  // and keeps several); a runtime whose store could not be written keeps the
  // one it replaced in memory.
  const std::vector<ProgramVersion>& h = programs_.history(task);
  std::string source, label;
  if (h.size() >= 2) {
    const ProgramVersion& prev = h[h.size() - 2];
    auto text = programs_.source(prev.hash);
    if (!text) return make_error("not rolled back: " + text.error());
    source = *text;
    label = prev.origin.substr(prev.origin.find(' ') + 1);
  } else if (const std::unique_ptr<LoadedProgram>& prev = previous_[t->index()]; prev && h.empty()) {
    source = prev->source;
    label = prev->file;
  } else {
    return make_error("task " + task + " has no previous program to roll back to");
  }
  lang::CompileResult r = compile_for(*t, source);
  if (!r.ok()) return make_error("not rolled back, the previous program no longer compiles:\n" + r.diags.render(label, source));
  if (t->swap_in_flight()) return make_error("not rolled back: a swap of task " + task + " is already in progress");
  auto next = make_program(t->index(), std::move(*r.image), source, label, &t->active(), drop_outputs);
  if (!next) return make_error("not rolled back: " + next.error());
  {
    std::lock_guard setpoints(setpoint_mu_);
    commit_new_channels(t->index(), **next);
  }
  auto res = install(*t, std::move(next).value(), false);
  if (!res) return res;
  if (h.size() >= 2) {
    if (auto p = programs_.pop(task); !p) *res += "warning: the rollback is not kept for restarts: " + p.error() + "\n";
    if (auto cur = programs_.current(task)) origins_[t->index()] = cur->origin;
  }
  return res;
}

// An SFC task's step flags are output channels on the step-flag processor
// labelled <chart>.<step> (docs/sfc.md): the steps whose flag is set now.
bool Runtime::is_chart(const Task& t) {
  const auto b = t.active().image.bindings();
  return std::any_of(b.begin(), b.end(), [](const Binding& x) {
    return x.dir == BindingDir::kOutput && x.p == lang::sfc::kStepFlagProcessor;
  });
}

std::vector<std::string> Runtime::active_step_names(const Task& t) const {
  std::vector<std::string> out;
  const TaskImage& img = t.active().image;
  for (const Binding& b : img.bindings()) {
    if (b.dir != BindingDir::kOutput || b.p != lang::sfc::kStepFlagProcessor) continue;
    const std::string label = img.str(b.label);
    const int c = image_.find_channel(label);
    if (c >= 0 && image_.read_channel(static_cast<uint32_t>(c)).value != 0) out.push_back(label.substr(label.find('.') + 1));
  }
  return out;
}

Result<Runtime::WatchInfo> Runtime::watch(const std::string& task) {
  Task* t = find_task(task);
  if (t == nullptr) return make_error(no_task_text(task));
  const int64_t now = kernel_rt::monotonic_now_ns();
  t->watch_until(now + kWatchLeaseNs);
  // active() is alive on this thread (only it frees programs); its watch
  // snapshot is read by the protocol of state_snapshot.h, never its arena.
  const LoadedProgram& p = t->active();
  WatchInfo w;
  w.program = ProgramStore::hash_of(p.source);
  std::vector<double> data;
  int64_t taken = 0;
  if (!p.watch.read(data, w.cycle, taken)) return w;
  w.pending = false;
  w.age_s = static_cast<double>(now - taken) * 1e-9;
  const auto& blocks = p.watch.blocks();
  size_t at = 0;  // each block's [output (n_value slots), status]
  for (size_t i = 0; i < blocks.size() && at + blocks[i].n_value < data.size(); ++i) {
    const uint32_t n = blocks[i].n_value;
    const auto lane = static_cast<uint8_t>(std::clamp(data[at + n], 0.0, 2.0));
    WatchedValue v{blocks[i].name, std::string(blocks[i].kind), data[at], quality_of(static_cast<Lane>(lane)), {}};
    if (n > 1) v.text = string_value(data.data() + at, n, 0, blocks[i].wide);
    w.blocks.push_back(std::move(v));
    at += n + 1;
  }
  return w;
}

Result<Runtime::ProgramInfo> Runtime::program_info(const std::string& task, const std::string& hash) {
  Task* t = find_task(task);
  if (t == nullptr) return make_error(no_task_text(task));
  ProgramInfo info;
  info.file = t->active().file;
  info.origin = origins_[t->index()];
  info.hash = ProgramStore::hash_of(t->active().source);
  info.history = programs_.history(task);
  if (hash.empty() || hash == info.hash) {
    info.source = t->active().source;
    return info;
  }
  const bool known = std::any_of(info.history.begin(), info.history.end(),
                                 [&](const ProgramVersion& v) { return v.hash == hash; });
  if (!known) return make_error("task " + task + " has no stored program " + hash);
  auto text = programs_.source(hash);
  if (!text) return make_error(text.error());
  info.source = std::move(*text);
  return info;
}

std::string Runtime::status() const {
  std::string s = "runtime " + name_ + " (pid " + std::to_string(getpid()) + "), " +
                  std::to_string(tasks_.size()) + " tasks, " + std::to_string(drivers_.size()) +
                  " drivers, " + std::to_string(image_.channel_count()) + " channels\n";
  s += "shared memory " + image_.object_name() + ", control socket " + socket_path_ +
       ", retain file " + retain_.path() + "\n";
  for (uint32_t l = 0; l < image_.link_count(); ++l) {
    const LinkSnapshot ls = link_snapshot(image_.link(l));
    s += "  " + link_status_line(ls) + "\n" + render_link_classes(ls);  // classes: planned links only
  }
  if (forces_.empty()) {
    s += "  forced: none\n";
  } else {
    s += "  FORCED: " + std::to_string(forces_.size()) + " channel" + (forces_.size() == 1 ? "" : "s") +
         " (rtplc unforce LABEL | --all)\n";
    for (const auto& [label, rec] : forces_) {
      s += "    FORCED " + rec.dir + " " + label + " = " + format_number(rec.value) + " since " +
           format_utc(rec.since_realtime_ns) + " by uid " + std::to_string(rec.uid) + "\n";
    }
  }
  for (const auto& t : tasks_) {
    const io::TaskInfo& ti = image_.task_info(t->index());
    const auto* st = static_cast<const CycleStats*>(image_.task_stats(t->index()));
    s += "  task " + t->params().name + ": " +
         io::task_state_name(static_cast<io::TaskState>(ti.state.load())) + ", " +
         t->active().file + " (program " + ProgramStore::hash_of(t->active().source) + ", " +
         origins_[t->index()] + (t->active().native ? ", native code" : "") + "), period " + fmt_ms(t->params().period_ns) + ", " +
         (ti.fifo ? "FIFO " + std::to_string(ti.priority) : std::string("OTHER")) + ", " +
         std::to_string(st->cycles()) + " cycles, " + std::to_string(st->overruns()) +
         " overruns, " + std::to_string(ti.swaps.load()) + " swaps, " +
         std::to_string(ti.block_errors.load()) + " block errors";
    if (t->index() < last_block_error_.size() && !last_block_error_[t->index()].empty()) {
      s += "\n    last block error: " + last_block_error_[t->index()];
    }
    if (is_chart(*t)) {
      std::string steps;
      for (const std::string& step : active_step_names(*t)) steps += (steps.empty() ? "" : " ") + step;
      s += ", active steps: " + (steps.empty() ? std::string("none") : steps);
    }
    if (t->index() < traces_.size() && !traces_[t->index()].token.empty() && !traces_[t->index()].clearing) {
      s += ", traced (" + traces_[t->index()].labels + ")";
    }
    s += "\n";
  }
  return s;
}

namespace {
// A JSON string: quotes, backslashes and control characters escaped.
std::string json_text(std::string_view t) {
  std::string out = "\"";
  for (const char c : t) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      out += fmt::format("\\u{:04x}", static_cast<unsigned>(static_cast<unsigned char>(c)));
    } else {
      out += c;
    }
  }
  return out + "\"";
}
}  // namespace

// An SFC task's active steps for status --json: `, "active_steps": [...]`.
std::string Runtime::steps_json(const Task& t) const {
  if (!is_chart(t)) return "";
  std::string out = ", \"active_steps\": [";
  bool first = true;
  for (const std::string& step : active_step_names(t)) {
    out += (first ? "" : ", ") + json_text(step);
    first = false;
  }
  return out + "]";
}

std::string Runtime::status_json() const {
  std::string s = fmt::format("{{\n  \"runtime\": {}, \"pid\": {}, \"shared_memory\": {}, \"control_socket\": {}, "
                              "\"retain_file\": {},\n  \"forced\": [",
                              json_text(name_), getpid(), json_text(image_.object_name()), json_text(socket_path_),
                              json_text(retain_.path()));
  bool first = true;
  for (const auto& [label, rec] : forces_) {
    s += fmt::format("{}\n    {{\"label\": {}, \"dir\": {}, \"value\": {}, \"since\": {}, \"uid\": {}}}",
                     first ? "" : ",", json_text(label), json_text(rec.dir), rec.value,
                     json_text(format_utc(rec.since_realtime_ns)), rec.uid);
    first = false;
  }
  s += first ? "],\n  \"tasks\": [" : "\n  ],\n  \"tasks\": [";
  first = true;
  for (const auto& t : tasks_) {
    const io::TaskInfo& ti = image_.task_info(t->index());
    const auto* st = static_cast<const CycleStats*>(image_.task_stats(t->index()));
    const std::string last_error =
        t->index() < last_block_error_.size() ? last_block_error_[t->index()] : std::string();
    s += fmt::format(
        "{}\n    {{\"name\": {}, \"state\": \"{}\", \"file\": {}, \"program\": \"{}\", \"origin\": {}, "
        "\"period_ns\": {}, \"policy\": \"{}\", \"priority\": {}, \"cycles\": {}, \"overruns\": {}, "
        "\"swaps\": {}, \"block_errors\": {}, \"last_block_error\": {}, \"native\": {}{}}}",
        first ? "" : ",", json_text(t->params().name),
        io::task_state_name(static_cast<io::TaskState>(ti.state.load())), json_text(t->active().file),
        ProgramStore::hash_of(t->active().source), json_text(origins_[t->index()]), t->params().period_ns,
        ti.fifo ? "FIFO" : "OTHER", ti.fifo ? ti.priority : 0, st->cycles(), st->overruns(), ti.swaps.load(),
        ti.block_errors.load(), last_error.empty() ? "null" : json_text(last_error),
        t->active().native ? "true" : "false", steps_json(*t));
    first = false;
  }
  s += first ? "]\n}\n" : "\n  ]\n}\n";
  return with_links_json(image_, s);
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
  for (const auto& d : drivers_) out.push_back("driver " + d->name() + " (" + d->kind() + ")");
  out.insert(out.end(), restore_lines_.begin(), restore_lines_.end());
  const double bound = liu_layland_bound(tasks_.size());
  out.push_back("Liu-Layland bound for " + std::to_string(tasks_.size()) + " tasks: " +
                format_number(bound * 100) + "% utilisation");
  return out;
}

std::vector<TaskStatsView> Runtime::stats_views() const { return read_task_stats(image_); }

}  // namespace rtplc::sched
