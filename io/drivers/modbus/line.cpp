// A Modbus line's I/O thread (see line.h).
#include "io/drivers/modbus/line.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <utility>

#include "io/link/backoff.h"
#include "kernel_rt/clock.h"

namespace rtplc::modbus {
namespace {

constexpr int64_t kConnectBackoffMinNs = 100'000'000;
constexpr int64_t kConnectBackoffMaxNs = 5'000'000'000;
constexpr int64_t kQuietMaxNs = 5'000'000'000;  // an RTU unit that does not answer: polled at least this often
constexpr uint32_t kTimeoutsBeforeReconnect = 3;
constexpr int64_t kQuantilesEveryNs = 50'000'000;

int64_t to_ns(double s) { return static_cast<int64_t>(s * 1e9); }

}  // namespace

Line::Line(const ModbusSettings& s, std::vector<uint32_t> slaves, Exchange& x, LineOptions opt)
    : s_(s), x_(x), opt_(std::move(opt)), queue_(256) {
  for (uint32_t slave : slaves) {
    Unit u;
    u.slave = slave;
    u.cfg = &s.slaves[slave];
    // Unplanned: one group per poll period. On a plan: one group per loop (its
    // period from the plan) and one for the non-RT items.
    std::map<std::pair<ChannelMap::Traffic, std::string>, std::vector<PlannedItem>> groups;
    for (uint32_t i = 0; i < s.reads.size(); ++i) {
      const ChannelMap& m = s.reads[i];
      if (m.slave != u.cfg->name) continue;
      int64_t period = to_ns(m.poll_s > 0 ? m.poll_s : u.cfg->poll_s);
      if (m.traffic == ChannelMap::Traffic::kPeriodic && u.cfg->plan) {
        if (const fieldbus::LoopPlan* l = u.cfg->plan->loop(m.loop)) period = l->period;
      }
      groups[{m.traffic, m.loop}].push_back({m.item, period, static_cast<uint32_t>(u.reads.size())});
      u.reads.push_back({i, 0});
    }
    for (auto& [key, items] : groups) {
      for (Block& b : plan_blocks(items, u.cfg->max_registers, u.cfg->max_bits)) {
        for (uint32_t& i : b.items) i = items[i].id;  // the group's index -> the unit's read
        UnitBlock ub{std::move(b), 0, false};
        ub.traffic = key.first;
        u.blocks.push_back(std::move(ub));
      }
    }
    units_.push_back(std::move(u));
  }
  const SlaveConfig& first = *units_.front().cfg;
  name_ = first.rtu() ? first.device : first.name;
  random_ ^= static_cast<uint64_t>(slaves.front()) * 0x2545F4914F6CDD1Dull;
  if (first.plan) plan_line(*first.plan);
}

// ---- on a plan ----------------------------------------------------------------

namespace {

int data_bytes(const Block& b) {
  const bool bits = b.table == Table::kCoil || b.table == Table::kDiscreteInput;
  return bits ? (b.count + 7) / 8 : 2 * b.count;
}

}  // namespace

void Line::plan_line(const fieldbus::LinkPlan& lp) {
  timing_ = &*lp.design.timing;
  fieldbus::SchedulerSetup ss;
  ss.t1 = lp.plan.t1;
  ss.ln = lp.plan.ln_max;
  for (uint32_t ui = 0; ui < units_.size(); ++ui) {
    Unit& u = units_[ui];
    for (uint32_t bi = 0; bi < u.blocks.size(); ++bi) {
      const UnitBlock& ub = u.blocks[bi];
      if (ub.traffic == ChannelMap::Traffic::kNonRt) {
        nonrt_.push_back({ui, bi});
        continue;
      }
      const ChannelMap& m = s_.reads[u.reads[ub.block.items.front()].map];
      const fieldbus::LoopPlan* loop = lp.loop(m.loop);
      if (!loop) continue;  // the config refused it
      const int64_t frames = int64_t{1} << loop->shift;
      periodic_.push_back({ui, bi});
      ss.periodic.push_back({frames, std::max<int64_t>(loop->offset, 0) % frames, timing_->packet(data_bytes(ub.block))});
    }
  }
  write_slot_.assign(s_.writes.size(), -1);
  for (uint32_t j = 0; j < s_.writes.size(); ++j) {
    const ChannelMap& m = s_.writes[j];
    for (const Unit& u : units_) {
      if (u.cfg->name != m.slave) continue;
      write_slot_[j] = static_cast<int32_t>(ss.urgent.size());
      ss.urgent.push_back(timing_->packet(m.item.type == ItemType::kBit ? 1 : 2 * width(m.item)));
    }
  }
  pending_.assign(ss.urgent.size(), WriteJob{});
  pending_set_.assign(ss.urgent.size(), 0);
  sched_ = std::make_unique<fieldbus::LinkScheduler>(std::move(ss), &kernel_rt::monotonic_now_ns);
}

void Line::run_planned() noexcept {
  const int64_t t1 = sched_->t1();
  epoch_ = (kernel_rt::monotonic_now_ns() / t1 + 1) * t1;  // T_1 frames on the clock's multiples of T_1
  sched_->start(epoch_);
  while (!stop_.load(std::memory_order_relaxed)) {
    const int64_t now = kernel_rt::monotonic_now_ns();
    int64_t wake = now + opt_.wake_ns;
    if (ensure_connected(now)) {
      WriteJob job;
      while (queue_.pop(job)) {
        const int32_t slot = write_slot_[job.write];
        if (slot < 0) continue;
        pending_[static_cast<size_t>(slot)] = job;  // the bridge keeps one write per item in flight
        pending_set_[static_cast<size_t>(slot)] = 1;
        sched_->urgent_ready(static_cast<uint32_t>(slot), now);
      }
      if (nonrt_active_ == SIZE_MAX) {
        for (size_t k = 0; k < nonrt_.size(); ++k) {
          UnitBlock& b = units_[nonrt_[k].unit].blocks[nonrt_[k].block];
          if (now < b.next_due) continue;
          const int64_t period = b.block.period_ns;
          b.next_due = (now / period + 1) * period;
          b.cursor = 0;
          nonrt_active_ = k;
          sched_->nonrt_ready(now);
          break;
        }
      }
      sched_->tick(now, *this);
    } else {
      wake = std::min(wake, std::max(next_connect_, now));
    }
    for (Unit& u : units_) publish(u);
    x_.planned[units_.front().slave].store(sched_->figures());
    const int64_t t = kernel_rt::monotonic_now_ns();
    if (t >= epoch_) wake = std::min(wake, epoch_ + ((t - epoch_) / t1 + 1) * t1);
    kernel_rt::sleep_until_ns(wake);
  }
  // Stopping: what the bridge queued last (the tasks' safe values) still goes out.
  if (client_.connected()) {
    WriteJob job;
    while (queue_.pop(job)) write_one(job);
    for (size_t i = 0; i < pending_.size(); ++i) {
      if (pending_set_[i]) write_one(pending_[i]);
    }
  }
  x_.planned[units_.front().slave].store(sched_->figures());
  client_.close();
}

fieldbus::SendOutcome Line::send_periodic(uint32_t slot) noexcept {
  if (!client_.connected()) return fieldbus::SendOutcome::kFailed;
  Unit& u = units_[periodic_[slot].unit];
  UnitBlock& b = u.blocks[periodic_[slot].block];
  const int64_t now = kernel_rt::monotonic_now_ns();
  if (now < u.quiet_until) {
    ++u.st.polls_offline;  // a quiet RTU unit: not asked (counted offline, not a missed window)
    return fieldbus::SendOutcome::kNothing;
  }
  poll_block(u, b, now);
  return fieldbus::SendOutcome::kSent;
}

fieldbus::SendOutcome Line::send_urgent(uint32_t slot) noexcept {
  if (!pending_set_[slot]) return fieldbus::SendOutcome::kNothing;
  if (!client_.connected()) return fieldbus::SendOutcome::kFailed;
  write_one(pending_[slot]);
  pending_set_[slot] = 0;
  return fieldbus::SendOutcome::kSent;
}

fieldbus::Nanos Line::send_nonrt(fieldbus::Nanos budget, bool& more) noexcept {
  more = false;
  if (nonrt_active_ == SIZE_MAX || !client_.connected()) return 0;
  Unit& u = units_[nonrt_[nonrt_active_].unit];
  UnitBlock& b = u.blocks[nonrt_[nonrt_active_].block];
  const std::vector<uint32_t>& items = b.block.items;
  const bool bits = b.block.table == Table::kCoil || b.block.table == Table::kDiscreteInput;
  // As many whole items from the cursor as fit the budget (never one cut in two).
  const uint16_t start = s_.reads[u.reads[items[b.cursor]].map].item.address;
  size_t end = b.cursor;
  uint32_t count = 0;
  while (end < items.size()) {
    const Address& a = s_.reads[u.reads[items[end]].map].item;
    const uint32_t need = std::max<uint32_t>(count, uint32_t{a.address} + (bits ? 1u : width(a)) - start);
    const int bytes = bits ? static_cast<int>((need + 7) / 8) : static_cast<int>(2 * need);
    if (timing_->packet(bytes) > budget || need > (bits ? u.cfg->max_bits : u.cfg->max_registers)) break;
    count = need;
    ++end;
  }
  more = true;
  if (end == b.cursor) return 0;  // not even one item fits what is left of this frame
  const int bytes = bits ? static_cast<int>((count + 7) / 8) : static_cast<int>(2 * count);
  client_.set_unit(u.cfg->unit);
  client_.set_timeout_ns(to_ns(u.cfg->timeout_s));
  uint16_t words[2000];  // MODBUS_MAX_READ_BITS
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  const Outcome o = client_.read(b.block.table, start, static_cast<uint16_t>(count), words);
  record(u, o, t0);
  const int64_t answered = kernel_rt::monotonic_now_ns();
  if (o.ok()) {
    store_items(u, b, b.cursor, end, start, words, answered);
    ++u.st.polls_completed;
  } else {
    for (size_t i = b.cursor; i < end; ++i) {
      Read& r = u.reads[items[i]];
      x_.samples[r.map].store(ItemSample{r.last, answered, 0, static_cast<uint8_t>(o.kind == Outcome::Kind::kException ? o.code : 0)});
    }
  }
  b.cursor = end;
  more = b.cursor < items.size();
  if (!more) nonrt_active_ = SIZE_MAX;
  return timing_->packet(bytes);
}

void Line::store_items(Unit& u, const UnitBlock& b, size_t from, size_t to, uint16_t start, const uint16_t* words,
                       int64_t answered) noexcept {
  for (size_t k = from; k < to; ++k) {
    Read& r = u.reads[b.block.items[k]];
    const ChannelMap& m = s_.reads[r.map];
    const double raw = decode(m.item, words + (m.item.address - start));
    r.last = raw * m.scale + m.offset;
    x_.samples[r.map].store(ItemSample{r.last, answered, 1, 0});
  }
}

Line::~Line() { join(); }

bool Line::serves(uint32_t slave) const {
  for (const Unit& u : units_) {
    if (u.slave == slave) return true;
  }
  return false;
}

Result<void> Line::start() {
  const SlaveConfig& first = *units_.front().cfg;
  auto c = first.rtu() ? Client::rtu({first.device, first.baud, first.parity, first.data_bits, first.stop_bits})
                       : Client::tcp(first.address, first.port);
  if (!c) return make_error(c.error());
  client_ = std::move(*c);
  for (Unit& u : units_) publish(u);
  kernel_rt::ThreadSpec spec;
  spec.name = "mb-" + name_.substr(name_.rfind('/') + 1);
  spec.fifo_priority = opt_.priority;
  if (opt_.cpu >= 0) spec.cpu = static_cast<unsigned>(opt_.cpu);
  auto t = kernel_rt::start_thread(spec, [this] { run(); });
  if (!t) return make_error(fmt::format("modbus line {}: {}", name_, t.error()));
  thread_ = std::move(*t);
  started_ = true;
  return {};
}

void Line::join() {
  if (!started_) return;
  request_stop();
  thread_.join();
  started_ = false;
}

void Line::log(io::LinkEvent::Level level, std::string_view text) noexcept {
  if (opt_.events) opt_.events->push(level, opt_.driver, text);
}

void Line::run() noexcept {
  if (sched_) {
    run_planned();
    return;
  }
  while (!stop_.load(std::memory_order_relaxed)) {
    int64_t now = kernel_rt::monotonic_now_ns();
    int64_t wake = now + opt_.wake_ns;
    if (ensure_connected(now)) {
      serve_writes();
      for (Unit& u : units_) {
        for (UnitBlock& b : u.blocks) {
          if (!client_.connected()) break;
          now = kernel_rt::monotonic_now_ns();
          if (now < b.next_due) continue;
          if (now < u.quiet_until) {
            // A quiet RTU unit: this poll is not made (counted offline).
            ++u.st.polls_offline;
            b.next_due = now + b.block.period_ns;
            continue;
          }
          poll_block(u, b, now);
        }
      }
    } else {
      for (Unit& u : units_) {
        for (UnitBlock& b : u.blocks) {
          if (now < b.next_due) continue;
          ++u.st.polls_offline;
          b.next_due = now + b.block.period_ns;
        }
      }
      wake = std::min(wake, std::max(next_connect_, now));
    }
    for (Unit& u : units_) {
      publish(u);
      for (const UnitBlock& b : u.blocks) wake = std::min(wake, std::max(b.next_due, u.quiet_until));
    }
    kernel_rt::sleep_until_ns(wake);
  }
  // Stopping: what the bridge queued last (the tasks' safe values) still goes out.
  if (client_.connected()) serve_writes();
  client_.close();
}

bool Line::ensure_connected(int64_t now) noexcept {
  if (client_.connected()) return true;
  if (now < next_connect_) return false;
  for (Unit& u : units_) u.st.state = static_cast<uint8_t>(io::LinkState::kConnecting);
  client_.set_timeout_ns(to_ns(units_.front().cfg->timeout_s));
  const Outcome o = client_.connect();
  if (o.ok()) {
    connect_failures_ = 0;
    for (Unit& u : units_) {
      ++u.st.connects;
      if (ever_connected_) ++u.st.reconnects;
      u.failures = 0;
      u.quiet_until = 0;
    }
    if (ever_connected_ || said_unreachable_) {
      log(io::LinkEvent::Level::kInfo,
          fmt::format("slave {} ({}) connected", units_.front().cfg->name, units_.front().cfg->peer()));
    }
    ever_connected_ = true;
    return true;
  }
  ++connect_failures_;
  random_ = random_ * 6364136223846793005ull + 1442695040888963407ull;
  next_connect_ = now + link::backoff_delay_ns(connect_failures_, kConnectBackoffMinNs, kConnectBackoffMaxNs, random_ >> 11);
  for (Unit& u : units_) u.st.state = static_cast<uint8_t>(io::LinkState::kDown);
  if (!ever_connected_ && !said_unreachable_) {
    said_unreachable_ = true;
    log(io::LinkEvent::Level::kError,
        fmt::format("slave {} ({}) unreachable at start: {}; retrying with backoff", units_.front().cfg->name,
                    units_.front().cfg->peer(), outcome_text(o)));
  }
  return false;
}

void Line::drop_connection(int64_t now, const char* why) noexcept {
  client_.close();
  for (Unit& u : units_) {
    for (const UnitBlock& b : u.blocks) mark_bad(u, b, now, 0);
    u.st.state = static_cast<uint8_t>(io::LinkState::kDown);
  }
  random_ = random_ * 6364136223846793005ull + 1442695040888963407ull;
  connect_failures_ = 1;
  next_connect_ = now + link::backoff_delay_ns(1, kConnectBackoffMinNs, kConnectBackoffMaxNs, random_ >> 11);
  log(io::LinkEvent::Level::kWarning,
      fmt::format("slave {} disconnected: {}; its channels are bad until it is back", units_.front().cfg->name, why));
}

void Line::serve_writes() noexcept {
  WriteJob job;
  while (queue_.pop(job)) write_one(job);
}

void Line::write_one(const WriteJob& job) noexcept {
  const ChannelMap& m = s_.writes[job.write];
  WriteOutcome out;
  out.seq = job.seq;
  Unit* u = nullptr;
  for (Unit& cand : units_) {
    if (cand.cfg->name == m.slave) u = &cand;
  }
  if (u && client_.connected()) {
    client_.set_unit(u->cfg->unit);
    client_.set_timeout_ns(to_ns(u->cfg->timeout_s));
    Outcome o;
    for (uint32_t attempt = 0; attempt <= u->cfg->retries; ++attempt) {
      const int64_t t0 = kernel_rt::monotonic_now_ns();
      o = client_.write(m.item, job.words);
      record(*u, o, t0);
      if (o.kind != Outcome::Kind::kTimeout) break;
      client_.flush();
    }
    out.ok = o.ok() ? 1 : 0;
    out.exception = o.kind == Outcome::Kind::kException ? static_cast<uint8_t>(o.code) : 0;
    if (o.kind == Outcome::Kind::kLink) drop_connection(kernel_rt::monotonic_now_ns(), "connection lost on a write");
  }
  x_.outcomes[job.write].store(out);
}

void Line::record(Unit& u, const Outcome& o, int64_t started_ns) noexcept {
  if (o.kind == Outcome::Kind::kTimeout) {
    ++u.st.timeouts;
    return;
  }
  if (o.kind == Outcome::Kind::kLink || o.kind == Outcome::Kind::kProtocol || o.kind == Outcome::Kind::kBadCrc) {
    ++u.st.errors;
    return;
  }
  // An answer (data or an exception): its round trip counts.
  const auto us = static_cast<uint64_t>(std::max<int64_t>(0, kernel_rt::monotonic_now_ns() - started_ns) / 1000);
  u.rtt.record(us);
  u.st.buckets.record(us);
  if (o.kind == Outcome::Kind::kException) ++u.st.errors;
}

void Line::mark_bad(Unit& u, const UnitBlock& b, int64_t now, uint8_t exception) noexcept {
  for (uint32_t i : b.block.items) {
    Read& r = u.reads[i];
    ItemSample smp;
    smp.value = r.last;
    smp.timestamp_ns = now;
    smp.good = 0;
    smp.exception = exception;
    x_.samples[r.map].store(smp);
  }
}

void Line::poll_block(Unit& u, UnitBlock& b, int64_t now) noexcept {
  const int64_t period = b.block.period_ns;
  // The slot this poll stands for: the latest grid point not after now.
  const int64_t due = b.next_due == 0 ? now : b.next_due + ((now - b.next_due) / period) * period;
  if (b.next_due != 0 && now - b.next_due >= period) {
    u.st.polls_missed += static_cast<uint64_t>((now - b.next_due) / period);
  }
  // The next poll on the grid after now (a late poll does not shift the grid).
  // The grid is the clock's own multiples of the period, shared by every line
  // of that period: their threads wake together, once per period, instead of
  // at a hundred scattered instants, each pulling an idle CPU out of its sleep
  // (bench/modbus: a third of the CPU for 100 slaves every 10 ms).
  b.next_due = b.next_due == 0 ? (now / period + 1) * period : b.next_due + ((now - b.next_due) / period + 1) * period;
  client_.set_unit(u.cfg->unit);
  client_.set_timeout_ns(to_ns(u.cfg->timeout_s));
  uint16_t words[2000];  // MODBUS_MAX_READ_BITS
  Outcome o;
  for (uint32_t attempt = 0; attempt <= u.cfg->retries; ++attempt) {
    const int64_t t0 = kernel_rt::monotonic_now_ns();
    o = client_.read(b.block.table, b.block.start, b.block.count, words);
    record(u, o, t0);
    if (o.kind != Outcome::Kind::kTimeout && o.kind != Outcome::Kind::kProtocol && o.kind != Outcome::Kind::kBadCrc) break;
    client_.flush();
  }
  const int64_t answered = kernel_rt::monotonic_now_ns();
  switch (o.kind) {
    case Outcome::Kind::kOk:
      store_items(u, b, 0, b.block.items.size(), b.block.start, words, answered);
      break;
    case Outcome::Kind::kException:
      mark_bad(u, b, answered, static_cast<uint8_t>(o.code));
      if (!b.refusal_logged) {
        b.refusal_logged = true;
        log(io::LinkEvent::Level::kError,
            fmt::format("slave {}: read of {}:{} ({} items) refused: {}", u.cfg->name, table_name(b.block.table),
                        b.block.start, b.block.count, exception_text(o.code)));
      }
      break;
    default:
      mark_bad(u, b, answered, 0);
      break;
  }
  if (o.ok() || o.kind == Outcome::Kind::kException) {
    ++u.st.polls_completed;
    if (opt_.on_poll) opt_.on_poll(u.slave, due, answered);
    if (u.failures > 0 && u.answered) {
      log(io::LinkEvent::Level::kInfo, fmt::format("slave {} ({}) answers again", u.cfg->name, u.cfg->peer()));
      if (u.cfg->rtu()) {
        // An RTU unit has no connection of its own: its coming back counts as
        // its reconnect, so the driver sends its outputs again (it may have
        // restarted with its reset values).
        ++u.st.connects;
        ++u.st.reconnects;
      }
    }
    if (o.ok()) b.refusal_logged = false;
    u.failures = 0;
    u.quiet_until = 0;
    u.answered = true;
    u.st.state = static_cast<uint8_t>(io::LinkState::kUp);
    return;
  }
  ++u.failures;
  u.st.state = static_cast<uint8_t>(io::LinkState::kDown);
  if (u.failures == 1) {
    log(io::LinkEvent::Level::kWarning, fmt::format("slave {} ({}) not answering: {}; its channels are bad until it answers",
                                                    u.cfg->name, u.cfg->peer(), outcome_text(o)));
  }
  if (o.kind == Outcome::Kind::kLink) {
    drop_connection(answered, "connection lost");
  } else if (u.cfg->rtu()) {
    // Quiet for one to two poll periods after the first failure, doubling with
    // each further one up to kQuietMaxNs: every failed poll costs the line a
    // timeout, so from the second poll on a dead unit is polled less often
    // than its period asks, and the live units around it keep their grid.
    random_ = random_ * 6364136223846793005ull + 1442695040888963407ull;
    u.quiet_until =
        answered + link::backoff_delay_ns(u.failures + 1, to_ns(u.cfg->poll_s), kQuietMaxNs, random_ >> 11);
  } else if (u.failures >= kTimeoutsBeforeReconnect) {
    drop_connection(answered, "no answer to several polls");
  }
}

void Line::publish(Unit& u) noexcept {
  if (client_.connected() && u.st.state == static_cast<uint8_t>(io::LinkState::kDown) && u.failures == 0) {
    u.st.state = static_cast<uint8_t>(io::LinkState::kConnecting);
  }
  // The quantiles walk the whole histogram (about 700 buckets, twice):
  // at most every kQuantilesEveryNs, not after every poll; the bridge reads
  // them only every 100 ms anyway.
  const int64_t now = kernel_rt::monotonic_now_ns();
  if (now >= u.quantiles_due) {
    u.quantiles_due = now + kQuantilesEveryNs;
    u.st.rtt_p50_us = static_cast<uint32_t>(u.rtt.quantile(0.5));
    u.st.rtt_p99_us = static_cast<uint32_t>(u.rtt.quantile(0.99));
  }
  u.st.rtt_max_us = static_cast<uint32_t>(u.rtt.max());
  x_.status[u.slave].store(u.st);
}

}  // namespace rtplc::modbus
