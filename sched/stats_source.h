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

}  // namespace rtplc::sched
