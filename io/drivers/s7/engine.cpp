// The S7 engine's API side (issue 4, item 3): id allocation and setup commands for
// non-real-time threads, and the never-blocking read/write/status calls for tasks.
// The loop itself is in engine_loop.cpp.
#include "io/drivers/s7/engine.h"

#include <pthread.h>
#include <sched.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

#include <fmt/format.h>

#include "io/drivers/s7/engine_impl.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::s7 {

std::string_view plc_state_name(PlcState s) {
  switch (s) {
    case PlcState::kUnused: return "unused";
    case PlcState::kIdle: return "disconnected";
    case PlcState::kProbing: return "probing";
    case PlcState::kHandshake: return "handshake";
    case PlcState::kReady: return "ready";
  }
  return "?";
}

std::string_view write_state_name(WriteState s) {
  switch (s) {
    case WriteState::kUnknown: return "unknown";
    case WriteState::kPending: return "pending";
    case WriteState::kAcknowledged: return "acknowledged";
    case WriteState::kFailed: return "failed";
    case WriteState::kRejected: return "rejected";
  }
  return "?";
}

int64_t Engine::now_ns() { return kernel_rt::monotonic_now_ns(); }

Engine::Impl::Impl(EngineOptions o)
    : opt(std::move(o)),
      samples(std::make_unique<SnapshotSlot<Sample>[]>(opt.max_items)),
      statuses(std::make_unique<SnapshotSlot<PlcStatus>[]>(opt.max_plcs)),
      write_queue(opt.write_queue),
      rng(opt.seed | 1) {
  // Four times the queue: an outcome stays readable for a while after the write left
  // the queue.
  const size_t n = write_queue.capacity() * 4;
  write_status = std::make_unique<std::atomic<uint64_t>[]>(n);
  for (size_t i = 0; i < n; ++i) write_status[i].store(0, std::memory_order_relaxed);
  write_status_mask = n - 1;
  for (size_t i = opt.max_plcs; i > 0; --i) free_plcs.push_back(static_cast<uint32_t>(i - 1));
  for (size_t i = opt.max_items; i > 0; --i) free_items.push_back(static_cast<uint32_t>(i - 1));
  api_plc_used.assign(opt.max_plcs, 0);
  api_item_plc.assign(opt.max_items, kNoId);
  plcs.resize(opt.max_plcs);
  items.resize(opt.max_items);
  timers.resize(opt.max_plcs);
  epoll_fd.reset(::epoll_create1(EPOLL_CLOEXEC));
  wake_fd.reset(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = UINT64_MAX;
  ::epoll_ctl(epoll_fd.get(), EPOLL_CTL_ADD, wake_fd.get(), &ev);
}

Engine::Impl::~Impl() = default;

void Engine::Impl::wake() {
  const uint64_t one = 1;
  // A full eventfd counter still wakes the loop, so a failed write changes nothing.
  [[maybe_unused]] const ssize_t n = ::write(wake_fd.get(), &one, sizeof one);
}

void Engine::Impl::set_write_status(uint64_t ticket, WriteState s, uint8_t rc) {
  std::atomic<uint64_t>& e = write_status[ticket & write_status_mask];
  uint64_t expect = ticket << 16 | static_cast<uint64_t>(WriteState::kPending);
  const uint64_t want = ticket << 16 | static_cast<uint64_t>(rc) << 8 | static_cast<uint64_t>(s);
  e.compare_exchange_strong(expect, want, std::memory_order_release, std::memory_order_relaxed);
}

Engine::Engine(EngineOptions opt) : impl_(std::make_unique<Impl>(std::move(opt))) {}

Engine::~Engine() { stop(); }

Result<void> Engine::start() {
  if (!impl_->epoll_fd.valid() || !impl_->wake_fd.valid()) return make_error("cannot create epoll/eventfd");
  if (impl_->running.exchange(true)) return make_error("engine already running");
  // Threads, priorities and affinity only through kernel_rt: a refused FIFO
  // runs the loop under SCHED_OTHER (as tasks do) instead of failing.
  kernel_rt::ThreadSpec spec;
  spec.name = "rtplc:s7-engine";
  spec.fifo_priority = impl_->opt.sched_fifo_priority;
  if (impl_->opt.cpu >= 0) spec.cpu = static_cast<unsigned>(impl_->opt.cpu);
  spec.prefault_stack = 64 * 1024;
  auto t = kernel_rt::start_thread(spec, [this] {
    while (impl_->running.load(std::memory_order_relaxed)) impl_->poll_once(100);
  });
  if (!t) {
    impl_->running.store(false);
    return make_error("engine thread: " + t.error());
  }
  impl_->thread = std::move(t).value();
  return {};
}

void Engine::stop() {
  if (!impl_->running.exchange(false)) return;
  impl_->wake();
  if (impl_->thread.joinable()) impl_->thread.join();
}

void Engine::poll_once(int max_wait_ms) { impl_->poll_once(max_wait_ms); }

Result<PlcId> Engine::connect(const PlcConfig& cfg) {
  auto ep = parse_endpoint(cfg.address, cfg.port);
  if (!ep) return make_error(ep.error());
  if (cfg.poll_period_ms == 0) return make_error("poll period must be at least 1 ms");
  Command c;
  c.kind = Command::Kind::kAddPlc;
  c.plc_cfg = cfg;
  if (c.plc_cfg.name.empty()) c.plc_cfg.name = ep->text();
  c.endpoint = *ep;
  PlcId id = kNoId;
  {
    std::lock_guard lock(impl_->mu);
    if (impl_->free_plcs.empty()) return make_error(fmt::format("engine full: {} PLCs", impl_->opt.max_plcs));
    id = impl_->free_plcs.back();
    impl_->free_plcs.pop_back();
    impl_->api_plc_used[id] = 1;
    c.id = id;
    impl_->commands.push_back(std::move(c));
  }
  impl_->wake();
  return id;
}

void Engine::disconnect(PlcId plc) {
  {
    std::lock_guard lock(impl_->mu);
    if (plc >= impl_->api_plc_used.size() || !impl_->api_plc_used[plc]) return;
    impl_->api_plc_used[plc] = 0;
    for (size_t i = 0; i < impl_->api_item_plc.size(); ++i) {
      if (impl_->api_item_plc[i] == plc) {
        impl_->api_item_plc[i] = kNoId;
        impl_->free_items.push_back(static_cast<uint32_t>(i));
      }
    }
    impl_->free_plcs.push_back(plc);
    Command c;
    c.kind = Command::Kind::kRemovePlc;
    c.id = plc;
    impl_->commands.push_back(std::move(c));
  }
  impl_->wake();
}

Result<ItemId> Engine::add_item(PlcId plc, const ItemConfig& item) {
  if (item.scale == 0.0) return make_error("item scale must not be 0");
  ItemId id = kNoId;
  {
    std::lock_guard lock(impl_->mu);
    if (plc >= impl_->api_plc_used.size() || !impl_->api_plc_used[plc]) return make_error("no such PLC");
    if (impl_->free_items.empty()) return make_error(fmt::format("engine full: {} items", impl_->opt.max_items));
    id = impl_->free_items.back();
    impl_->free_items.pop_back();
    impl_->api_item_plc[id] = plc;
    Command c;
    c.kind = Command::Kind::kAddItem;
    c.id = id;
    c.plc = plc;
    c.item_cfg = item;
    impl_->commands.push_back(std::move(c));
  }
  impl_->wake();
  return id;
}

void Engine::remove_item(ItemId item) {
  {
    std::lock_guard lock(impl_->mu);
    if (item >= impl_->api_item_plc.size() || impl_->api_item_plc[item] == kNoId) return;
    impl_->api_item_plc[item] = kNoId;
    impl_->free_items.push_back(item);
    Command c;
    c.kind = Command::Kind::kRemoveItem;
    c.id = item;
    impl_->commands.push_back(std::move(c));
  }
  impl_->wake();
}

bool Engine::try_read(ItemId item, Sample& out) const {
  if (item >= impl_->opt.max_items) return false;
  return impl_->samples[item].try_load(out);
}

Sample Engine::read(ItemId item) const {
  Sample s;
  if (!try_read(item, s)) return Sample{};  // quality bad
  return s;
}

namespace {
WriteTicket queue_write(Engine::Impl& im, const WriteCmd& cmd) {
  if (cmd.item >= im.opt.max_items) {
    im.writes_rejected.fetch_add(1, std::memory_order_relaxed);
    return WriteTicket{};
  }
  uint64_t ticket = 0;
  const bool ok = im.write_queue.push(cmd, [&](uint64_t pos) {
    ticket = pos + 1;
    im.write_status[ticket & im.write_status_mask].store(ticket << 16 | static_cast<uint64_t>(WriteState::kPending),
                                                         std::memory_order_relaxed);
  });
  if (!ok) {
    im.writes_rejected.fetch_add(1, std::memory_order_relaxed);
    return WriteTicket{};
  }
  im.writes_queued.fetch_add(1, std::memory_order_relaxed);
  return WriteTicket{ticket};
}
}  // namespace

WriteTicket Engine::write(ItemId item, double value) {
  WriteCmd c;
  c.item = item;
  c.is_value = true;
  c.value = value;
  return queue_write(*impl_, c);
}

WriteTicket Engine::write_raw(ItemId item, uint64_t raw) {
  WriteCmd c;
  c.item = item;
  c.raw = raw;
  return queue_write(*impl_, c);
}

WriteResult Engine::write_result(WriteTicket t) const {
  if (t.id == 0) return WriteResult{WriteState::kRejected, 0};
  const uint64_t e = impl_->write_status[t.id & impl_->write_status_mask].load(std::memory_order_acquire);
  if ((e >> 16) != t.id) return WriteResult{};
  return WriteResult{static_cast<WriteState>(e & 0xFF), static_cast<uint8_t>((e >> 8) & 0xFF)};
}

bool Engine::try_status(PlcId plc, PlcStatus& out) const {
  if (plc >= impl_->opt.max_plcs) return false;
  return impl_->statuses[plc].try_load(out);
}

PlcStatus Engine::status(PlcId plc) const {
  PlcStatus st;
  if (!try_status(plc, st)) return PlcStatus{};
  return st;
}

EngineCounters Engine::counters() const {
  EngineCounters c;
  c.writes_queued = impl_->writes_queued.load(std::memory_order_relaxed);
  c.writes_rejected = impl_->writes_rejected.load(std::memory_order_relaxed);
  c.writes_acked = impl_->writes_acked.load(std::memory_order_relaxed);
  c.writes_failed = impl_->writes_failed.load(std::memory_order_relaxed);
  c.loop_wakeups = impl_->wakeups.load(std::memory_order_relaxed);
  return c;
}

}  // namespace rtplc::s7
