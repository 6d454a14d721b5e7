// What one Modbus connection knows of the units behind it, and tells the
// bridge: shared by the blocking serial line (line.h: an RTU device and its
// units) and the TCP event loop (tcp_master.h: one book per TCP slave), which
// differ only in how bytes move.
//   units    each unit's reads grouped into request blocks (planner.h), on the
//            clock's multiples of their period (take_slot)
//   outcomes a finished poll stores its items' samples (good, or bad with the
//            last value), counts, logs the first failure and the recovery,
//            quiets a dead RTU unit with backoff and says when a TCP
//            connection is to be dropped (poll_done); a write's outcome goes
//            to its slot (write_done)
//   link     connect backoff, the connect/disconnect log lines, the counters
//            the bridge turns into resends (connects)
//   status   publish() stores a unit's counters into its SnapshotSlot
// One thread owns a book: the line's or the event loop's.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "fieldbus/link_scheduler.h"
#include "io/drivers/driver.h"
#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/config.h"
#include "io/drivers/modbus/planner.h"
#include "io/link/handoff.h"
#include "io/link/latency_buckets.h"
#include "io/link/rtt_histogram.h"

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

// Shared between the bridge and the I/O threads, indexed by the driver's read
// map, write map and slave indices.
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
  int64_t wake_ns = 10000000;  // queued writes are picked up at least this often
  int priority = 0;
  int cpu = -1;
  io::LinkEventQueue* events = nullptr;
  // Measurements only (bench/modbus; the driver leaves it empty): called on the
  // I/O thread after each poll that a unit answered (data or an exception),
  // with the poll's slot on its block's grid and when the answer came, so the
  // latency from the scheduled tick can be measured without a second clock.
  std::function<void(uint32_t slave, int64_t due_ns, int64_t answered_ns)> on_poll;
};

class UnitBook {
 public:
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
    int64_t timeout_ns = 0;
    std::vector<Read> reads;
    std::vector<UnitBlock> blocks;
    UnitStatus st;
    link::RttHistogram rtt;
    uint32_t failures = 0;       // consecutive failed polls
    int64_t quiet_until = 0;     // RTU: a unit that stopped answering is skipped until then
    bool answered = false;       // ever
    int64_t quantiles_due = 0;   // when st's RTT quantiles are computed again
  };

  // `slaves`: the indices of the slaves behind this connection (one for TCP).
  UnitBook(const ModbusSettings& s, const std::vector<uint32_t>& slaves, Exchange& x, const LineOptions& opt);

  std::vector<Unit> units;
  const ModbusSettings& settings() const { return s_; }
  Exchange& exchange() { return x_; }
  const std::string& name() const { return name_; }  // "pump" or "/dev/ttyUSB0"
  const SlaveConfig& first() const { return *units.front().cfg; }

  // The poll grid. The slot a poll made at `now` stands for (the latest grid
  // point not after now; the first poll: now itself), counting the slots it
  // skipped as missed and moving the block to its next slot after now.
  static int64_t take_slot(Unit& u, UnitBlock& b, int64_t now);
  // A poll not made (the unit quiet or the link down): counted offline; the
  // block waits for its next slot on the grid.
  static void skip_slot(Unit& u, UnitBlock& b, int64_t now);
  // The earliest instant a block of `u` is due (its quiet time included).
  static int64_t next_due(const Unit& u);

  // One request's outcome into the counters (an answer's round trip into the RTT).
  void record(Unit& u, const Outcome& o, int64_t started_ns, int64_t now) noexcept;
  // After a poll's last attempt: samples, counters, logs, backoff. Returns why
  // the connection is to be dropped (the caller closes it and calls dropped()),
  // or nullptr.
  const char* poll_done(Unit& u, UnitBlock& b, const Outcome& o, const uint16_t* words, int64_t due,
                        int64_t answered) noexcept;
  void store_items(Unit& u, const UnitBlock& b, size_t from, size_t to, uint16_t start, const uint16_t* words,
                   int64_t answered) noexcept;
  void mark_bad(Unit& u, const UnitBlock& b, int64_t now, uint8_t exception) noexcept;
  // The unit a write map entry goes to, or nullptr (not behind this connection).
  Unit* unit_of_write(uint32_t write) noexcept;
  // A write's outcome for the bridge; `o` null: not sent (no connection).
  void write_done(const WriteJob& job, const Outcome* o) noexcept;
  void publish(Unit& u, int64_t now) noexcept;
  void publish_all(int64_t now) noexcept {
    for (Unit& u : units) publish(u, now);
  }
  void log(io::LinkEvent::Level level, std::string_view text) noexcept;

  // The connection (TCP) or the serial device (RTU).
  bool connect_due(int64_t now) const { return now >= next_connect_; }
  int64_t next_connect() const { return next_connect_; }
  void connecting() noexcept;
  void connected() noexcept;
  void connect_failed(const Outcome& o, int64_t now) noexcept;
  // The connection was closed for `why`: every item bad, units down, reconnect
  // after a short backoff.
  void dropped(int64_t now, const char* why) noexcept;
  uint64_t next_random() noexcept {
    random_ = random_ * 6364136223846793005ull + 1442695040888963407ull;
    return random_ >> 11;
  }

 private:
  const ModbusSettings& s_;
  Exchange& x_;
  const LineOptions& opt_;
  std::string name_;
  bool ever_connected_ = false;
  bool said_unreachable_ = false;
  uint32_t connect_failures_ = 0;
  int64_t next_connect_ = 0;
  uint64_t random_ = 0x9E3779B97F4A7C15ull;
};

int64_t seconds_to_ns(double s);

}  // namespace rtplc::modbus
