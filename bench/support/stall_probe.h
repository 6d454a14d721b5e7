// The machine's own stalls during a benchmark: a child process with one
// thread pinned to each CPU, at SCHED_FIFO above everything the benchmark
// runs, wakes every 4 ms and writes how late each wake-up was (or how long
// the wake-up before it was held up, if that was longer). (One
// per CPU: a host may stop one virtual CPU and not the other, and a thread
// on the stopped one cannot move away.) A virtual machine whose host takes its CPUs away
// (a noisy neighbour, the hypervisor's own work) makes every thread late,
// however high its priority; a benchmark that misses a deadline can then say
// whether the machine was stalled at that time (a figure the code under test
// cannot beat) or was not (the code's own fault).
//
// Fork it before any thread starts. Its cost: 250 wake-ups a second on
// each CPU, in its own process, so it is not counted in the CPU the benchmark
// measures for itself.
//
// Shared memory protocol (per CPU, one writer, that CPU's probe thread; one
// reader, the benchmark): the thread writes late_us[k] and then stores
// ticks = k + 1 with release; the reader loads ticks with acquire and reads
// only entries below it, so every entry it reads was complete. start_ns is
// written before fork.
#pragma once

#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <new>
#include <vector>

#include "kernel_rt/clock.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::bench {

struct Stalls {
  double max_ms = 0;      // the latest wake-up in the window, on any CPU
  uint64_t over_2ms = 0;  // wake-ups more than 2 ms late, all CPUs
  uint64_t wakes = 0;     // wake-ups in the window, all CPUs
};

class StallProbe {
 public:
  static constexpr int64_t kPeriodNs = 4'000'000;  // sees every stall of 4 ms or more (a poll period is 10)
  static constexpr uint64_t kMaxTicks = 3600 * 250;  // an hour; later ticks are not recorded
  static constexpr unsigned kMaxCpus = 8;              // probed CPUs (the first ones allowed)

  // priority: SCHED_FIFO priority of the probe (above the benchmark's threads).
  // on: false makes a probe that does nothing and reports no wake-ups.
  StallProbe(int priority, bool on) {
    if (!on) return;
    void* m = ::mmap(nullptr, sizeof(Shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (m == MAP_FAILED) return;
    shm_ = new (m) Shared;  // the mapping is zeroed already: no need to touch its pages
    shm_->start_ns = kernel_rt::monotonic_now_ns();
    pid_ = ::fork();
    if (pid_ == 0) run(priority);
    if (pid_ < 0) pid_ = 0;
  }
  ~StallProbe() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (shm_) ::munmap(shm_, sizeof(Shared));
  }
  StallProbe(const StallProbe&) = delete;
  StallProbe& operator=(const StallProbe&) = delete;

  bool running() const { return pid_ > 0; }

  // The wake-ups due in [t0, t1) (monotonic ns) that the probe has recorded.
  Stalls between(int64_t t0, int64_t t1) const {
    Stalls s;
    if (!shm_) return s;
    const int64_t start = shm_->start_ns;
    const uint64_t first = t0 <= start ? 0 : static_cast<uint64_t>((t0 - start) / kPeriodNs);
    for (const PerCpu& c : shm_->cpu) {
      const uint64_t n = c.ticks.load(std::memory_order_acquire);
      for (uint64_t k = first; k < n; ++k) {
        const int64_t due = start + static_cast<int64_t>(k + 1) * kPeriodNs;
        if (due < t0) continue;
        if (due >= t1) break;
        const uint32_t late = c.late_us[k];
        ++s.wakes;
        s.max_ms = std::max(s.max_ms, late / 1e3);
        if (late > 2000) ++s.over_2ms;
      }
    }
    return s;
  }

 private:
  struct PerCpu {
    std::atomic<uint64_t> ticks{0};
    uint32_t late_us[kMaxTicks];
  };
  struct Shared {
    int64_t start_ns = 0;
    PerCpu cpu[kMaxCpus];
  };

  [[noreturn]] void run(int priority) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    std::vector<kernel_rt::RtThread> threads;
    unsigned probed = 0;
    for (unsigned cpu = 0; cpu < 1024 && probed < kMaxCpus; ++cpu) {
      if (!kernel_rt::cpu_allowed(cpu)) continue;
      kernel_rt::ThreadSpec spec;
      spec.name = "stall-probe";
      spec.fifo_priority = priority;
      spec.cpu = cpu;
      PerCpu* c = &shm_->cpu[probed++];
      const int64_t start = shm_->start_ns;
      auto t = kernel_rt::start_thread(spec, [c, start] {
        int64_t next = start;
        int64_t held = 0;  // how long the previous wake-up took from its clock read to its sleep
        for (uint64_t k = 0; k < kMaxTicks; ++k) {
          next += kPeriodNs;
          kernel_rt::sleep_until_ns(next);
          const int64_t woke = kernel_rt::monotonic_now_ns();
          // A wake-up does a microsecond of work; one that took milliseconds
          // was stopped while it ran (a scheduler trace of a stall on a
          // virtual machine showed this probe "running" 2.9 ms at a time),
          // a stall its lateness alone does not show.
          const int64_t late = std::max(woke - next, held);
          c->late_us[k] = static_cast<uint32_t>(std::clamp<int64_t>(late / 1000, 0, UINT32_MAX));
          c->ticks.store(k + 1, std::memory_order_release);
          held = kernel_rt::monotonic_now_ns() - woke;
        }
      });
      if (t) threads.push_back(std::move(*t));
    }
    for (auto& t : threads) t.join();
    ::_exit(0);
  }

  Shared* shm_ = nullptr;
  pid_t pid_ = 0;
};

}  // namespace rtplc::bench
