// Internal state of the S7 engine (engine.h), shared by engine.cpp (the API side:
// ids, commands, the lock-free handoff) and engine_loop.cpp (the event loop and the
// per-PLC state machine). Not part of the public interface.
#pragma once

#include <array>
#include <atomic>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

#include "io/drivers/s7/engine.h"
#include "kernel_rt/rt_thread.h"
#include "io/drivers/s7/link.h"
#include "io/drivers/s7/planner.h"
#include "io/drivers/s7/transfer.h"

namespace rtplc::s7 {

// A write as queued by a task: engineering value or raw bits.
struct WriteCmd {
  ItemId item = kNoId;
  bool is_value = false;
  uint64_t raw = 0;
  double value = 0;
};

struct Command {
  enum class Kind : uint8_t { kAddPlc, kRemovePlc, kAddItem, kRemoveItem };
  Kind kind = Kind::kAddPlc;
  uint32_t id = kNoId;   // PlcId or ItemId
  PlcId plc = kNoId;     // kAddItem
  PlcConfig plc_cfg;
  Endpoint endpoint;
  ItemConfig item_cfg;
};

struct PendingWrite {
  uint64_t ticket = 0;
  ItemId item = kNoId;
  uint64_t raw = 0;
  int64_t expires_ns = 0;
};

// A job in flight; its index in Plc::out is the cookie given to the Connection.
struct Outstanding {
  bool used = false;
  bool is_write = false;
  uint16_t ref = 0;
  uint32_t request = 0;    // poll: index in the plan
  uint32_t plan_gen = 0;   // poll: the plan it belongs to
  uint32_t cycle = 0;      // poll: the poll cycle
  int64_t sent_ns = 0;
  int64_t deadline_ns = 0;
  std::vector<PendingWrite> writes;
};

// One poll cycle: the requests of one tick, possibly overlapping the next tick's
// when the link is slower than the poll period (pipelining up to AmQ).
struct Cycle {
  bool active = false;
  uint32_t remaining = 0;
  int64_t tick_ns = 0;
};

struct Plc {
  PlcState state = PlcState::kUnused;
  uint32_t gen = 0;
  PlcConfig cfg;
  Endpoint endpoint;
  UniqueFd fd;
  bool want_out = false;
  Connection conn;
  int64_t state_deadline = TimerHeap::kNever;  // reconnect time, probe or handshake limit
  uint32_t failures = 0;
  bool was_ready = false;
  int64_t offline_since = 0;

  std::vector<ItemId> items;  // current subscription
  bool plan_dirty = true;
  uint32_t plan_gen = 0;
  std::vector<ItemId> plan_items;        // the items the plan was made for
  std::vector<ItemAddress> plan_addrs;
  ReadPlan plan;
  std::vector<Bytes> frames;             // pre-encoded poll jobs
  int64_t next_poll = TimerHeap::kNever;

  static constexpr uint32_t kCycles = 16;
  std::array<Cycle, kCycles> cycles{};
  uint32_t cycle_seq = 0;
  uint32_t next_request = 0;    // of the newest cycle
  uint32_t cycle_requests = 0;

  std::array<Outstanding, Connection::kMaxInFlight> out{};
  std::deque<PendingWrite> pending;

  RttHistogram rtt;
  PlcStatus st;
  uint64_t dropped_before = 0;  // dropped replies of earlier connections
  int64_t last_publish = 0;
};

struct ItemState {
  bool used = false;
  PlcId plc = kNoId;
  ItemConfig cfg;
};

struct Engine::Impl {
  explicit Impl(EngineOptions o);
  ~Impl();

  // --- shared between threads ---
  EngineOptions opt;
  std::unique_ptr<SnapshotSlot<Sample>[]> samples;
  std::unique_ptr<SnapshotSlot<PlcStatus>[]> statuses;
  BoundedQueue<WriteCmd> write_queue;
  // Write outcomes by ticket: (ticket << 16) | (return code << 8) | WriteState. The
  // producer stores kPending before the write becomes visible to the engine (inside
  // the queue's claim step); the engine moves it to a final state with a CAS that
  // only succeeds if the entry still belongs to that ticket, so a slot reused by a
  // much newer ticket is never overwritten by an old outcome.
  std::unique_ptr<std::atomic<uint64_t>[]> write_status;
  uint64_t write_status_mask = 0;
  std::atomic<uint64_t> writes_queued{0}, writes_rejected{0}, writes_acked{0}, writes_failed{0}, wakeups{0};

  // --- API side, under mu ---
  std::mutex mu;
  std::vector<Command> commands;
  std::vector<uint32_t> free_plcs;
  std::vector<uint32_t> free_items;
  std::vector<uint8_t> api_plc_used;
  std::vector<PlcId> api_item_plc;

  UniqueFd epoll_fd;
  UniqueFd wake_fd;
  kernel_rt::RtThread thread;
  std::atomic<bool> running{false};

  // --- engine thread only ---
  std::vector<Plc> plcs;
  std::vector<ItemState> items;
  TimerHeap timers;
  uint64_t rng;
  std::vector<DataItem> scratch;
  std::vector<uint8_t> codes;
  Bytes frame;
  std::vector<Command> taken;
  uint64_t popped_writes = 0;
  int64_t last_activity_ns = 0;  // last loop pass that had events (coalescing)

  void wake();
  void set_write_status(uint64_t ticket, WriteState s, uint8_t rc);

  // engine_loop.cpp
  void poll_once(int max_wait_ms);
  void process_commands(int64_t now);
  void drain_writes(int64_t now);
  void handle_io(uint32_t idx, uint32_t events, int64_t now);
  void fire(uint32_t idx, int64_t now);
  void start_probe(Plc& p, uint32_t idx, int64_t now);
  void on_ready(Plc& p, int64_t now);
  void on_reply(Plc& p, const Connection::Reply& r, int64_t now);
  void tick(Plc& p, int64_t now);
  void pump(Plc& p, int64_t now);
  void flush(Plc& p, uint32_t idx, int64_t now);
  void replan(Plc& p);
  void lost(Plc& p, uint32_t idx, std::string_view why, int64_t now, bool connect_failure);
  void remove_plc(Plc& p, uint32_t idx, int64_t now);
  void mark_items_bad(const Plc& p, uint8_t rc);
  void publish_item(ItemId id, const ItemResult& r, int64_t now, int64_t period_ns);
  void publish(Plc& p, uint32_t idx, int64_t now, bool force);
  void reschedule(Plc& p, uint32_t idx);
  void finish_write(const PendingWrite& w, WriteState s, uint8_t rc, Plc* p);
  int64_t backoff_ns(Plc& p);
  uint64_t random();
  void set_error(Plc& p, std::string_view msg);
};

}  // namespace rtplc::s7
