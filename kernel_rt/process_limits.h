// What this process may do in real time: its memlock and rtprio limits, its capabilities,
// whether SCHED_FIFO is actually granted, and the monotonic clock's resolution
// (spec: runtime.md, "Tasks and the scheduler", the doctor paragraph).
//
// These are live probes of the calling process, kept apart from the file-based checks so
// `doctor` tests can inject any combination (not root, low memlock, FIFO refused).
#pragma once

#include <cstdint>
#include <string>

namespace rtplc::kernel_rt {

inline constexpr uint64_t kUnlimited = UINT64_MAX;

struct ProcessFacts {
  uint32_t euid = 0;
  uint64_t memlock_soft = 0;  // bytes, kUnlimited for RLIM_INFINITY
  uint64_t memlock_hard = 0;
  uint64_t rtprio_soft = 0;  // highest RT priority allowed without CAP_SYS_NICE
  uint64_t rtprio_hard = 0;
  bool cap_sys_nice = false;  // may set any RT priority regardless of RLIMIT_RTPRIO
  bool cap_ipc_lock = false;  // may lock any amount of memory regardless of RLIMIT_MEMLOCK
  int fifo_probe_priority = 0;
  bool fifo_obtained = false;           // a thread really ran under SCHED_FIFO at that priority
  std::string fifo_detail;              // what the probe saw
  int64_t monotonic_resolution_ns = 0;  // clock_getres: 1 with high-resolution timers
};

// The RT priority the probe asks for: the top of the runtime's default band, which sits just
// below the kernel's threaded interrupt handlers at 50 (spec: runtime.md, rate-monotonic band).
inline constexpr int kFifoProbePriority = 49;

// Probes the calling process. Starts (and joins) one short thread to try SCHED_FIFO.
ProcessFacts probe_process_facts(int fifo_priority = kFifoProbePriority);

}  // namespace rtplc::kernel_rt
