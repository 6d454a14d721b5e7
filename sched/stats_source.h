// Reading every task's timing statistics out of a process image — the runtime's
// own mapping or a tool's read-only one (`rtplc stats`, `rtplc monitor`).
#pragma once

#include <vector>

#include "io/process_image.h"
#include "sched/stats_render.h"

namespace rtplc::sched {

std::vector<TaskStatsView> read_task_stats(const io::ProcessImage& image);

// Uptime of the runtime that owns the image, from its start time.
int64_t runtime_uptime_ns(const io::ProcessImage& image);

// The summary under the stats table for this box and image: uptime, RT kernel,
// kernel release, and a note when tasks could not get SCHED_FIFO.
RuntimeSummary summary_of(const io::ProcessImage& image, const std::vector<TaskStatsView>& views);

// One S7 PLC's link status as plain values, for the stats and monitor views.
struct LinkSnapshot {
  std::string name, driver, address, state;
  unsigned rtt_p50_us = 0, rtt_p99_us = 0;
  unsigned long long polls_completed = 0, polls_missed = 0, polls_offline = 0;
  unsigned long long reconnects = 0, timeouts = 0, errors = 0;
  unsigned long long writes_acked = 0, writes_failed = 0, writes_pending = 0;
};
LinkSnapshot link_snapshot(const io::LinkStatus& ls);

}  // namespace rtplc::sched
