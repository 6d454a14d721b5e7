// The `gpio` I/O driver (issue "CAN/GPIO", GPIO half; docs/gpio.md): GPIO
// lines as direct I/O. Two threads:
//   I/O thread  (below the task band; only moves events) exists when some line
//               has edges to follow (counters, debounced inputs). It waits on
//               their event queues with a short timeout and takes every event
//               the kernel queued, in order, with its kernel timestamp:
//     counter   an edge of the configured kind is a pulse, unless it is closer
//               than `debounce` to the last counted one; the running count is
//               published (a pulse is never lost between task cycles: the
//               kernel queues them and the count only grows);
//     input     (debounced) a new level is published once it held `debounce`.
//   bridge      (the driver's periodic thread, never blocks: line reads and
//               writes are non-blocking ioctls on lines it holds):
//     inputs    level -> channel, good while the read works (a debounced input
//               takes the I/O thread's level);
//     counters  the published count -> channel, good while events are read;
//     outputs   the task's value drives the line (set only when it changes,
//               or after a failed set); a value the task cannot vouch for
//               (bad quality) drives the entry's `safe` level instead, and its
//               delivery is bad. After `rtplc stop` one more cycle drives the
//               tasks' safe values.
//     status    one link row per chip.
//
// Handoff between the two threads (io/link/handoff.h):
//   edges_[e]   SnapshotSlot<EdgeState>, event line e: written by the I/O
//               thread only, read by the bridge (and tests);
//   io_stop_    written by the control thread (on_joined), read by the I/O
//               thread; relaxed: it carries no data, the join orders the rest.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "io/drivers/driver.h"
#include "io/drivers/gpio/chip.h"
#include "io/drivers/gpio/config.h"
#include "io/link/handoff.h"

namespace rtplc::gpio {

struct EdgeState {
  uint64_t count = 0;     // counters: pulses counted since start
  uint64_t ignored = 0;   // edges inside the debounce time, or of the other kind
  uint64_t errors = 0;    // failed event reads / waits
  int64_t last_ns = 0;    // kernel timestamp of the last counted pulse / accepted level
  int64_t alive_ns = 0;   // when the I/O thread last looked at the line (the value's time:
                          // a starved or stuck thread makes it stale, io::judge_quality)
  uint8_t level = 0;      // the (debounced) logical level
  uint8_t ok = 1;         // 0: the last wait or read failed
};

class GpioDriver final : public io::Driver {
 public:
  GpioDriver(const io::DriverSetup& setup, const ChipOps& ops);
  ~GpioDriver() override;

  // Opens the chips, requests the lines and starts the I/O thread (on_start
  // does; tests call it alone and drive the bridge with cycle_now()).
  Result<void> start_io();
  // Tests: the state of the i-th configured line's events, as last published
  // (zero for lines without events).
  EdgeState edges_of(size_t line) const;
  uint64_t io_errors() const { return io_errors_.load(std::memory_order_relaxed); }

 private:
  struct Track {
    void* line = nullptr;
    uint32_t chip = 0;      // link row
    uint32_t index = 0;     // input index (inputs, counters) or output index
    int edge_slot = -1;     // into edges_, when the I/O thread follows it
    int last_set = -1;      // outputs: the level driven last (-1: none yet)
    int last_err = 0;
    bool failing = false;
    bool vouched = false;   // outputs: the level driven last was the task's own, good value
    EdgeState seen;         // the I/O thread's state as the bridge last read it
  };

  Result<void> on_start() override;
  void cycle(int64_t now_ns) noexcept override;
  void on_stop() noexcept override;
  void on_joined() noexcept override;
  void io_loop() noexcept;
  void publish_status() noexcept;

  const GpioSettings& settings_;
  const ChipOps& ops_;
  std::vector<std::string> chip_names_;
  std::vector<void*> chips_;
  std::vector<Track> tracks_;
  std::vector<void*> event_lines_;
  std::vector<uint32_t> event_track_;  // event line -> track
  std::unique_ptr<link::SnapshotSlot<EdgeState>[]> edges_;
  std::atomic<bool> io_stop_{false};
  kernel_rt::RtThread io_thread_;
  bool io_started_ = false;
  int64_t io_wait_ns_ = 0;

  // Bridge thread only (the atomic is read by tests).
  std::vector<uint64_t> chip_errors_;
  std::atomic<uint64_t> io_errors_{0};
  int64_t next_status_ = 0;
};

extern const io::DriverKind kDriverKind;

}  // namespace rtplc::gpio
