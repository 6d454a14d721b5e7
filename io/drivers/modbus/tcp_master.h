// The TCP side of the modbus driver (issue 24): every TCP slave of one driver
// served by one event loop on one thread below the task band, over
// non-blocking sockets with our own MBAP framing (request.h, pdu.h). A
// hundred slaves polled every 10 ms cost one wake-up per period plus the
// answers' arrivals, instead of a thread and a wake-up per slave per period
// (bench/modbus: 19,000 context switches a second and a fifth of a core with
// a thread per slave).
//
// Per slave, one state machine (the slave's UnitBook does the bookkeeping,
// shared with the serial line, line.h):
//   down        reconnect when its backoff ends; due polls count offline
//   connecting  a non-blocking connect, failed after the slave's timeout
//   up          one request in flight at a time: queued writes and the
//               blocks due on the grid, alternating when both wait; an answer is matched by its
//               transaction id (a late answer to an attempt that timed out is
//               dropped), a timeout is retried `retries` times, and
//               several polls without an answer drop the connection
// A dead or silent slave only ever holds its own state machine: nobody waits
// on its socket, so it delays no other slave.
//
// Time: one deadline per slave in a timer heap (its connect or answer
// timeout, its reconnect time, its next poll on the grid); the loop sleeps in
// epoll until the earliest deadline or the write pickup (`wake_ns`, the
// driver's period), whichever comes first. Polls fall on the clock's
// multiples of their period (UnitBook::take_slot), so all slaves of one
// period are served in one wake-up; every 16 requests sent in it, the loop
// takes the answers already there (pump(0)), so the first slaves' values do
// not wait for the last slaves' requests. A deadline reached late reads the
// slave's socket before it calls a timeout: the answer may be there.
//
// Handoff with the bridge thread (io/link/handoff.h), nobody ever waits:
//   writes   the bridge pushes WriteJobs into the slave's BoundedQueue (the
//            bridge is the only producer, the loop the only consumer)
//   reads, outcomes, status: SnapshotSlots in the Exchange, one writer (the
//            loop), one reader (the bridge)
// Stopping: no new polls or connects; the writes the bridge queued last (the
// tasks' safe values) still go to the slaves that are up, within each
// slave's timeout and retries, then every socket closes.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "io/drivers/modbus/lane.h"
#include "io/drivers/modbus/request.h"
#include "io/drivers/modbus/unit_book.h"
#include "io/link/socket_util.h"
#include "io/link/timer_heap.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::modbus {

class TcpMaster final : public Lane {
 public:
  // `slaves`: the indices of the TCP slaves this loop serves.
  TcpMaster(const ModbusSettings& s, const std::vector<uint32_t>& slaves, Exchange& x, LineOptions opt);
  ~TcpMaster() override;
  TcpMaster(const TcpMaster&) = delete;
  TcpMaster& operator=(const TcpMaster&) = delete;

  Result<void> start() override;
  // Release: pairs with the loop's acquire load, so whatever the driver did
  // before asking (its last writes queued) is visible once the loop sees it.
  void request_stop() override { stop_.store(true, std::memory_order_release); }
  void join() override;
  bool push(const WriteJob& job) override;

  // The loop's own figures (tests, bench/modbus): how often it woke.
  uint64_t wakeups() const { return wakeups_.load(std::memory_order_relaxed); }

 private:
  struct Peer;
  enum class Job : uint8_t { kNone, kRead, kWrite };

  void run() noexcept;
  void pump(int64_t wait_ns) noexcept;
  void service(uint32_t i, int64_t now) noexcept;
  void on_io(uint32_t i, uint32_t events, int64_t now) noexcept;
  void begin_connect(Peer& p, uint32_t i, int64_t now) noexcept;
  void connect_done(Peer& p, int err, int64_t now) noexcept;
  bool start_next(Peer& p, int64_t now) noexcept;
  void send_job(Peer& p, int64_t now) noexcept;
  void receive(uint32_t i, int64_t now) noexcept;
  void finish(Peer& p, const Outcome& o, const uint16_t* words, int64_t now, const char* why_lost = nullptr) noexcept;
  void lose_link(Peer& p, int err, const char* why, int64_t now) noexcept;
  void drop(Peer& p, int64_t now, const char* why) noexcept;
  void reschedule(uint32_t i) noexcept;
  bool drained() const noexcept;

  const ModbusSettings& s_;
  LineOptions opt_;
  std::vector<std::unique_ptr<Peer>> peers_;
  std::vector<int32_t> peer_of_write_;  // write map -> peers_ index, -1: not a TCP slave's
  link::UniqueFd epoll_;
  link::TimerHeap timers_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> wakeups_{0};
  bool stopping_ = false;
  kernel_rt::RtThread thread_;
  bool started_ = false;
};

}  // namespace rtplc::modbus
