// The S7 engine's event loop and per-PLC state machine (spec: s7-client.md, "The
// engine we want"; issue 4, items 2-3). Everything here runs on the engine thread.
//
// One iteration: wait in epoll until the earliest PLC deadline (or the write pickup
// period), handle socket events, apply setup commands, take queued writes, fire due
// timers. Every PLC has exactly one entry in the timer heap, at the earliest of its
// deadlines, so the loop's cost grows with the work to do, not with the PLC count.
#include <sys/epoll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

#include "io/drivers/s7/engine_impl.h"
#include "kernel_rt/clock.h"
#include "io/drivers/s7/transfer.h"

namespace rtplc::s7 {
namespace {

constexpr int64_t kMs = 1'000'000;
// Timers due within this much are fired together: one wakeup instead of several.
constexpr int64_t kTimerSlackNs = 200'000;
constexpr int64_t kPublishEveryNs = 250 * kMs;

uint64_t key_of(uint32_t idx, uint32_t gen) { return static_cast<uint64_t>(gen) << 32 | idx; }

}  // namespace

uint64_t Engine::Impl::random() {
  // xorshift64: backoff jitter needs spread, not quality.
  rng ^= rng << 13;
  rng ^= rng >> 7;
  rng ^= rng << 17;
  return rng;
}

int64_t Engine::Impl::backoff_ns(Plc& p) {
  return link::backoff_delay_ns(p.failures, static_cast<int64_t>(p.cfg.backoff_min_ms) * kMs,
                                static_cast<int64_t>(p.cfg.backoff_max_ms) * kMs,
                                static_cast<uint64_t>(random()));
}

void Engine::Impl::set_error(Plc& p, std::string_view msg) {
  const size_t n = std::min(msg.size(), sizeof(p.st.last_error) - 1);
  std::memcpy(p.st.last_error, msg.data(), n);
  p.st.last_error[n] = '\0';
}

void Engine::Impl::poll_once(int max_wait_ms) {
  int64_t now = Engine::now_ns();
  int64_t until = std::min<int64_t>(timers.next_deadline(), now + static_cast<int64_t>(opt.write_pickup_us) * 1000);
  until = std::min<int64_t>(until, now + static_cast<int64_t>(max_wait_ms) * kMs);
  std::array<epoll_event, 256> events;
  int n = 0;
  const int64_t coalesce = static_cast<int64_t>(opt.coalesce_us) * 1000;
  if (coalesce > 0 && now - last_activity_ns < 100 * kMs) {
    // Busy: sleep without waiting in epoll, so arriving replies do not wake the
    // thread one at a time, then take everything that is ready.
    const int64_t at = std::min(until, now + coalesce);
    if (at > now) {
      kernel_rt::sleep_until_ns(at);
    }
    n = ::epoll_wait(epoll_fd.get(), events.data(), static_cast<int>(events.size()), 0);
  } else {
    const int64_t wait = std::max<int64_t>(0, until - now);
    timespec ts{static_cast<time_t>(wait / 1'000'000'000), static_cast<long>(wait % 1'000'000'000)};
    n = ::epoll_pwait2(epoll_fd.get(), events.data(), static_cast<int>(events.size()), &ts, nullptr);
    if (n < 0 && errno == ENOSYS) {
      n = ::epoll_wait(epoll_fd.get(), events.data(), static_cast<int>(events.size()),
                       static_cast<int>((wait + kMs - 1) / kMs));
    }
  }
  wakeups.fetch_add(1, std::memory_order_relaxed);
  now = Engine::now_ns();
  if (n > 0) last_activity_ns = now;
  bool commands_due = false;
  for (int i = 0; i < n; ++i) {
    const uint64_t key = events[static_cast<size_t>(i)].data.u64;
    if (key == UINT64_MAX) {
      uint64_t v = 0;
      [[maybe_unused]] const ssize_t r = ::read(wake_fd.get(), &v, sizeof v);
      commands_due = true;
      continue;
    }
    const auto idx = static_cast<uint32_t>(key & 0xFFFFFFFF);
    if (idx >= plcs.size() || plcs[idx].gen != static_cast<uint32_t>(key >> 32)) continue;
    handle_io(idx, events[static_cast<size_t>(i)].events, now);
  }
  if (commands_due) process_commands(now);
  drain_writes(now);
  // Every fire() moves the PLC's deadline past `now + slack`; the bound only guards
  // against a bug turning that into a livelock.
  for (size_t n_fired = 0; n_fired < 4 * plcs.size() + 16; ++n_fired) {
    if (timers.empty() || timers.next_deadline() > now + kTimerSlackNs) break;
    fire(timers.top(), now);
  }
}

// --- setup commands ------------------------------------------------------------

void Engine::Impl::process_commands(int64_t now) {
  {
    std::lock_guard lock(mu);
    taken.swap(commands);
  }
  for (Command& c : taken) {
    switch (c.kind) {
      case Command::Kind::kAddPlc: {
        Plc& p = plcs[c.id];
        const uint32_t gen = p.gen + 1;
        p = Plc{};
        p.gen = gen;
        p.cfg = c.plc_cfg;
        p.endpoint = c.endpoint;
        p.conn = Connection(p.cfg.connection);
        p.state = PlcState::kIdle;
        p.state_deadline = now;  // connect at once
        p.offline_since = now;
        p.st.state = PlcState::kIdle;
        publish(p, c.id, now, true);
        reschedule(p, c.id);
        break;
      }
      case Command::Kind::kRemovePlc:
        if (plcs[c.id].state != PlcState::kUnused) remove_plc(plcs[c.id], c.id, now);
        break;
      case Command::Kind::kAddItem: {
        Plc& p = plcs[c.plc];
        if (p.state == PlcState::kUnused) break;
        items[c.id] = ItemState{true, c.plc, c.item_cfg};
        p.items.push_back(c.id);
        p.plan_dirty = true;
        Sample s;
        s.max_age_ns = 3 * static_cast<int64_t>(p.cfg.poll_period_ms) * kMs;
        samples[c.id].store(s);
        if (p.state == PlcState::kReady && p.next_poll == TimerHeap::kNever) p.next_poll = now;
        reschedule(p, c.plc);
        break;
      }
      case Command::Kind::kRemoveItem: {
        ItemState& it = items[c.id];
        if (!it.used) break;
        Plc& p = plcs[it.plc];
        p.items.erase(std::remove(p.items.begin(), p.items.end(), c.id), p.items.end());
        p.plan_dirty = true;
        it = ItemState{};
        samples[c.id].store(Sample{});
        break;
      }
    }
  }
  taken.clear();
}

void Engine::Impl::remove_plc(Plc& p, uint32_t idx, int64_t now) {
  for (Outstanding& o : p.out) {
    if (o.used && o.is_write) {
      for (const PendingWrite& w : o.writes) finish_write(w, WriteState::kFailed, 0, &p);
    }
  }
  for (const PendingWrite& w : p.pending) finish_write(w, WriteState::kFailed, 0, &p);
  for (ItemId id : p.items) {
    items[id] = ItemState{};
    samples[id].store(Sample{});
  }
  const uint32_t gen = p.gen + 1;
  p = Plc{};
  p.gen = gen;
  timers.cancel(idx);
  publish(p, idx, now, true);
}

// --- writes ---------------------------------------------------------------------

void Engine::Impl::finish_write(const PendingWrite& w, WriteState s, uint8_t rc, Plc* p) {
  set_write_status(w.ticket, s, rc);
  if (s == WriteState::kAcknowledged) {
    writes_acked.fetch_add(1, std::memory_order_relaxed);
    if (p != nullptr) ++p->st.writes_acked;
  } else {
    writes_failed.fetch_add(1, std::memory_order_relaxed);
    if (p != nullptr) ++p->st.writes_failed;
  }
}

void Engine::Impl::drain_writes(int64_t now) {
  WriteCmd cmd;
  uint32_t touched = kNoId;
  while (write_queue.pop(cmd)) {
    PendingWrite w;
    w.item = cmd.item;
    // The ticket is the queue position + 1, and the one consumer takes positions in
    // order, so counting pops recovers it without storing it in the cell.
    w.ticket = ++popped_writes;
    const ItemState& it = items[cmd.item];
    if (!it.used || plcs[it.plc].state == PlcState::kUnused) {
      finish_write(w, WriteState::kFailed, 0, nullptr);
      continue;
    }
    const DataType t = it.cfg.address.type;
    Plc& p = plcs[it.plc];
    w.raw = cmd.raw;
    // A value the item cannot hold fails here, never clamped or wrapped: a PLC
    // holding 32767 (or -25536) where the task meant 40000 would look delivered.
    if (cmd.is_value && !value_to_raw(t, (cmd.value - it.cfg.offset) / it.cfg.scale, w.raw)) {
      finish_write(w, WriteState::kFailed, 0, &p);
      ++p.st.errors;
      set_error(p, fmt::format("write of {} refused: out of range for {} ({})", cmd.value, type_name(t),
                               range_text(t)));
      continue;
    }
    w.expires_ns = now + static_cast<int64_t>(p.cfg.write_timeout_ms) * kMs;
    p.pending.push_back(w);
    if (touched != it.plc && touched != kNoId) {
      pump(plcs[touched], now);
      flush(plcs[touched], touched, now);
      reschedule(plcs[touched], touched);
    }
    touched = it.plc;
  }
  if (touched != kNoId) {
    pump(plcs[touched], now);
    flush(plcs[touched], touched, now);
    reschedule(plcs[touched], touched);
  }
}

// --- timers ----------------------------------------------------------------------

void Engine::Impl::reschedule(Plc& p, uint32_t idx) {
  int64_t d = TimerHeap::kNever;
  switch (p.state) {
    case PlcState::kUnused:
      timers.cancel(idx);
      return;
    case PlcState::kIdle:
    case PlcState::kProbing:
    case PlcState::kHandshake:
      d = p.state_deadline;
      break;
    case PlcState::kReady:
      d = p.next_poll;
      for (const Outstanding& o : p.out) {
        if (o.used) d = std::min(d, o.deadline_ns);
      }
      break;
  }
  if (!p.pending.empty()) d = std::min(d, p.pending.front().expires_ns);
  timers.schedule(idx, d);
}

void Engine::Impl::fire(uint32_t idx, int64_t now) {
  Plc& p = plcs[idx];
  const int64_t due = now + kTimerSlackNs;
  while (!p.pending.empty() && p.pending.front().expires_ns <= due) {
    finish_write(p.pending.front(), WriteState::kFailed, 0, &p);
    set_error(p, "write not sent within the write timeout (PLC not connected)");
    p.pending.pop_front();
  }
  switch (p.state) {
    case PlcState::kUnused:
      break;
    case PlcState::kIdle:
      if (p.state_deadline <= due) start_probe(p, idx, now);
      break;
    case PlcState::kProbing:
      if (p.state_deadline <= due) {
        lost(p, idx,
             fmt::format("no answer to TCP connect within {} ms (unreachable or blackholed)", p.cfg.probe_timeout_ms),
             now, true);
      }
      break;
    case PlcState::kHandshake:
      if (p.state_deadline <= due) {
        lost(p, idx, fmt::format("no S7 handshake within {} ms", p.cfg.handshake_timeout_ms), now, true);
      }
      break;
    case PlcState::kReady: {
      for (const Outstanding& o : p.out) {
        if (o.used && o.deadline_ns <= due) {
          ++p.st.timeouts;
          lost(p, idx, fmt::format("no reply within {} ms", p.cfg.reply_timeout_ms), now, false);
          break;
        }
      }
      if (p.state == PlcState::kReady && p.next_poll <= due) tick(p, now);
      if (p.state == PlcState::kReady) {
        pump(p, now);
        flush(p, idx, now);
      }
      break;
    }
  }
  publish(p, idx, now, false);
  reschedule(p, idx);
}

// --- connection -----------------------------------------------------------------

void Engine::Impl::start_probe(Plc& p, uint32_t idx, int64_t now) {
  auto fd = start_connect(p.endpoint);
  if (!fd) {
    lost(p, idx, fd.error(), now, true);
    return;
  }
  p.fd = std::move(*fd);
  epoll_event ev{};
  ev.events = EPOLLOUT;
  ev.data.u64 = key_of(idx, p.gen);
  if (::epoll_ctl(epoll_fd.get(), EPOLL_CTL_ADD, p.fd.get(), &ev) != 0) {
    lost(p, idx, fmt::format("epoll_ctl: {}", errno_text(errno)), now, true);
    return;
  }
  p.want_out = true;
  p.state = PlcState::kProbing;
  p.st.state = p.state;
  p.state_deadline = now + static_cast<int64_t>(p.cfg.probe_timeout_ms) * kMs;
  publish(p, idx, now, true);
}

void Engine::Impl::lost(Plc& p, uint32_t idx, std::string_view why, int64_t now, bool connect_failure) {
  p.fd.reset();  // closing removes it from the epoll set
  p.want_out = false;
  p.dropped_before += p.conn.dropped_replies();
  p.conn.reset();
  for (Outstanding& o : p.out) {
    if (o.used && o.is_write) {
      // Sent but unacknowledged: the PLC may or may not have applied it; say failed
      // rather than guess, so the caller can re-issue it.
      for (const PendingWrite& w : o.writes) finish_write(w, WriteState::kFailed, 0, &p);
    }
    o.used = false;
    o.writes.clear();
  }
  for (Cycle& c : p.cycles) c.active = false;
  p.next_request = p.cycle_requests = 0;
  if (p.state == PlcState::kReady) {
    ++p.st.reconnects;
    p.offline_since = now;
    mark_items_bad(p, 0);
  }
  if (connect_failure) ++p.st.connect_failures;
  ++p.failures;
  p.state = PlcState::kIdle;
  p.st.state = p.state;
  p.next_poll = TimerHeap::kNever;
  p.state_deadline = now + backoff_ns(p);
  set_error(p, why);
  publish(p, idx, now, true);
  reschedule(p, idx);
}

void Engine::Impl::mark_items_bad(const Plc& p, uint8_t rc) {
  for (ItemId id : p.items) {
    Sample s = samples[id].writer_value();
    s.quality = Quality::kBad;
    s.return_code = rc;
    samples[id].store(s);
  }
}

void Engine::Impl::handle_io(uint32_t idx, uint32_t events, int64_t now) {
  Plc& p = plcs[idx];
  if (p.state == PlcState::kProbing) {
    const int err = connect_error(p.fd.get());
    if (err != 0) {
      lost(p, idx, fmt::format("TCP connect: {}", errno_text(err)), now, true);
      return;
    }
    p.state = PlcState::kHandshake;
    p.st.state = p.state;
    p.state_deadline = now + static_cast<int64_t>(p.cfg.handshake_timeout_ms) * kMs;
    p.conn.open();
    flush(p, idx, now);
    reschedule(p, idx);
    return;
  }
  if (p.state != PlcState::kHandshake && p.state != PlcState::kReady) return;
  if ((events & EPOLLIN) != 0) {
    std::array<uint8_t, 16384> buf;
    const ssize_t n = ::recv(p.fd.get(), buf.data(), buf.size(), 0);
    if (n == 0) {
      lost(p, idx, "the PLC closed the connection", now, p.state != PlcState::kReady);
      return;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) {
      lost(p, idx, fmt::format("recv: {}", errno_text(errno)), now, p.state != PlcState::kReady);
      return;
    }
    if (n > 0) p.conn.feed(ByteSpan(buf.data(), static_cast<size_t>(n)));
    Connection::Reply reply;
    while (true) {
      const Connection::Event e = p.conn.next_event(reply);
      if (e == Connection::Event::kNone) break;
      if (e == Connection::Event::kFailed) {
        ++p.st.errors;
        lost(p, idx, p.conn.error(), now, p.state != PlcState::kReady);
        return;
      }
      if (e == Connection::Event::kReady) {
        on_ready(p, now);
        publish(p, idx, now, true);
      }
      if (e == Connection::Event::kReply) {
        on_reply(p, reply, now);
        if (p.state != PlcState::kReady) return;  // a malformed reply dropped the connection
      }
    }
  } else if ((events & (EPOLLERR | EPOLLHUP)) != 0) {
    const int err = connect_error(p.fd.get());
    lost(p, idx, fmt::format("connection error: {}", errno_text(err != 0 ? err : ECONNRESET)), now,
         p.state != PlcState::kReady);
    return;
  }
  if (p.state == PlcState::kReady) pump(p, now);
  flush(p, idx, now);
  if (p.state != PlcState::kUnused) {
    publish(p, idx, now, false);
    reschedule(p, idx);
  }
}

void Engine::Impl::flush(Plc& p, uint32_t idx, int64_t now) {
  if (!p.fd.valid()) return;
  while (!p.conn.outbox().empty()) {
    ByteSpan out = p.conn.outbox();
    const ssize_t n = ::send(p.fd.get(), out.data(), out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      p.conn.consume_outbox(static_cast<size_t>(n));
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    if (n < 0 && errno == EINTR) continue;
    lost(p, idx, fmt::format("send: {}", errno_text(errno)), now, p.state != PlcState::kReady);
    return;
  }
  const bool want = !p.conn.outbox().empty();
  if (want != p.want_out || p.state == PlcState::kHandshake) {
    epoll_event ev{};
    ev.events = EPOLLIN | (want ? EPOLLOUT : 0u);
    ev.data.u64 = key_of(idx, p.gen);
    ::epoll_ctl(epoll_fd.get(), EPOLL_CTL_MOD, p.fd.get(), &ev);
    p.want_out = want;
  }
}

void Engine::Impl::on_ready(Plc& p, int64_t now) {
  p.state = PlcState::kReady;
  p.st.state = p.state;
  p.failures = 0;
  p.was_ready = true;
  ++p.st.connects;
  p.st.pdu_size = p.conn.negotiated().pdu_size;
  p.st.amq = static_cast<uint16_t>(p.conn.max_in_flight());
  const int64_t period = static_cast<int64_t>(p.cfg.poll_period_ms) * kMs;
  if (p.offline_since != 0) p.st.polls_offline += static_cast<uint64_t>((now - p.offline_since) / period);
  p.offline_since = 0;
  p.plan_dirty = true;
  // A random phase spreads the polls of PLCs that connected together; phases sit on
  // a 1 ms grid so that PLCs sharing a slot are served by one wakeup (a thousand
  // PLCs at 100 ms share each slot ten at a time) instead of one wakeup each.
  const int64_t slots = std::max<int64_t>(1, period / kMs);
  const int64_t grid = (now / kMs + 1) * kMs;
  p.next_poll = grid + static_cast<int64_t>(random() % static_cast<uint64_t>(slots)) * kMs;
  p.st.last_error[0] = '\0';
}

void Engine::Impl::replan(Plc& p) {
  p.plan_items = p.items;
  p.plan_addrs.clear();
  for (ItemId id : p.plan_items) p.plan_addrs.push_back(items[id].cfg.address);
  PlanLimits lim;
  lim.pdu = p.conn.negotiated().pdu_size;
  lim.merge_gap = p.cfg.merge_gap;
  auto plan = plan_reads(p.plan_addrs, lim);
  if (plan) {
    p.plan = std::move(*plan);
  } else {
    p.plan = ReadPlan{};
    p.plan_items.clear();
    set_error(p, plan.error());
  }
  p.frames = encode_read_frames(p.plan);
  ++p.plan_gen;
  p.plan_dirty = false;
  p.st.items = static_cast<uint32_t>(p.plan_items.size());
  p.st.requests_per_poll = static_cast<uint32_t>(p.plan.requests.size());
}

void Engine::Impl::tick(Plc& p, int64_t now) {
  const int64_t period = static_cast<int64_t>(p.cfg.poll_period_ms) * kMs;
  const int64_t t = p.next_poll;
  p.next_poll += period;
  if (p.next_poll + period <= now) {
    // The loop itself fell behind by whole periods (machine stalled): count them.
    const int64_t behind = (now - p.next_poll) / period;
    p.st.polls_missed += static_cast<uint64_t>(behind);
    p.next_poll += behind * period;
  }
  const bool unsent = p.next_request < p.cycle_requests;
  if (p.plan_dirty && !unsent) replan(p);
  if (p.frames.empty()) return;
  Cycle& next = p.cycles[(p.cycle_seq + 1) % Plc::kCycles];
  if (unsent || next.active) {
    ++p.st.polls_missed;
    return;
  }
  ++p.cycle_seq;
  next = Cycle{true, static_cast<uint32_t>(p.frames.size()), t};
  p.next_request = 0;
  p.cycle_requests = static_cast<uint32_t>(p.frames.size());
  ++p.st.polls_started;
}

void Engine::Impl::pump(Plc& p, int64_t now) {
  while (p.conn.can_send()) {
    size_t slot = 0;
    while (slot < p.out.size() && p.out[slot].used) ++slot;
    if (slot == p.out.size()) return;
    Outstanding& o = p.out[slot];
    const int64_t deadline = now + static_cast<int64_t>(p.cfg.reply_timeout_ms) * kMs;
    if (!p.pending.empty()) {
      // Writes go before polls: they are rarer and someone waits for each.
      std::array<ItemAddress, kMaxItemsPerPdu> addrs{};
      std::array<uint64_t, kMaxItemsPerPdu> raws{};
      const size_t n = std::min(p.pending.size(), kMaxItemsPerPdu);
      for (size_t i = 0; i < n; ++i) {
        addrs[i] = items[p.pending[i].item].cfg.address;
        raws[i] = p.pending[i].raw;
      }
      PlanLimits lim;
      lim.pdu = p.conn.negotiated().pdu_size;
      auto groups = plan_writes(std::span<const ItemAddress>(addrs.data(), n), lim);
      if (!groups || groups->empty()) return;
      const PlannedWrite& g = groups->front();
      frame.clear();
      encode_write_frame(frame, std::span<const ItemAddress>(addrs.data(), n), std::span<const uint64_t>(raws.data(), n),
                         g.items);
      auto ref = p.conn.send_job(static_cast<uint32_t>(slot), frame);
      if (!ref) return;
      o.used = true;
      o.is_write = true;
      o.ref = *ref;
      o.sent_ns = now;
      o.deadline_ns = deadline;
      o.writes.assign(p.pending.begin(), p.pending.begin() + static_cast<std::ptrdiff_t>(g.items.size()));
      p.pending.erase(p.pending.begin(), p.pending.begin() + static_cast<std::ptrdiff_t>(g.items.size()));
      continue;
    }
    if (p.next_request >= p.cycle_requests) return;
    const uint32_t r = p.next_request;
    auto ref = p.conn.send_job(static_cast<uint32_t>(slot), p.frames[r]);
    if (!ref) return;
    ++p.next_request;
    o.used = true;
    o.is_write = false;
    o.ref = *ref;
    o.request = r;
    o.plan_gen = p.plan_gen;
    o.cycle = p.cycle_seq;
    o.sent_ns = now;
    o.deadline_ns = deadline;
  }
}

void Engine::Impl::publish_item(ItemId id, const ItemResult& r, int64_t now, int64_t period_ns) {
  Sample s = samples[id].writer_value();
  s.return_code = r.return_code;
  s.max_age_ns = 3 * period_ns;
  if (r.ok()) {
    const ItemConfig& cfg = items[id].cfg;
    s.raw = r.raw;
    s.value = raw_to_double(cfg.address.type, r.raw) * cfg.scale + cfg.offset;
    s.timestamp_ns = now;
    s.quality = Quality::kGood;
  } else {
    s.quality = Quality::kBad;
  }
  samples[id].store(s);
}

void Engine::Impl::on_reply(Plc& p, const Connection::Reply& r, int64_t now) {
  if (r.cookie >= p.out.size() || !p.out[r.cookie].used) return;
  Outstanding& o = p.out[r.cookie];
  p.rtt.record(static_cast<uint64_t>((now - o.sent_ns) / 1000));
  p.st.rtt_buckets.record(static_cast<uint64_t>((now - o.sent_ns) / 1000));
  const uint32_t idx = static_cast<uint32_t>(&p - plcs.data());
  if (o.is_write) {
    auto ok = parse_write_reply(r.header, o.writes.size(), codes);
    if (!ok) {
      ++p.st.errors;
      set_error(p, ok.error());
      for (const PendingWrite& w : o.writes) finish_write(w, WriteState::kFailed, 0, &p);
      o.writes.clear();
      o.used = false;
      if (r.header.error() == 0) lost(p, idx, fmt::format("malformed write reply: {}", ok.error()), now, false);
      return;
    }
    for (size_t i = 0; i < o.writes.size(); ++i) {
      const bool acked = codes[i] == kItemOk;
      if (!acked) {
        ++p.st.errors;
        set_error(p, fmt::format("write refused: {}", item_error_message(codes[i])));
      }
      finish_write(o.writes[i], acked ? WriteState::kAcknowledged : WriteState::kFailed, codes[i], &p);
    }
    o.writes.clear();
    o.used = false;
    return;
  }
  const int64_t period = static_cast<int64_t>(p.cfg.poll_period_ms) * kMs;
  const uint32_t cycle = o.cycle;
  const uint32_t request = o.request;
  const bool current = o.plan_gen == p.plan_gen;
  o.used = false;
  if (current) {
    if (r.header.error() != 0) {
      ++p.st.errors;
      set_error(p, header_error_message(r.header.error()));
      for (uint32_t i : p.plan.requests[request].items) {
        if (items[p.plan_items[i]].used) publish_item(p.plan_items[i], ItemResult{0, 0}, now, period);
      }
    } else {
      bool item_error = false;
      auto ok = apply_read_reply(p.plan, p.plan_addrs, request, r.header, scratch,
                                 [&](uint32_t i, const ItemResult& res) {
                                   const ItemId id = p.plan_items[i];
                                   if (!items[id].used || items[id].plc != idx) return;
                                   if (!res.ok()) item_error = true;
                                   publish_item(id, res, now, period);
                                 });
      if (!ok) {
        ++p.st.errors;
        lost(p, idx, fmt::format("malformed reply: {}", ok.error()), now, false);
        return;
      }
      if (item_error) {
        ++p.st.errors;
        set_error(p, "an item was refused by the PLC (see its return code)");
      }
    }
  }
  Cycle& c = p.cycles[cycle % Plc::kCycles];
  if (c.active && c.remaining > 0 && --c.remaining == 0) {
    c.active = false;
    ++p.st.polls_completed;
    if (opt.on_poll_complete) opt.on_poll_complete(idx, now - c.tick_ns);
  }
}

void Engine::Impl::publish(Plc& p, uint32_t idx, int64_t now, bool force) {
  if (!force && now - p.last_publish < kPublishEveryNs) return;
  p.last_publish = now;
  p.st.state = p.state;
  p.st.dropped_replies = p.dropped_before + p.conn.dropped_replies();
  p.st.rtt_p50_us = static_cast<uint32_t>(p.rtt.quantile(0.50));
  p.st.rtt_p99_us = static_cast<uint32_t>(p.rtt.quantile(0.99));
  p.st.rtt_max_us = static_cast<uint32_t>(p.rtt.max());
  p.st.rtt_count = p.rtt.count();
  uint32_t pending = static_cast<uint32_t>(p.pending.size());
  for (const Outstanding& o : p.out) {
    if (o.used && o.is_write) pending += static_cast<uint32_t>(o.writes.size());
  }
  p.st.writes_pending = pending;
  statuses[idx].store(p.st);
}

}  // namespace rtplc::s7
