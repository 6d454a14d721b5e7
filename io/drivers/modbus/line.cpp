// A Modbus line's I/O thread (see line.h).
#include "io/drivers/modbus/line.h"

#include <fmt/format.h>

#include <algorithm>

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
    std::vector<PlannedItem> planned;
    for (uint32_t i = 0; i < s.reads.size(); ++i) {
      const ChannelMap& m = s.reads[i];
      if (m.slave != u.cfg->name) continue;
      planned.push_back({m.item, to_ns(m.poll_s > 0 ? m.poll_s : u.cfg->poll_s), static_cast<uint32_t>(u.reads.size())});
      u.reads.push_back({i, 0});
    }
    for (Block& b : plan_blocks(planned, u.cfg->max_registers, u.cfg->max_bits)) {
      u.blocks.push_back(UnitBlock{std::move(b), 0, false});
    }
    units_.push_back(std::move(u));
  }
  const SlaveConfig& first = *units_.front().cfg;
  name_ = first.rtu() ? first.device : first.name;
  random_ ^= static_cast<uint64_t>(slaves.front()) * 0x2545F4914F6CDD1Dull;
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
  while (queue_.pop(job)) {
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
      for (uint32_t i : b.block.items) {
        Read& r = u.reads[i];
        const ChannelMap& m = s_.reads[r.map];
        const double raw = decode(m.item, words + (m.item.address - b.block.start));
        r.last = raw * m.scale + m.offset;
        x_.samples[r.map].store(ItemSample{r.last, answered, 1, 0});
      }
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
