// Live probes of this process's real-time permissions (spec: runtime.md, "Tasks and the
// scheduler", the doctor paragraph).
#include "kernel_rt/process_limits.h"

#include <sys/resource.h>
#include <unistd.h>

#include <fmt/format.h>
#include <cstdlib>
#include <ctime>

#include "kernel_rt/host_files.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::kernel_rt {
namespace {

constexpr unsigned kCapIpcLock = 14;  // from <linux/capability.h>
constexpr unsigned kCapSysNice = 23;

uint64_t as_bytes(rlim_t v) {
  return v == RLIM_INFINITY ? kUnlimited : static_cast<uint64_t>(v);
}

// The effective capability set from /proc/self/status (libcap is not worth a dependency for
// two bits).
uint64_t effective_caps() {
  const auto status = HostFiles{}.read("/proc/self/status");
  if (!status) return 0;
  const size_t pos = status->find("CapEff:");
  if (pos == std::string::npos) return 0;
  return std::strtoull(status->c_str() + pos + 7, nullptr, 16);
}

}  // namespace

ProcessFacts probe_process_facts(int fifo_priority) {
  ProcessFacts f;
  f.euid = static_cast<uint32_t>(geteuid());
  rlimit lim{};
  if (getrlimit(RLIMIT_MEMLOCK, &lim) == 0) {
    f.memlock_soft = as_bytes(lim.rlim_cur);
    f.memlock_hard = as_bytes(lim.rlim_max);
  }
  if (getrlimit(RLIMIT_RTPRIO, &lim) == 0) {
    f.rtprio_soft = as_bytes(lim.rlim_cur);
    f.rtprio_hard = as_bytes(lim.rlim_max);
  }
  const uint64_t caps = effective_caps();
  f.cap_ipc_lock = (caps >> kCapIpcLock & 1u) != 0;
  f.cap_sys_nice = (caps >> kCapSysNice & 1u) != 0;

  f.fifo_probe_priority = fifo_priority;
  ThreadSpec spec;
  spec.name = "rtplc-probe";
  spec.fifo_priority = fifo_priority;
  SchedState seen;
  auto t = start_thread(spec, [&seen] { seen = current_thread_sched(); });
  if (!t) {
    f.fifo_detail = t.error();
  } else {
    t->join();
    f.fifo_obtained = seen.policy == SchedPolicy::kFifo && seen.priority == fifo_priority;
    f.fifo_detail =
        t->outcome().fell_back
            ? fmt::format("a probe thread asking for SCHED_FIFO {} was refused and ran {}",
                          fifo_priority, policy_name(seen.policy))
            : fmt::format("a probe thread ran {} priority {}", policy_name(seen.policy),
                          seen.priority);
  }

  timespec res{};
  if (clock_getres(CLOCK_MONOTONIC, &res) == 0) {
    f.monotonic_resolution_ns = static_cast<int64_t>(res.tv_sec) * 1'000'000'000 + res.tv_nsec;
  }
  return f;
}

}  // namespace rtplc::kernel_rt
