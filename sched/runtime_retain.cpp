// Retained block state in the runtime (spec runtime.md, "Retain";
// docs/runtime.md, "Retained block state"): the warm start that restores it before the tasks run,
// and the control thread's writes of the state file (see state_file.h and state_snapshot.h for the
// file and the task -> control hand-over).
#include <ctime>

#include "sched/runtime.h"
#include "kernel_rt/clock.h"

namespace rtplc::sched {
namespace {

std::string utc_text(int64_t unix_ms) {
  const time_t s = static_cast<time_t>(unix_ms / 1000);
  tm t{};
  gmtime_r(&s, &t);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &t);
  return buf;
}

int64_t unix_ms_now() {
  return kernel_rt::realtime_now_ns() / 1000000;
}

std::string names_of(const std::vector<std::string>& v, size_t max = 8) {
  std::string s;
  for (size_t i = 0; i < v.size() && i < max; ++i) s += (i ? ", " : "") + v[i];
  if (v.size() > max) s += ", ... (" + std::to_string(v.size() - max) + " more)";
  return s;
}

// "1 block", "3 blocks".
std::string blocks_text(size_t n, const char* what = "blocks") {
  std::string w = what;
  if (n == 1) w.pop_back();
  return std::to_string(n) + " " + w;
}

}  // namespace

void Runtime::restore_state(const config::RuntimeConfig& cfg, DiagnosticList& cdiag) {
  const size_t n = tasks_.size();
  saved_tasks_.assign(n, SavedTask{});
  persisted_taken_.assign(n, 0);
  persisted_program_.assign(n, nullptr);
  persisted_layout_.assign(n, nullptr);
  persisted_data_.assign(n, {});
  persisted_cycle_.assign(n, 0);
  for (size_t t = 0; t < n; ++t) saved_tasks_[t].name = tasks_[t]->params().name;
  if (options_.cold) {
    restore_lines_.push_back(
        "cold start (--cold): every block starts from its initial state; " + state_path_ +
        " is replaced at the first write (set-points keep their retained values)");
    return;
  }
  auto loaded = load_state_file(state_path_);
  if (!loaded) {
    cdiag.warning(SourcePos{},
                  "retained block state ignored, every block starts from its initial state: " +
                      loaded.error());
    return;
  }
  if (!*loaded) {
    restore_lines_.push_back("no retained block state yet (" + state_path_ +
                             "): every block starts from its initial state");
    return;
  }
  const SavedState& st = **loaded;
  if (st.runtime != state_name_) {
    cdiag.warning(SourcePos{}, "retained block state ignored: " + state_path_ +
                                   " belongs to runtime '" + st.runtime + "', not '" + state_name_ +
                                   "'");
    return;
  }
  const std::string when = utc_text(st.saved_unix_ms);
  for (size_t t = 0; t < n; ++t) {
    const std::string& task = tasks_[t]->params().name;
    LoadedProgram& p = tasks_[t]->last_run();  // not started yet: ours
    if (p.snapshot.blocks().empty()) continue;
    const SavedTask* saved = st.find(task);
    if (saved == nullptr) {
      restore_lines_.push_back("task " + task + ": no retained state in " + state_path_ +
                               "; starts from its initial state");
      continue;
    }
    saved_tasks_[t] = *saved;  // until its first snapshot, a write keeps what the file had
    RestoreOutcome o = restore_task(*saved, p.snapshot.blocks(), p.arena);
    if (!o.restored.empty()) {
      restore_lines_.push_back("task " + task + ": restored " + blocks_text(o.restored.size()) +
                               " (" + names_of(o.restored) + ") from the state saved " + when +
                               " at its cycle " + std::to_string(saved->cycle));
    }
    if (!o.refused.empty()) {
      cdiag.warning(cfg.tasks[t].retain_pos,
                    "task " + task + ": retained state not restored into blocks that changed: " +
                        names_of(o.refused) + "; they start from their initial state");
    }
    if (!o.missing.empty()) {
      restore_lines_.push_back(
          "task " + task + ": " + blocks_text(o.missing.size(), "retained blocks") +
          " had no saved state and start from their initial state (" + names_of(o.missing) + ")");
    }
    if (!o.dropped.empty()) {
      restore_lines_.push_back(
          "task " + task + ": " + blocks_text(o.dropped.size(), "saved blocks") +
          " no longer retained by its program, dropped (" + names_of(o.dropped) + ")");
    }
  }
}

bool Runtime::persist_state(std::string* error) {
  bool any_retained = false;
  bool changed = false;
  std::vector<double> data;
  for (size_t t = 0; t < tasks_.size() && t < saved_tasks_.size(); ++t) {
    // active() is the program as far as this thread knows; one the task has
    // just replaced is still alive (only this thread frees it) and holds the
    // task's last snapshot before the swap.
    const LoadedProgram& p = tasks_[t]->active();
    if (p.snapshot.blocks().empty()) {
      if (!saved_tasks_[t].blocks.empty() || persisted_layout_[t]) changed = true;
      saved_tasks_[t].blocks.clear();
      persisted_layout_[t].reset();
      persisted_data_[t].clear();
      continue;
    }
    any_retained = true;
    const uint64_t taken = p.snapshot.taken();
    if (&p == persisted_program_[t] && taken == persisted_taken_[t]) continue;
    uint64_t cycle = 0;
    int64_t at = 0;
    if (!p.snapshot.read(data, cycle, at))
      continue;  // none yet, or the writer lapped us: next time
    persisted_taken_[t] = taken;
    persisted_program_[t] = &p;
    // A plant at rest (every state as it was) costs no write: flash wears.
    auto layout = p.snapshot.layout();
    const bool same = persisted_layout_[t]
                          ? persisted_layout_[t] == layout && persisted_data_[t] == data
                          : saved_task(tasks_[t]->params().name, *layout, data, cycle).blocks == saved_tasks_[t].blocks;
    persisted_layout_[t] = std::move(layout);
    persisted_data_[t].swap(data);
    persisted_cycle_[t] = cycle;
    // From now on the snapshot is what the file holds for this task.
    std::vector<SavedBlock>().swap(saved_tasks_[t].blocks);
    if (!same) changed = true;
  }
  if (!any_retained || !changed) return true;
  std::vector<TaskStateRef> refs;
  refs.reserve(tasks_.size());
  for (size_t t = 0; t < tasks_.size() && t < saved_tasks_.size(); ++t) {
    if (persisted_layout_[t]) {
      refs.push_back({saved_tasks_[t].name, persisted_cycle_[t], nullptr, persisted_layout_[t].get(),
                      &persisted_data_[t]});
    } else {
      refs.push_back({saved_tasks_[t].name, saved_tasks_[t].cycle, &saved_tasks_[t], nullptr, nullptr});
    }
  }
  if (auto r = save_state_file(state_path_, state_name_, unix_ms_now(), refs); !r) {
    if (error) *error = "cannot write the retained block state: " + r.error();
    return false;
  }
  return true;
}

}  // namespace rtplc::sched
