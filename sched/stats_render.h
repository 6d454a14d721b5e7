// `rtplc stats` presentation: per-task wake latency and exec time as a table a cyclictest
// user reads at a glance, the same as JSON, and the scheduling summary (Liu-Layland bound,
// measured utilisation) (spec: runtime.md, "Jitter monitor"; "Tasks and the scheduler" for
// the bound). Returns text; printing is the caller's business. The histogram file lives in
// sched/stats_histfile.h. docs/jitter.md explains how to read all three.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sched/jitter.h"

namespace rtplc::sched {

// One task as the stats readers see it: its configuration and two snapshots.
struct TaskStatsView {
  std::string name;
  int64_t period_ns = 0;
  int priority = 0;          // the RT priority obtained; 0 under SCHED_OTHER
  std::string policy;        // "FIFO" or "OTHER"
  int cpu = -1;              // the CPU the thread is pinned to; -1 = any
  std::string state;         // "running", "stopped (watchdog)", ...
  StatsSnapshot wake;        // wake latency = wake - release
  StatsSnapshot exec;        // execution time = end - wake
};

// Fills view.wake and view.exec from a task's statistics (the writer may be running).
void take_snapshots(TaskStatsView& view, const CycleStats& stats) noexcept;

// What the table and the JSON say about the runtime as a whole.
struct RuntimeSummary {
  int64_t uptime_ns = 0;
  bool rt_kernel = false;       // PREEMPT_RT detected
  std::string kernel;           // kernel release (uname -r); empty = not shown
  size_t tasks = 0;
  double liu_layland_bound = 0;   // n(2^(1/n) - 1) for n tasks
  double utilisation = 0;         // sum of avg exec / period
  double utilisation_worst = 0;   // sum of max exec / period: the longest runs seen
  std::string note;             // one remark printed under the table, e.g. a SCHED_OTHER fallback
};

// n(2^(1/n) - 1): rate-monotonic priorities meet every deadline of n independent periodic
// tasks whose utilisation is at most this (Liu & Layland, 1973). 1.0 for n = 1, falling to
// ln 2 ~ 0.693; 0 for n = 0.
double liu_layland_bound(size_t n) noexcept;
// Sum over tasks of avg exec / period (tasks without a period or without cycles add 0).
double utilisation(const std::vector<TaskStatsView>& views) noexcept;
// The same with the longest exec time seen instead of the average.
double worst_case_utilisation(const std::vector<TaskStatsView>& views) noexcept;

// Fills the computed fields of a summary for `views`.
RuntimeSummary summarise(const std::vector<TaskStatsView>& views, int64_t uptime_ns, bool rt_kernel,
                         std::string kernel = {}, std::string note = {});

// The table. Lines starting "T:" follow cyclictest's summary line (latencies in whole
// microseconds, rounded down as cyclictest does) and add P99, P99.9 and overruns; lines
// starting "E:" give exec times; every other line starts with '#', so `grep '^T:'` yields
// exactly the cyclictest-like lines. At most ~120 columns for names up to 12 characters.
std::string render_table(const std::vector<TaskStatsView>& views, const RuntimeSummary& summary);

// The same content as JSON with stable keys (documented in docs/jitter.md); all times in
// nanoseconds, exact.
std::string render_json(const std::vector<TaskStatsView>& views, const RuntimeSummary& summary);

}  // namespace rtplc::sched
