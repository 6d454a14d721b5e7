// The bookkeeping of one Modbus connection's units (see unit_book.h).
#include "io/drivers/modbus/unit_book.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <utility>

#include "io/link/backoff.h"

namespace rtplc::modbus {
namespace {

constexpr int64_t kConnectBackoffMinNs = 100'000'000;
constexpr int64_t kConnectBackoffMaxNs = 5'000'000'000;
constexpr int64_t kQuietMaxNs = 5'000'000'000;  // an RTU unit that does not answer: polled at least this often
constexpr uint32_t kTimeoutsBeforeReconnect = 3;
constexpr int64_t kQuantilesEveryNs = 50'000'000;

}  // namespace

int64_t seconds_to_ns(double s) { return static_cast<int64_t>(s * 1e9); }

UnitBook::UnitBook(const ModbusSettings& s, const std::vector<uint32_t>& slaves, Exchange& x, const LineOptions& opt)
    : s_(s), x_(x), opt_(opt) {
  for (uint32_t slave : slaves) {
    Unit u;
    u.slave = slave;
    u.cfg = &s.slaves[slave];
    u.timeout_ns = seconds_to_ns(u.cfg->timeout_s);
    // Unplanned: one group per poll period. On a plan: one group per loop (its
    // period from the plan) and one for the non-RT items.
    std::map<std::pair<ChannelMap::Traffic, std::string>, std::vector<PlannedItem>> groups;
    for (uint32_t i = 0; i < s.reads.size(); ++i) {
      const ChannelMap& m = s.reads[i];
      if (m.slave != u.cfg->name) continue;
      int64_t period = seconds_to_ns(m.poll_s > 0 ? m.poll_s : u.cfg->poll_s);
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
    units.push_back(std::move(u));
  }
  name_ = first().rtu() ? first().device : first().name;
  random_ ^= static_cast<uint64_t>(slaves.front()) * 0x2545F4914F6CDD1Dull;
}

int64_t UnitBook::take_slot(Unit& u, UnitBlock& b, int64_t now) {
  const int64_t period = b.block.period_ns;
  const int64_t due = b.next_due == 0 ? now : b.next_due + ((now - b.next_due) / period) * period;
  if (b.next_due != 0 && now - b.next_due >= period) {
    u.st.polls_missed += static_cast<uint64_t>((now - b.next_due) / period);
  }
  // The next poll on the grid after now (a late poll does not shift the grid).
  // The grid is the clock's own multiples of the period, shared by every
  // connection of that period: they are served together, once per period,
  // instead of at a hundred scattered instants, each pulling an idle CPU out
  // of its sleep.
  b.next_due = b.next_due == 0 ? (now / period + 1) * period : b.next_due + ((now - b.next_due) / period + 1) * period;
  return due;
}

void UnitBook::skip_slot(Unit& u, UnitBlock& b, int64_t now) {
  ++u.st.polls_offline;
  const int64_t period = b.block.period_ns;
  b.next_due = b.next_due == 0 ? (now / period + 1) * period : b.next_due + ((now - b.next_due) / period + 1) * period;
}

int64_t UnitBook::next_due(const Unit& u) {
  int64_t t = INT64_MAX;
  for (const UnitBlock& b : u.blocks) t = std::min(t, std::max(b.next_due, u.quiet_until));
  return t;
}

void UnitBook::record(Unit& u, const Outcome& o, int64_t started_ns, int64_t now) noexcept {
  if (o.kind == Outcome::Kind::kTimeout) {
    ++u.st.timeouts;
    return;
  }
  if (o.kind == Outcome::Kind::kLink || o.kind == Outcome::Kind::kProtocol || o.kind == Outcome::Kind::kBadCrc) {
    ++u.st.errors;
    return;
  }
  // An answer (data or an exception): its round trip counts.
  const auto us = static_cast<uint64_t>(std::max<int64_t>(0, now - started_ns) / 1000);
  u.rtt.record(us);
  u.st.buckets.record(us);
  if (o.kind == Outcome::Kind::kException) ++u.st.errors;
}

void UnitBook::store_items(Unit& u, const UnitBlock& b, size_t from, size_t to, uint16_t start, const uint16_t* words,
                           int64_t answered) noexcept {
  for (size_t k = from; k < to; ++k) {
    Read& r = u.reads[b.block.items[k]];
    const ChannelMap& m = s_.reads[r.map];
    const double raw = decode(m.item, words + (m.item.address - start));
    r.last = raw * m.scale + m.offset;
    x_.samples[r.map].store(ItemSample{r.last, answered, 1, 0});
  }
}

void UnitBook::mark_bad(Unit& u, const UnitBlock& b, int64_t now, uint8_t exception) noexcept {
  for (uint32_t i : b.block.items) {
    Read& r = u.reads[i];
    x_.samples[r.map].store(ItemSample{r.last, now, 0, exception});
  }
}

const char* UnitBook::poll_done(Unit& u, UnitBlock& b, const Outcome& o, const uint16_t* words, int64_t due,
                                int64_t answered) noexcept {
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
    return nullptr;
  }
  ++u.failures;
  u.st.state = static_cast<uint8_t>(io::LinkState::kDown);
  if (u.failures == 1) {
    log(io::LinkEvent::Level::kWarning, fmt::format("slave {} ({}) not answering: {}; its channels are bad until it answers",
                                                    u.cfg->name, u.cfg->peer(), outcome_text(o)));
  }
  if (o.kind == Outcome::Kind::kLink) return "connection lost";
  if (u.cfg->rtu()) {
    // Quiet for one to two poll periods after the first failure, doubling with
    // each further one up to kQuietMaxNs: every failed poll costs the line a
    // timeout, so from the second poll on a dead unit is polled less often
    // than its period asks, and the live units around it keep their grid.
    u.quiet_until =
        answered + link::backoff_delay_ns(u.failures + 1, seconds_to_ns(u.cfg->poll_s), kQuietMaxNs, next_random());
  } else if (u.failures >= kTimeoutsBeforeReconnect) {
    return "no answer to several polls";
  }
  return nullptr;
}

UnitBook::Unit* UnitBook::unit_of_write(uint32_t write) noexcept {
  const std::string& slave = s_.writes[write].slave;
  for (Unit& u : units) {
    if (u.cfg->name == slave) return &u;
  }
  return nullptr;
}

void UnitBook::write_done(const WriteJob& job, const Outcome* o) noexcept {
  WriteOutcome out;
  out.seq = job.seq;
  if (o) {
    out.ok = o->ok() ? 1 : 0;
    out.exception = o->kind == Outcome::Kind::kException ? static_cast<uint8_t>(o->code) : 0;
  }
  x_.outcomes[job.write].store(out);
}

void UnitBook::publish(Unit& u, int64_t now) noexcept {
  // The quantiles walk the whole histogram (about 700 buckets, twice):
  // at most every kQuantilesEveryNs, not after every poll; the bridge reads
  // them only every 100 ms anyway.
  if (now >= u.quantiles_due) {
    u.quantiles_due = now + kQuantilesEveryNs;
    u.st.rtt_p50_us = static_cast<uint32_t>(u.rtt.quantile(0.5));
    u.st.rtt_p99_us = static_cast<uint32_t>(u.rtt.quantile(0.99));
  }
  u.st.rtt_max_us = static_cast<uint32_t>(u.rtt.max());
  x_.status[u.slave].store(u.st);
}

void UnitBook::log(io::LinkEvent::Level level, std::string_view text) noexcept {
  if (opt_.events) opt_.events->push(level, opt_.driver, text);
}

void UnitBook::connecting() noexcept {
  for (Unit& u : units) u.st.state = static_cast<uint8_t>(io::LinkState::kConnecting);
}

void UnitBook::connected() noexcept {
  connect_failures_ = 0;
  for (Unit& u : units) {
    ++u.st.connects;
    if (ever_connected_) ++u.st.reconnects;
    u.failures = 0;
    u.quiet_until = 0;
    // Up to the bridge only once a unit answers; connected, it is no longer down.
    u.st.state = static_cast<uint8_t>(io::LinkState::kConnecting);
  }
  if (ever_connected_ || said_unreachable_) {
    log(io::LinkEvent::Level::kInfo, fmt::format("slave {} ({}) connected", first().name, first().peer()));
  }
  ever_connected_ = true;
}

void UnitBook::connect_failed(const Outcome& o, int64_t now) noexcept {
  ++connect_failures_;
  next_connect_ = now + link::backoff_delay_ns(connect_failures_, kConnectBackoffMinNs, kConnectBackoffMaxNs, next_random());
  for (Unit& u : units) u.st.state = static_cast<uint8_t>(io::LinkState::kDown);
  if (!ever_connected_ && !said_unreachable_) {
    said_unreachable_ = true;
    log(io::LinkEvent::Level::kError, fmt::format("slave {} ({}) unreachable at start: {}; retrying with backoff",
                                                  first().name, first().peer(), outcome_text(o)));
  }
}

void UnitBook::dropped(int64_t now, const char* why) noexcept {
  for (Unit& u : units) {
    for (const UnitBlock& b : u.blocks) mark_bad(u, b, now, 0);
    u.st.state = static_cast<uint8_t>(io::LinkState::kDown);
  }
  connect_failures_ = 1;
  next_connect_ = now + link::backoff_delay_ns(1, kConnectBackoffMinNs, kConnectBackoffMaxNs, next_random());
  log(io::LinkEvent::Level::kWarning,
      fmt::format("slave {} disconnected: {}; its channels are bad until it is back", first().name, why));
}

}  // namespace rtplc::modbus
