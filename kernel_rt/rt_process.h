// One call that readies the whole process for real time before the first task starts
// (spec: runtime.md, "Tasks and the scheduler": mlockall, prefault, mallopt, hold
// /dev/cpu_dma_latency at 0; without privileges or on a non-RT kernel run anyway and say so
// once).
//
// The scheduler calls prepare_process_for_rt() once from its main thread, logs every notice
// it returns (each is one complete sentence for a person), keeps the result alive for as long
// as tasks run, and then starts its threads with start_thread().
#pragma once

#include <string>
#include <vector>

#include "kernel_rt/dma_latency.h"
#include "kernel_rt/memory.h"

namespace rtplc::kernel_rt {

struct RtProcess {
  bool rt_kernel = false;                // PREEMPT_RT detected
  bool memory_locked = false;            // mlockall succeeded
  CpuDmaLatencyRequest cpu_dma_latency;  // holds 0 us while alive, when active()
  // What is not as it should be on an RT box, once each: not PREEMPT_RT, memory not locked,
  // idle states not limited. Empty on a tuned box run with the right privileges.
  std::vector<std::string> notices;
};

RtProcess prepare_process_for_rt(const MemoryLockOptions& memory = {});

}  // namespace rtplc::kernel_rt
