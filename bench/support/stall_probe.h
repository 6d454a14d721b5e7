// The machine's own stalls during a benchmark: a child process with one
// thread pinned to each CPU, at SCHED_FIFO above everything the benchmark
// runs, wakes every 4 ms and writes the time it lost around each wake-up:
// how late it woke plus how long the wake-up before it was held up (a
// microsecond's work that took milliseconds was stopped while it ran). A
// host that runs its virtual CPUs in short slices (a CPU quota) makes no
// single wake-up very late but loses a lot of time in a row, so the figure
// that matters is the time lost within a poll period (`span`). (One
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
  double max_ms = 0;       // the most time lost around one wake-up, on any CPU
  double span_ms = 0;      // the most time lost within `span` on one CPU
  uint64_t over_2ms = 0;   // wake-ups that lost more than 2 ms, all CPUs
  uint64_t wakes = 0;      // wake-ups in the window, all CPUs
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

  // The wake-ups due in [t0, t1) (monotonic ns) that the probe has recorded;
  // span_ms sums the time lost over runs of wake-ups that cover `span_ns`.
  Stalls between(int64_t t0, int64_t t1, int64_t span_ns) const {
    Stalls s;
    if (!shm_) return s;
    const int64_t start = shm_->start_ns;
    const uint64_t first = t0 <= start ? 0 : static_cast<uint64_t>((t0 - start) / kPeriodNs);
    const auto run = static_cast<uint64_t>(std::max<int64_t>(1, (span_ns + kPeriodNs - 1) / kPeriodNs));
    for (const PerCpu& c : shm_->cpu) {
      const uint64_t n = c.ticks.load(std::memory_order_acquire);
      uint64_t in_window = 0, sum_us = 0;  // the last `run` wake-ups' lost time
      for (uint64_t k = first; k < n; ++k) {
        const int64_t due = start + static_cast<int64_t>(k + 1) * kPeriodNs;
        if (due < t0) continue;
        if (due >= t1) break;
        const uint32_t lost = c.lost_us[k];
        ++s.wakes;
        s.max_ms = std::max(s.max_ms, lost / 1e3);
        if (lost > 2000) ++s.over_2ms;
        sum_us += lost;
        if (++in_window > run) sum_us -= c.lost_us[k - run];
        s.span_ms = std::max(s.span_ms, static_cast<double>(sum_us) / 1e3);
      }
    }
    return s;
  }

 private:
  struct PerCpu {
    std::atomic<uint64_t> ticks{0};
    uint32_t lost_us[kMaxTicks];
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
        int64_t held = 0;       // how long the previous wake-up took from its clock read to its sleep
        int64_t slept = start;  // when the previous wake-up went to sleep
        for (uint64_t k = 0; k < kMaxTicks; ++k) {
          next += kPeriodNs;
          kernel_rt::sleep_until_ns(next);
          const int64_t woke = kernel_rt::monotonic_now_ns();
          // A wake-up does a microsecond of work; one that took milliseconds
          // was stopped while it ran (a scheduler trace of a stall on a
          // virtual machine showed this probe "running" 2.9 ms at a time),
          // a stall its lateness alone does not show. Lateness counts from
          // the later of the deadline and the last sleep, so the wake-ups
          // that catch up after a long stall do not count it again: the
          // time lost by consecutive wake-ups never overlaps.
          const int64_t lost = std::max<int64_t>(0, woke - std::max(next, slept)) + held;
          c->lost_us[k] = static_cast<uint32_t>(std::clamp<int64_t>(lost / 1000, 0, UINT32_MAX));
          c->ticks.store(k + 1, std::memory_order_release);
          slept = kernel_rt::monotonic_now_ns();
          held = slept - woke;
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
