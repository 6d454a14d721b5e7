// Process-wide preparation for real time (spec: runtime.md, "Tasks and the scheduler").
#include "kernel_rt/rt_process.h"

#include "kernel_rt/rt_kernel.h"

namespace rtplc::kernel_rt {

RtProcess prepare_process_for_rt(const MemoryLockOptions& memory) {
  RtProcess p;
  const RtKernelInfo kernel = detect_rt_kernel(HostFiles{});
  p.rt_kernel = kernel.realtime;
  if (!kernel.realtime) {
    p.notices.push_back("kernel " + kernel.release +
                        " is not PREEMPT_RT: tasks run, but wake-up latency has no bound "
                        "(`rtplc doctor` says what to change)");
  }
  Result<void> locked = lock_memory(memory);
  p.memory_locked = locked.ok();
  if (!locked) p.notices.push_back(locked.error());
  // Opened after mlockall so the request's own pages are locked too.
  p.cpu_dma_latency = CpuDmaLatencyRequest(0);
  if (!p.cpu_dma_latency.active()) p.notices.push_back(p.cpu_dma_latency.status());
  return p;
}

}  // namespace rtplc::kernel_rt
