// Task statistics views from a process image (see stats_source.h).
#include "sched/stats_source.h"

#include <sys/utsname.h>
#include <time.h>

#include <cstring>
#include <string>

#include "io/s7/engine.h"
#include "kernel_rt/rt_kernel.h"
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

RuntimeSummary summary_of(const io::ProcessImage& image, const std::vector<TaskStatsView>& views) {
  std::string note;
  for (const TaskStatsView& v : views) {
    if (v.policy != "FIFO") note = "tasks run SCHED_OTHER (no SCHED_FIFO privilege): latencies are not real-time";
  }
  utsname u{};
  uname(&u);
  return summarise(views, runtime_uptime_ns(image), kernel_rt::running_on_rt_kernel(), u.release, note);
}

LinkSnapshot link_snapshot(const io::LinkStatus& ls) {
  const auto r = std::memory_order_relaxed;
  LinkSnapshot s;
  s.name = std::string(ls.name, strnlen(ls.name, sizeof ls.name));
  s.driver = std::string(ls.driver, strnlen(ls.driver, sizeof ls.driver));
  s.address = std::string(ls.address, strnlen(ls.address, sizeof ls.address));
  s.state = std::string(s7::plc_state_name(static_cast<s7::PlcState>(ls.state.load(r))));
  s.rtt_p50_us = ls.rtt_p50_us.load(r);
  s.rtt_p99_us = ls.rtt_p99_us.load(r);
  s.polls_completed = ls.polls_completed.load(r);
  s.polls_missed = ls.polls_missed.load(r);
  s.polls_offline = ls.polls_offline.load(r);
  s.reconnects = ls.reconnects.load(r);
  s.timeouts = ls.timeouts.load(r);
  s.errors = ls.errors.load(r);
  s.writes_acked = ls.writes_acked.load(r);
  s.writes_failed = ls.writes_failed.load(r);
  s.writes_pending = ls.writes_pending.load(r);
  return s;
}

}  // namespace rtplc::sched
