// The I/O side of the modbus driver (issue 9, item 1): one Line per TCP slave,
// and one per RTU serial device serving its units in turn. Each line is its own
// thread below the task band, polling with libmodbus's blocking calls under
// the slave's own timeout, so a slow or dead TCP slave delays only its own
// thread; on RTU a dead unit costs its own timeout and is then polled less
// often (backoff) until it answers.
//
// Handoff with the bridge thread (io/link/handoff.h), nobody ever waits:
//   reads    the line stores each item's latest sample into its SnapshotSlot
//            (one writer: the line; reader: the bridge).
//   writes   the bridge pushes WriteJobs into the line's BoundedQueue (the
//            bridge is the only producer); the line stores each write's outcome
//            into the write's SnapshotSlot, tagged with the job's sequence.
//   status   the line stores each unit's counters into its SnapshotSlot.
// The line wakes at its next poll or after `wake_ns` (the driver's period),
// whichever comes first, so a queued write waits at most about one period.
// Polls fall on the clock's multiples of their period, so all lines of one
// period wake together (see poll_block).
//
// An RTU line on a fieldbus plan (its slaves' `plan`, docs/fieldbus.md
// "Running a link on a plan") is scheduled by fieldbus/link_scheduler.h
// instead, in T_1 frames on the clock's multiples of T_1: urgent writes first
// in the frame they were queued in, then the read requests of the loops that
// sample in this frame, then one non-RT read of at most L_n of data. The
// line's per-class figures go to the bridge through `planned` (one writer:
// the line; reader: the bridge, which writes them into the line's first
// slave's link row).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/result.h"
#include "fieldbus/link_scheduler.h"
#include "io/drivers/driver.h"
#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/config.h"
#include "io/drivers/modbus/planner.h"
#include "io/link/handoff.h"
#include "io/link/latency_buckets.h"
#include "io/link/rtt_histogram.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::modbus {

struct ItemSample {
  double value = 0;          // engineering value (scaled)
  int64_t timestamp_ns = 0;  // when the slave answered
  uint8_t good = 0;
  uint8_t exception = 0;     // the slave refused the item's block with this exception
};

struct WriteJob {
  uint32_t write = 0;  // the write map's index
  uint64_t seq = 0;
  uint16_t words[2] = {};
};

struct WriteOutcome {
  uint64_t seq = 0;  // the job this outcome is for (0: none yet)
  uint8_t ok = 0;
  uint8_t exception = 0;
};

struct UnitStatus {
  uint8_t state = 0;  // io::LinkState
  uint64_t connects = 0, reconnects = 0, timeouts = 0, errors = 0;
  uint64_t polls_completed = 0, polls_missed = 0, polls_offline = 0;
  uint32_t rtt_p50_us = 0, rtt_p99_us = 0, rtt_max_us = 0;
  link::LatencyBuckets buckets;
};

// Shared between the bridge and the lines, indexed by the driver's read map,
// write map and slave indices.
struct Exchange {
  explicit Exchange(size_t reads, size_t writes, size_t slaves)
      : samples(std::make_unique<link::SnapshotSlot<ItemSample>[]>(reads)),
        outcomes(std::make_unique<link::SnapshotSlot<WriteOutcome>[]>(writes)),
        status(std::make_unique<link::SnapshotSlot<UnitStatus>[]>(slaves)),
        planned(std::make_unique<link::SnapshotSlot<fieldbus::LinkFigures>[]>(slaves)) {}
  std::unique_ptr<link::SnapshotSlot<ItemSample>[]> samples;
  std::unique_ptr<link::SnapshotSlot<WriteOutcome>[]> outcomes;
  std::unique_ptr<link::SnapshotSlot<UnitStatus>[]> status;
  // A planned line's figures, in the slot of its first slave.
  std::unique_ptr<link::SnapshotSlot<fieldbus::LinkFigures>[]> planned;
};

struct LineOptions {
  std::string driver;       // for log events
  int64_t wake_ns = 10000000;
  int priority = 0;
  int cpu = -1;
  io::LinkEventQueue* events = nullptr;
  // Measurements only (bench/modbus; the driver leaves it empty): called on the
  // line's thread after each poll that a unit answered (data or an exception),
  // with the poll's slot on its block's grid and when the answer came, so the
  // latency from the scheduled tick can be measured without a second clock.
  std::function<void(uint32_t slave, int64_t due_ns, int64_t answered_ns)> on_poll;
};

class Line final : private fieldbus::LinkSender {
 public:
  // `slaves`: the indices of the slaves on this line (one for TCP).
  Line(const ModbusSettings& s, std::vector<uint32_t> slaves, Exchange& x, LineOptions opt);
  ~Line();
  Line(const Line&) = delete;
  Line& operator=(const Line&) = delete;

  Result<void> start();
  void request_stop() { stop_.store(true, std::memory_order_relaxed); }
  void join();
  // The bridge (one producer): false when the queue is full.
  bool push(const WriteJob& job) { return queue_.push(job); }
  bool serves(uint32_t slave) const;
  // On a plan: the scheduler (tests read its figures through Exchange::planned).
  bool planned() const { return sched_ != nullptr; }

 private:
  struct Read {
    uint32_t map = 0;  // index into settings.reads
    double last = 0;
  };
  struct UnitBlock {
    Block block;
    int64_t next_due = 0;
    bool refusal_logged = false;
    ChannelMap::Traffic traffic = ChannelMap::Traffic::kUnplanned;
    size_t cursor = 0;  // non-RT: the next of block.items to read
  };
  struct Unit {
    uint32_t slave = 0;
    const SlaveConfig* cfg = nullptr;
    std::vector<Read> reads;
    std::vector<UnitBlock> blocks;
    UnitStatus st;
    link::RttHistogram rtt;
    uint32_t failures = 0;       // consecutive failed polls
    int64_t quiet_until = 0;     // RTU: a unit that stopped answering is skipped until then
    bool answered = false;       // ever
    int64_t quantiles_due = 0;   // when st's RTT quantiles are computed again
  };

  void run() noexcept;
  void run_planned() noexcept;
  void plan_line(const fieldbus::LinkPlan& lp);
  void write_one(const WriteJob& job) noexcept;
  void store_items(Unit& u, const UnitBlock& b, size_t from, size_t to, uint16_t start, const uint16_t* words,
                   int64_t answered) noexcept;
  fieldbus::SendOutcome send_periodic(uint32_t slot) noexcept override;
  fieldbus::SendOutcome send_urgent(uint32_t slot) noexcept override;
  fieldbus::Nanos send_nonrt(fieldbus::Nanos budget, bool& more) noexcept override;
  bool ensure_connected(int64_t now) noexcept;
  void drop_connection(int64_t now, const char* why) noexcept;
  void serve_writes() noexcept;
  void poll_block(Unit& u, UnitBlock& b, int64_t now) noexcept;
  void mark_bad(Unit& u, const UnitBlock& b, int64_t now, uint8_t exception) noexcept;
  void record(Unit& u, const Outcome& o, int64_t started_ns) noexcept;
  void publish(Unit& u) noexcept;
  void log(io::LinkEvent::Level level, std::string_view text) noexcept;

  const ModbusSettings& s_;
  Exchange& x_;
  LineOptions opt_;
  std::vector<Unit> units_;
  Client client_;
  link::BoundedQueue<WriteJob> queue_;
  std::atomic<bool> stop_{false};
  kernel_rt::RtThread thread_;
  bool started_ = false;
  bool ever_connected_ = false;
  bool said_unreachable_ = false;
  uint32_t connect_failures_ = 0;
  int64_t next_connect_ = 0;
  uint64_t random_ = 0x9E3779B97F4A7C15ull;
  std::string name_;  // "pump" or "/dev/ttyUSB0"

  // On a plan (the line's thread only).
  struct BlockRef {
    uint32_t unit = 0;
    uint32_t block = 0;
  };
  std::unique_ptr<fieldbus::LinkScheduler> sched_;
  const fieldbus::LinkTiming* timing_ = nullptr;
  int64_t epoch_ = 0;
  std::vector<BlockRef> periodic_;       // scheduler slot -> block
  std::vector<BlockRef> nonrt_;          // the non-RT blocks
  std::vector<int32_t> write_slot_;      // write map -> urgent slot, -1: not on this line
  std::vector<WriteJob> pending_;        // urgent slot -> its queued write
  std::vector<uint8_t> pending_set_;
  size_t nonrt_active_ = SIZE_MAX;       // index into nonrt_
};

}  // namespace rtplc::modbus
