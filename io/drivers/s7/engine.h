// The S7 multi-PLC engine (spec: s7-client.md, "The engine we want"; issue 4, item 3).
//
// One thread runs one epoll loop that owns every PLC connection as a state machine:
//
//   idle (backoff) -> probing (TCP connect = reachability check) -> handshake
//   (COTP + setup) -> ready <-> jobs in flight; any failure -> idle with backoff
//
// No thread per PLC, no select(): a dead, slow or blackholed PLC costs the others
// nothing but its own timer entry. Items are polled per PLC at its poll period with
// the fewest PDUs the negotiated PDU allows (planner.h), pipelined up to the
// negotiated AmQ.
//
// The API keeps the seed's verbs: connect / disconnect a PLC, add_item / remove_item,
// read (latest value), write (queued), and poll_once — the seed's "receive" step —
// for callers that drive the loop themselves instead of start().
//
// Threads: setup calls (connect, add_item, ...) may come from any non-real-time
// thread; they take a mutex and wake the engine. read(), write(), write_result() and
// status() never block, lock, allocate or make a system call, so a SCHED_FIFO task
// can call them every cycle (handoff.h documents the two lock-free protocols).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "common/quality.h"
#include "io/process_image.h"
#include "io/link/latency_buckets.h"
#include "common/result.h"
#include "io/drivers/s7/address.h"
#include "io/drivers/s7/connection.h"

namespace rtplc::s7 {

using PlcId = uint32_t;
using ItemId = uint32_t;
inline constexpr uint32_t kNoId = UINT32_MAX;

struct PlcConfig {
  std::string name;     // for status and logs; defaults to the address
  std::string address;  // numeric IPv4 (resolve names before: the engine never blocks on DNS)
  uint16_t port = 102;
  ConnectionConfig connection;     // TSAPs, requested PDU size and AmQ
  uint32_t poll_period_ms = 100;   // every item of the PLC is read this often
  uint32_t probe_timeout_ms = 1000;    // TCP connect: the reachability check
  uint32_t handshake_timeout_ms = 2000;  // COTP + setup communication
  uint32_t reply_timeout_ms = 1000;  // a job unanswered this long drops the connection
  uint32_t backoff_min_ms = 250;     // first reconnect delay; doubles per failure
  uint32_t backoff_max_ms = 10000;
  uint32_t write_timeout_ms = 5000;  // a write not sent by then fails (PLC unreachable)
  uint32_t merge_gap = 8;            // planner: bytes read for nothing to merge items
};

struct ItemConfig {
  ItemAddress address;
  double scale = 1.0;   // value = raw * scale + offset (raw as signed/float per type)
  double offset = 0.0;
};


// The latest value of an item (what a runtime channel reads).
struct Sample {
  double value = 0;          // engineering value
  uint64_t raw = 0;          // bit pattern as read
  int64_t timestamp_ns = 0;  // CLOCK_MONOTONIC when the reply arrived; 0 = never read
  int64_t max_age_ns = 0;    // three of its poll periods
  Quality quality = Quality::kBad;  // as the last reply said; its age is judged by the reader
  uint8_t return_code = 0;   // the PLC's item return code of the last read (0xFF ok)

  // What the sample is worth at `now_ns`, by the one freshness rule.
  Quality quality_at(int64_t now_ns) const {
    return io::judge_quality(quality, value, timestamp_ns, now_ns, max_age_ns);
  }
};

enum class PlcState : uint8_t { kUnused, kIdle, kProbing, kHandshake, kReady };
std::string_view plc_state_name(PlcState s);

struct PlcStatus {
  PlcState state = PlcState::kUnused;
  uint16_t pdu_size = 0;
  uint16_t amq = 0;
  uint64_t connects = 0;         // handshakes completed
  uint64_t reconnects = 0;       // connections lost after being ready
  uint64_t connect_failures = 0; // probes or handshakes that failed
  uint64_t timeouts = 0;         // jobs that got no reply in time
  uint64_t errors = 0;           // malformed replies, header errors, item errors
  uint64_t dropped_replies = 0;  // replies whose PDU reference matched nothing
  uint64_t polls_started = 0;
  uint64_t polls_completed = 0;
  uint64_t polls_missed = 0;     // ticks skipped while connected (previous poll unsent)
  uint64_t polls_offline = 0;    // ticks while not connected
  uint64_t writes_acked = 0;
  uint64_t writes_failed = 0;
  uint32_t writes_pending = 0;
  uint32_t items = 0;
  uint32_t requests_per_poll = 0;
  uint32_t rtt_p50_us = 0;
  uint32_t rtt_p99_us = 0;
  uint32_t rtt_max_us = 0;
  uint64_t rtt_count = 0;
  link::LatencyBuckets rtt_buckets;  // every round trip since start, coarse
  char last_error[112] = {};
};

enum class WriteState : uint8_t { kUnknown, kPending, kAcknowledged, kFailed, kRejected };
std::string_view write_state_name(WriteState s);

struct WriteTicket {
  uint64_t id = 0;  // 0: rejected (queue full or bad item)
};

struct WriteResult {
  WriteState state = WriteState::kUnknown;
  uint8_t return_code = 0;  // the PLC's item return code when failed by the PLC
};

struct EngineCounters {
  uint64_t writes_queued = 0;
  uint64_t writes_rejected = 0;
  uint64_t writes_acked = 0;
  uint64_t writes_failed = 0;
  uint64_t loop_wakeups = 0;
};

struct EngineOptions {
  size_t max_plcs = 1024;
  size_t max_items = 65536;
  size_t write_queue = 4096;
  // How often the loop looks at the write queue when nothing else wakes it: write()
  // makes no system call, so the engine picks writes up within this time.
  uint32_t write_pickup_us = 2000;
  uint64_t seed = 0x5eed;  // backoff jitter
  // Scheduling of the engine thread made by start(): SCHED_FIFO at this priority
  // (0: leave it SCHED_OTHER), pinned to this CPU (-1: anywhere). Beside real-time
  // tasks, give it a priority below theirs: it never holds anything they wait for.
  int sched_fifo_priority = 0;
  int cpu = -1;
  // Wakeup coalescing. 0: the loop wakes on every event (lowest latency). N > 0:
  // while traffic flows, the loop sleeps N us at most, not waiting in epoll, then
  // takes every ready event at once: replies no longer wake it one by one, at the
  // price of up to N us of added latency. Idle, it waits in epoll as usual.
  uint32_t coalesce_us = 0;
  // Called on the engine thread when a poll completes: latency from the scheduled
  // tick to the last reply. For benchmarks and monitors; keep it short.
  std::function<void(PlcId, int64_t latency_ns)> on_poll_complete;
};

class Engine {
 public:
  explicit Engine(EngineOptions opt = {});
  ~Engine();
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  // Runs the loop on its own thread until stop() or destruction.
  Result<void> start();
  void stop();
  // Or drive it yourself: one loop iteration, waiting at most `max_wait_ms` for I/O.
  void poll_once(int max_wait_ms);

  // --- setup (non-real-time threads) ---
  Result<PlcId> connect(const PlcConfig& cfg);
  void disconnect(PlcId plc);
  Result<ItemId> add_item(PlcId plc, const ItemConfig& item);
  void remove_item(ItemId item);

  // --- any thread, never blocks ---
  // The latest sample; false (out unchanged) when no consistent copy could be
  // taken in a bounded number of tries (see io/link/handoff.h).
  bool try_read(ItemId item, Sample& out) const;
  // The same for tools and tests: a sample that could not be read comes back bad.
  Sample read(ItemId item) const;
  WriteTicket write(ItemId item, double value);
  WriteTicket write_raw(ItemId item, uint64_t raw);
  WriteResult write_result(WriteTicket t) const;
  // Published on every state change and at most every 250 ms otherwise.
  PlcStatus status(PlcId plc) const;
  bool try_status(PlcId plc, PlcStatus& out) const;
  EngineCounters counters() const;

  static int64_t now_ns();  // CLOCK_MONOTONIC, the clock of every timestamp here

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtplc::s7
