// The serial side of the modbus driver (issue 9, item 1): one Line per RTU
// device, serving its units in turn on one thread below the task band with
// libmodbus's blocking calls under each unit's timeout; a dead unit costs its
// own timeout and is then polled less often (backoff, unit_book.h) until it
// answers. TCP slaves are served by one event loop instead (tcp_master.h).
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
// Polls fall on the clock's multiples of their period (UnitBook::take_slot).
//
// A line on a fieldbus plan (its slaves' `plan`, docs/fieldbus.md "Running a
// link on a plan") is scheduled by fieldbus/link_scheduler.h instead, in T_1
// frames on the clock's multiples of T_1: urgent writes first in the frame
// they were queued in, then the read requests of the loops that sample in
// this frame, then one non-RT read of at most L_n of data. The line's
// per-class figures go to the bridge through `planned` (one writer: the line;
// reader: the bridge, which writes them into the line's first slave's link row).
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
#include "io/drivers/modbus/lane.h"
#include "io/drivers/modbus/unit_book.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::modbus {

class Line final : public Lane, private fieldbus::LinkSender {
 public:
  // `slaves`: the indices of the RTU slaves on this device.
  Line(const ModbusSettings& s, std::vector<uint32_t> slaves, Exchange& x, LineOptions opt);
  ~Line() override;
  Line(const Line&) = delete;
  Line& operator=(const Line&) = delete;

  Result<void> start() override;
  void request_stop() override { stop_.store(true, std::memory_order_relaxed); }
  void join() override;
  // The bridge (one producer): false when the queue is full.
  bool push(const WriteJob& job) override { return queue_.push(job); }
  // On a plan: the scheduler (tests read its figures through Exchange::planned).
  bool planned() const { return sched_ != nullptr; }

 private:
  using Read = UnitBook::Read;
  using UnitBlock = UnitBook::UnitBlock;
  using Unit = UnitBook::Unit;

  void run() noexcept;
  void run_planned() noexcept;
  void plan_line(const fieldbus::LinkPlan& lp);
  void write_one(const WriteJob& job) noexcept;
  fieldbus::SendOutcome send_periodic(uint32_t slot) noexcept override;
  fieldbus::SendOutcome send_urgent(uint32_t slot) noexcept override;
  fieldbus::Nanos send_nonrt(fieldbus::Nanos budget, bool& more) noexcept override;
  bool ensure_connected(int64_t now) noexcept;
  void drop_connection(int64_t now, const char* why) noexcept;
  void serve_writes() noexcept;
  void poll_block(Unit& u, UnitBlock& b, int64_t now) noexcept;

  const ModbusSettings& s_;
  Exchange& x_;
  LineOptions opt_;
  UnitBook book_;
  std::vector<Unit>& units_ = book_.units;
  Client client_;
  link::BoundedQueue<WriteJob> queue_;
  std::atomic<bool> stop_{false};
  kernel_rt::RtThread thread_;
  bool started_ = false;

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
