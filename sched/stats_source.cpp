// Task statistics views from a process image (see stats_source.h).
#include "sched/stats_source.h"

#include <time.h>

#include <cstring>
#include <string>

#include "sched/jitter.h"

namespace rtplc::sched {

std::vector<TaskStatsView> read_task_stats(const io::ProcessImage& image) {
  std::vector<TaskStatsView> views;
  const io::ImageHeader& h = image.header();
  if (h.task_stats_size != sizeof(CycleStats)) return views;  // another rtplc build's layout
  for (uint32_t t = 0; t < h.n_tasks; ++t) {
    const io::TaskInfo& ti = image.task_info(t);
    TaskStatsView v;
    v.name = std::string(ti.name, strnlen(ti.name, sizeof ti.name));
    v.period_ns = ti.period_ns;
    v.priority = ti.fifo ? ti.priority : 0;
    v.policy = ti.fifo ? "FIFO" : "OTHER";
    v.cpu = ti.cpu;
    v.state = io::task_state_name(static_cast<io::TaskState>(ti.state.load(std::memory_order_relaxed)));
    take_snapshots(v, *static_cast<const CycleStats*>(image.task_stats(t)));
    views.push_back(std::move(v));
  }
  return views;
}

int64_t runtime_uptime_ns(const io::ProcessImage& image) {
  timespec rt;
  clock_gettime(CLOCK_REALTIME, &rt);
  const int64_t now = int64_t{rt.tv_sec} * 1000000000 + rt.tv_nsec;
  return now - image.header().started_realtime_ns;
}

}  // namespace rtplc::sched
