// The `can` I/O driver (issue "CAN/GPIO", item 1; docs/can.md): the bridge
// between the process image and one CAN interface. Two threads:
//   I/O thread  (below the task band; only moves frames) blocks in recv() with
//               a short timeout; a mapped frame -> its receive slot, an error
//               frame -> the bus counters and the log; between receives it
//               sends what the bridge queued.
//   bridge      (the driver's periodic thread, never blocks):
//     receive   each frame's last data -> its signals' channels, good while a
//               frame came within the frame's timeout, bad after (last value
//               kept); never good before the first frame.
//     transmit  each frame due (its period elapsed, or a value changed and
//               `on_change`) is packed from the task outputs and queued. A
//               frame is sent only when every one of its outputs is good (or
//               forced) and fits its signal: a drive is never sent bytes we
//               cannot vouch for. Delivery is good while frames of that output
//               leave the controller and the bus is not off.
//     status    the bus counters -> the driver's one link row.
//
// Handoff between the two threads (io/link/handoff.h):
//   rx_[i]       SnapshotSlot<RxSample>, written by the I/O thread only, read by
//                the bridge (and tests);
//   bus_         SnapshotSlot<BusCounters>, the same;
//   tx_done_[i]  SnapshotSlot<TxOutcome>, written by the I/O thread after each
//                send of transmit frame i, read by the bridge;
//   queue_       BoundedQueue<TxJob>, pushed by the bridge, popped by the I/O
//                thread; a full queue refuses at once (counted failed).
//   io_stop_     written by the control thread (on_joined), read by the I/O
//                thread; relaxed: it carries no data, the thread's join orders
//                the rest.
//
// On a plan (`plan:`, docs/fieldbus.md "Running a link on a plan") the bridge
// is the link's scheduler (fieldbus/link_scheduler.h): each cycle it stages
// every transmit frame from the outputs, then urgent frames that changed,
// the periodic frames whose loop samples in this T_1 frame and one non-RT
// fragment (`bulk`) of at most L_n are handed to the controller by the bridge
// itself, in that order, with non-blocking sends: the order and the instant
// are the schedule, and a queue to the I/O thread would add up to its receive
// timeout of delay. The I/O thread then only receives. The per-class delays
// go to the link row (io/drivers/planned_link.h).
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "fieldbus/link_scheduler.h"
#include "io/drivers/can/config.h"
#include "io/drivers/can/transport.h"
#include "io/drivers/driver.h"
#include "io/link/handoff.h"
#include "kernel_rt/clock.h"

namespace rtplc::can {

struct RxSample {
  uint8_t data[8] = {};
  uint8_t len = 0;
  uint64_t count = 0;   // frames of this id so far (0: none yet)
  int64_t at_ns = 0;    // CLOCK_MONOTONIC when the last one arrived
};

struct BusCounters {
  uint64_t frames_rx = 0;      // mapped frames received
  uint64_t frames_tx = 0;      // frames the controller took
  uint64_t tx_failed = 0;      // sends refused (ENOBUFS, ENETDOWN...)
  uint64_t error_frames = 0;
  uint64_t bad_frames = 0;     // mapped ids shorter than their signals need
  uint64_t rx_errors = 0;      // recv() failures
  uint64_t bus_offs = 0;
  uint64_t restarts = 0;
  uint8_t up = 0;              // 1: the bus carries frames (not off, not down)
  uint8_t passive = 0;         // 1: the controller is error-passive
};

struct TxOutcome {
  uint64_t seq = 0;  // the job it answers
  int err = 0;       // 0: sent
};

struct TxJob {
  uint32_t frame = 0;
  uint64_t seq = 0;
  Frame f;
};

class CanDriver final : public io::Driver, private fieldbus::LinkSender {
 public:
  // `clock` stamps the planned link's hand-overs (tests give a virtual one).
  CanDriver(const io::DriverSetup& setup, const TransportOps& transport,
            fieldbus::LinkScheduler::Clock clock = &kernel_rt::monotonic_now_ns);
  ~CanDriver() override;

  // Opens the port and starts the I/O thread (on_start does; tests call it
  // alone and drive the bridge with cycle_now() at times of their choosing).
  Result<void> start_io();
  // Whether a transmit signal (consumed output j) can carry `value` after its
  // scale and offset in its bytes and encoding (what pack() accepts).
  Result<void> can_send(uint32_t j, double value) const override;
  // Tests: the bus counters as the I/O thread last published them.
  BusCounters counters() const;
  uint64_t rx_timeouts() const { return rx_timeouts_.load(std::memory_order_relaxed); }
  uint64_t rejected() const { return rejected_.load(std::memory_order_relaxed); }
  // Tests, on a plan: the scheduler (its stats), frames the bridge sent, bulk transfers finished.
  const fieldbus::LinkScheduler* scheduler() const { return sched_.get(); }
  uint64_t planned_sent() const { return planned_tx_; }
  uint64_t transfers_done() const { return transfers_done_; }

 private:
  struct RxTrack {
    RxSample last;
    bool stale = true;
    bool seen = false;
    uint32_t first = 0;  // its first signal's input index
  };
  struct TxTrack {
    uint32_t first = 0;  // its first signal's output index
    int64_t next_due = 0;
    bool sent = false;
    bool force = false;
    uint8_t data[8] = {};      // what was queued last
    uint64_t next_seq = 1;
    uint64_t in_flight = 0;    // seq not answered yet
    int last_err = 0;
    bool refusal_logged = false;
    bool failure_logged = false;
    uint8_t staged[8] = {};    // on a plan: what the outputs say now
    bool staged_ok = false;    // ... and whether we can vouch for it
    uint32_t slot = 0;         // on a plan: its index among the scheduler's periodic or urgent messages
  };

  Result<void> on_start() override;
  void cycle(int64_t now_ns) noexcept override;
  void on_stop() noexcept override;
  void on_joined() noexcept override;
  void io_loop() noexcept;
  void io_frame(const Frame& f, BusCounters& c) noexcept;
  void publish_status() noexcept;
  void receive(uint32_t k, int64_t now) noexcept;
  void transmit(uint32_t k, int64_t now) noexcept;
  // Packs frame i from the outputs into `data`; false when it must not be sent.
  // Stages frame i from its outputs; `held` gets a bit per signal kept at its
  // last bytes. False: nothing to send (a signal held before a first send, a value that
  // does not fit).
  bool pack_frame(uint32_t i, int64_t now, uint8_t (&data)[8], uint64_t& held) noexcept;
  void transmit_planned(uint32_t k, int64_t now) noexcept;
  int send_now(uint32_t i) noexcept;  // frame i's staged data, from the bridge
  fieldbus::SendOutcome send_periodic(uint32_t slot) noexcept override;
  fieldbus::SendOutcome send_urgent(uint32_t slot) noexcept override;
  fieldbus::Nanos send_nonrt(fieldbus::Nanos budget, bool& more) noexcept override;
  Result<void> load_bulk();

  const CanSettings& settings_;
  const TransportOps& transport_;
  Port port_;
  std::vector<IdFilter> filters_;
  std::unique_ptr<link::SnapshotSlot<RxSample>[]> rx_;
  std::unique_ptr<link::SnapshotSlot<TxOutcome>[]> tx_done_;
  link::SnapshotSlot<BusCounters> bus_;
  link::BoundedQueue<TxJob> queue_;
  std::atomic<bool> io_stop_{false};
  kernel_rt::RtThread io_thread_;
  bool io_started_ = false;
  int64_t io_wait_ns_ = 0;

  // Bridge thread only (the atomics are read by tests).
  std::vector<RxTrack> rx_track_;
  std::vector<TxTrack> tx_track_;
  BusCounters seen_;
  std::atomic<uint64_t> rx_timeouts_{0};
  std::atomic<uint64_t> rejected_{0};
  bool was_up_ = true;
  int64_t next_status_ = 0;

  // On a plan (bridge thread only once started).
  std::unique_ptr<fieldbus::LinkScheduler> sched_;
  bool sched_started_ = false;
  std::vector<uint32_t> periodic_tx_, urgent_tx_;  // scheduler slot -> transmit frame
  fieldbus::Nanos wire_[9] = {};                   // wire time of a frame with n data bytes
  std::vector<std::vector<uint8_t>> bulk_data_;    // read at start
  std::vector<int64_t> bulk_next_;
  size_t bulk_active_ = SIZE_MAX;
  size_t bulk_offset_ = 0;
  uint64_t planned_tx_ = 0;
  uint64_t planned_failed_ = 0;
  uint64_t transfers_done_ = 0;
  bool planned_failure_logged_ = false;
};

extern const io::DriverKind kDriverKind;

}  // namespace rtplc::can
