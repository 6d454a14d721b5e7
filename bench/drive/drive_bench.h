// bench_drive's shared parts (issue 10, item 5, "Benchmark"): the options, the
// CPU clocks of single threads, and one stream run (a producer pushing items
// into a fake at a fixed rate while a consumer thread takes them), used by the
// CAN half (can_bench.cpp) and the GPIO half (gpio_bench.cpp).
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.h"
#include "io/drivers/driver.h"
#include "io/process_image.h"

namespace rtplc::bench {

struct Options {
  bool can = true;
  bool gpio = true;
  double scale = 1.0;           // multiplies every item count (--quick: 0.2)
  int64_t decode_cycles = 200000;
  double can_paced_rate = 8000;  // frames/s: a saturated 1 Mbit/s bus of 8-byte frames
  double gpio_paced_rate = 1000;  // pulses/s
  double paced_seconds = 2;
  unsigned can_queue = 256;     // the fake bus's receive queue per port
  unsigned gpio_queue = 16;     // the fake chip's event queue per line (the kernel's)
  int helper_priority = 9;      // the runtime's helper priority (band_lo - 1); 0: SCHED_OTHER
  int bridge_priority = 50;     // above the default task band (10..49)
};

// CPU time of the calling thread (CLOCK_THREAD_CPUTIME_ID), ns.
int64_t self_cpu_ns();
// On-CPU time of one thread of this process from the scheduler's clock
// (/proc/self/task/TID/schedstat, exact unlike tick-sampled utime), ns; -1
// when unreadable.
int64_t task_cpu_ns(pid_t tid);
// The thread of this process whose name (comm) is `comm`; 0 when none.
pid_t find_task(std::string_view comm);
pid_t current_tid();
// "SCHED_FIFO 9" or "SCHED_OTHER": what the thread runs as now.
std::string policy_text(pid_t tid);

// What a stream run watches on the consumer under test.
struct Consumer {
  std::function<uint64_t()> taken;    // items the consumer counted so far
  std::function<uint64_t()> dropped;  // items the fake's bounded queue dropped so far
  std::function<int64_t()> cpu_ns;    // the consumer thread's CPU so far
};

struct StreamRow {
  double rate = 0;  // asked, items/s; 0: as fast as the producer can
  uint64_t sent = 0, taken = 0, dropped = 0;
  double produced_rate = 0;  // what the producer achieved, items/s
  int64_t cpu_ns = 0;        // consumer CPU over the run (until drained)
  bool drained = false;      // taken + dropped reached sent
  uint64_t lost() const { return sent - taken; }
  // Items neither taken nor dropped by the queue (or counted twice): a bug.
  int64_t unaccounted() const {
    return static_cast<int64_t>(sent) - static_cast<int64_t>(taken) - static_cast<int64_t>(dropped);
  }
};

// Pushes `n` items with produce(i) on the calling thread, item i due at
// i / rate s after the start (sleeping to just before it, then spinning; rate
// 0: no pacing), then waits until the consumer took or the queue dropped all
// of them (giving up after 3 s without progress). Counts are deltas over the run.
StreamRow run_stream(double rate, uint64_t n, const std::function<void(uint64_t)>& produce, const Consumer& c);

// One sweep row per rate, printed as it completes.
void print_stream_header(const char* item, const char* consumer_a, const char* consumer_b);
void print_stream_row(const char* label, const StreamRow& a, const StreamRow* b);
std::string per_item(int64_t cpu_ns, uint64_t items);
std::string rate_text(double items_per_s);

// Both halves return how many correctness checks failed (0: all counts right).
int run_can(const Options& o);
int run_gpio(const Options& o);

// One driver as the runtime starts it: its config parsed from `yaml` (one
// task, one driver), an image with one task output and a driver region
// "driver:`region`" of `provides` inputs, and the driver's setup on it. Exits
// with the error when the config or the image cannot be made (`what` names
// the map in the message).
struct DriverBench {
  config::LoadResult cfg;
  io::ProcessImage image;
  io::LinkEventQueue events{4096};
  io::DriverSetup setup;
};
void prepare_driver_bench(DriverBench& b, const char* what, const char* yaml, const std::string& region,
                          uint32_t provides, uint32_t channel_capacity, int64_t period_ns,
                          const Options& o);

}  // namespace rtplc::bench
