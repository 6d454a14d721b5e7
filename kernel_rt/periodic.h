// What every periodic driver thread shares (io/drivers/driver.h): how
// it starts (SCHED_FIFO at its priority, optionally pinned, stack prefaulted)
// and how it finds its next release on the grid after a stall.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "common/result.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::kernel_rt {

// One period after `release`; if `now` is already past that (a stall, a
// debugger), the first grid point after `now`: a driver resumes on its grid
// instead of running late cycles back to back.
inline int64_t next_release(int64_t release, int64_t period, int64_t now) noexcept {
  release += period;
  if (now > release) release += ((now - release) / period + 1) * period;
  return release;
}

// Starts a driver's thread ("rtplc:<tag>"): SCHED_FIFO `priority` (0 =
// SCHED_OTHER; a refused FIFO falls back, see kernel_rt/rt_thread.h), pinned to
// `cpu` when >= 0. Errors name the driver.
inline Result<RtThread> start_driver_thread(const std::string& driver, const char* tag,
                                                       int priority, int cpu,
                                                       std::function<void()> body) {
  ThreadSpec spec;
  spec.name = std::string("rtplc:") + tag;
  spec.fifo_priority = priority;
  if (cpu >= 0) spec.cpu = static_cast<unsigned>(cpu);
  spec.prefault_stack = 128 * 1024;
  auto t = start_thread(spec, std::move(body));
  if (!t) return make_error("driver " + driver + ": " + t.error());
  return t;
}

}  // namespace rtplc::kernel_rt
