// The `s7` I/O driver of the runtime (issue "S7 multi-PLC client", item 5): the
// bridge between the process image and the S7 engine (io/s7/engine.h).
//
// The engine runs its own epoll thread and owns every PLC connection. This
// driver's thread runs at the driver's period and never blocks on the network:
//   reads  (era/erd): the engine's latest sample of each item -> the driver's
//          input region, with quality (good / stale / bad) and the time the PLC
//          answered; a PLC that is gone leaves its last value, marked bad or stale;
//   writes (ewa/ewd): the task's output -> engine.write() when it changed (or
//          every cycle, as configured); every write is acknowledged, failed or
//          still pending, and counted — a failed one is sent again;
//   status: each PLC's state, round-trip times, timeouts, errors, reconnects and
//          write counts -> the image's link table, for `rtplc monitor`/`status`.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "common/result.h"
#include "config/driver_s7.h"
#include "io/process_image.h"
#include "io/s7/engine.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::sched {

struct S7WriteWiring {
  uint32_t source_region = 0;  // the task output region holding the value
  uint32_t source_index = 0;
};

class S7Driver {
 public:
  // `writes` parallels settings.writes; `first_link` is this driver's first entry
  // in the image's link table (one per PLC).
  S7Driver(std::string name, io::ProcessImage& image, uint32_t region, int64_t period_ns, int priority,
           int engine_priority, int cpu, const config::S7DriverSettings& settings,
           std::vector<S7WriteWiring> writes, uint32_t first_link);
  ~S7Driver();
  S7Driver(const S7Driver&) = delete;
  S7Driver& operator=(const S7Driver&) = delete;

  // Registers PLCs and items with the engine (no network yet). Errors name the item.
  Result<void> prepare();
  Result<void> start(int64_t first_release_ns);
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }
  void join();
  const std::string& name() const { return name_; }

 private:
  struct Read {
    s7::ItemId item;
    uint32_t index;
  };
  struct Write {
    s7::ItemId item;
    S7WriteWiring from;
    config::S7WriteMode mode;
    uint32_t plc;  // index into plcs_
    double last = 0;
    bool sent = false;
    bool resend = false;
    s7::WriteTicket ticket;
  };
  void run() noexcept;
  void exchange(int64_t now_ns) noexcept;
  void publish_status() noexcept;

  std::string name_;
  io::ProcessImage& image_;
  uint32_t region_;
  int64_t period_ns_;
  int priority_;
  int cpu_;
  config::S7DriverSettings settings_;
  std::vector<S7WriteWiring> write_wiring_;
  uint32_t first_link_;
  s7::Engine engine_;
  std::vector<s7::PlcId> plcs_;
  std::vector<Read> reads_;
  std::vector<Write> writes_;
  // Per-PLC write outcomes counted here (the engine counts per engine).
  std::vector<uint64_t> acked_, failed_, rejected_, pending_;
  std::atomic<bool> stop_{false};
  int64_t first_release_ = 0;
  kernel_rt::RtThread thread_;
  bool started_engine_ = false;
};

}  // namespace rtplc::sched
