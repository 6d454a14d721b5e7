// The s7 driver's bridge thread and its kind (see driver.h).
#include "io/drivers/s7/driver.h"

#include "common/text.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "io/drivers/s7/address.h"
#include "io/drivers/s7/cli.h"
#include "io/drivers/s7/protocol.h"
#include "io/drivers/lifecycle.h"
#include "io/drivers/link_row.h"
#include "kernel_rt/clock.h"

namespace rtplc::s7 {
namespace {

constexpr int64_t kStatusPeriodNs = 100000000;    // link rows and link events
constexpr int64_t kLogIntervalNs = 5000000000;    // then one down/up message per PLC per 5 s at most
constexpr uint32_t kLogBurst = 4;                 // messages logged at once before the limit applies

io::LinkState link_state(PlcState s) {
  switch (s) {
    case PlcState::kUnused: return io::LinkState::kUnused;
    case PlcState::kIdle: return io::LinkState::kDown;
    case PlcState::kProbing:
    case PlcState::kHandshake: return io::LinkState::kConnecting;
    case PlcState::kReady: return io::LinkState::kUp;
  }
  return io::LinkState::kDown;
}

EngineOptions engine_options(const io::DriverSetup& setup, const S7DriverSettings& s) {
  EngineOptions o;
  o.max_plcs = std::max<size_t>(s.plcs.size(), 1);
  // The engine thread only moves bytes: below every task, so it never delays one.
  o.sched_fifo_priority = setup.helper_priority;
  o.cpu = setup.cpu;
  return o;
}

}  // namespace

S7Driver::S7Driver(const io::DriverSetup& setup)
    : io::Driver(setup, "s7"),
      settings_(settings_of(*setup.config)),
      engine_(engine_options(setup, settings_)) {}

Result<void> S7Driver::prepare() {
  const size_t n = settings_.plcs.size();
  acked_.assign(n, 0);
  failed_.assign(n, 0);
  rejected_.assign(n, 0);
  pending_.assign(n, 0);
  PlcTrack fresh;
  fresh.log_budget = kLogBurst;
  track_.assign(n, fresh);
  for (size_t i = 0; i < n; ++i) {
    const S7PlcConfig& pc = settings_.plcs[i];
    PlcConfig c;
    c.name = pc.name;
    c.address = pc.address;
    c.port = pc.port;
    c.connection.local_tsap = pc.local_tsap.value_or(0x0100);
    c.connection.remote_tsap = pc.remote_tsap.value_or(
        remote_tsap(static_cast<ConnectionType>(pc.connection_type), pc.rack, pc.slot));
    c.connection.setup = SetupParams{pc.amq, pc.amq, pc.pdu};
    c.poll_period_ms = static_cast<uint32_t>(std::max(1.0, pc.poll_s * 1000.0));
    c.reply_timeout_ms = static_cast<uint32_t>(std::max(1.0, pc.reply_timeout_s * 1000.0));
    auto id = engine_.connect(c);
    if (!id) return make_error("PLC " + pc.name + ": " + id.error());
    plcs_.push_back(*id);
    describe_link(static_cast<uint32_t>(i), pc.name, pc.address + ":" + std::to_string(pc.port));
  }
  auto plc_index = [&](const std::string& plc) -> int {
    for (size_t i = 0; i < n; ++i) {
      if (settings_.plcs[i].name == plc) return static_cast<int>(i);
    }
    return -1;
  };
  auto add = [&](const S7ChannelMap& m, int& plc, DataType& type) -> Result<ItemId> {
    plc = plc_index(m.plc);
    if (plc < 0) return make_error("channel " + m.channel + ": no PLC named " + m.plc);
    auto addr = parse_address(m.item);
    if (!addr) return make_error("channel " + m.channel + ": " + addr.error());
    ItemConfig ic;
    ic.address = *addr;
    type = addr->type;
    ic.scale = m.scale;
    ic.offset = m.offset;
    return engine_.add_item(plcs_[static_cast<size_t>(plc)], ic);
  };
  for (size_t i = 0; i < settings_.reads.size(); ++i) {
    int plc = -1;
    DataType type = DataType::kByte;
    auto item = add(settings_.reads[i], plc, type);
    if (!item) return make_error(item.error());
    Read r;
    r.item = *item;
    r.index = static_cast<uint32_t>(i);
    r.what = "PLC " + settings_.reads[i].plc + " item " + settings_.reads[i].item;
    reads_.push_back(std::move(r));
  }
  for (size_t i = 0; i < settings_.writes.size(); ++i) {
    int plc = -1;
    DataType type = DataType::kByte;
    auto item = add(settings_.writes[i], plc, type);
    if (!item) return make_error(item.error());
    Write w;
    w.item = *item;
    w.mode = settings_.writes[i].mode;
    w.plc = static_cast<uint32_t>(plc);
    w.type = type;
    w.scale = settings_.writes[i].scale;
    w.offset = settings_.writes[i].offset;
    w.what = "PLC " + settings_.writes[i].plc + " item " + settings_.writes[i].item;
    copy_text(w.range, sizeof w.range, range_text(w.type));
    writes_.push_back(std::move(w));
  }
  return {};
}

Result<void> S7Driver::on_start() {
  if (auto r = engine_.start(); !r) return make_error(r.error());
  engine_started_ = true;
  return {};
}

void S7Driver::on_joined() noexcept {
  if (engine_started_) engine_.stop();
  engine_started_ = false;
}

void S7Driver::cycle(int64_t now) noexcept {
  if (now >= next_status_) {
    track_status(now);
    publish_status();
    next_status_ = now + kStatusPeriodNs;
  }
  const uint32_t k = begin_snapshot();
  // Reads: the engine's latest sample of every item, in one snapshot.
  for (Read& r : reads_) {
    Sample s;
    if (engine_.try_read(r.item, s)) r.last = s;  // a miss keeps the last sample, ageing
    // The PLC's word with its time: every reader judges the age (and a REAL
    // that is NaN or Inf) by the one rule, io::judge_quality.
    const Quality q = r.last.quality;
    put_input(k, r.index, r.last.value, q, r.last.timestamp_ns);
    const bool refused = r.last.return_code != 0 && r.last.return_code != 0xFF;
    if (refused && !r.refusal_logged) {
      r.refusal_logged = true;
      log(io::LinkEvent::Level::kError,
          io::LogLine("{}: read refused by the PLC: {} (0x{:02X})", r.what, item_error_name(r.last.return_code),
                      r.last.return_code)
              .text);
    } else if (!refused && q == Quality::kGood) {
      r.refusal_logged = false;
    }
  }

  for (uint32_t j = 0; j < writes_.size(); ++j) cycle_write(j, k, now);
  end_snapshot(k, now);
}

// Output j: collect the outcome of its write in flight, send it when due, and
// publish its delivery entry.
void S7Driver::cycle_write(uint32_t j, uint32_t k, int64_t now) noexcept {
  Write& w = writes_[j];
  if (w.ticket.id != 0) {
    const WriteResult res = engine_.write_result(w.ticket);
    if (res.state == WriteState::kAcknowledged) {
      ++acked_[w.plc];
      w.ticket = {};
      w.failed = false;
      w.refusal_logged = false;
    } else if (res.state == WriteState::kFailed || res.state == WriteState::kRejected ||
               res.state == WriteState::kUnknown) {
      ++failed_[w.plc];
      w.ticket = {};
      w.failed = true;
      const bool refused = res.state == WriteState::kFailed && res.return_code != 0 && res.return_code != 0xFF;
      // Lost with the link (or never sent): send it again. Refused by the PLC:
      // it would be refused again; wait for a new value or a reconnect.
      w.resend = !refused;
      if (refused && !w.refusal_logged) {
        w.refusal_logged = true;
        log(io::LinkEvent::Level::kError,
            io::LogLine("{}: write refused by the PLC: {} (0x{:02X})", w.what, item_error_name(res.return_code),
                        res.return_code)
                .text);
      }
    }
  }
  double value = 0;
  // Not good: its on_bad policy (hold: no write, the PLC keeps what it has).
  const bool sendable = output_to_send(j, value, now) == io::SendDecision::kSend;
  if (sendable) {
    const bool changed = !w.sent || value != w.last;
    const bool due = w.mode == config::WriteMode::kEveryCycle || changed || w.resend;
    // One write per item in flight: the newest value goes out after it.
    if (due && w.ticket.id == 0) send(w, value);
  }
  const bool plc_up = track_[w.plc].state == PlcState::kReady;
  const bool good = plc_up && sendable && w.sent && !w.failed && !w.out_of_range;
  put_delivery(k, j, w.last, good ? Quality::kGood : Quality::kBad, now);
}

Result<void> S7Driver::can_send(uint32_t j, double value) const {
  if (j >= writes_.size()) return {};
  const Write& w = writes_[j];
  uint64_t raw = 0;
  if (value_to_raw(w.type, (value - w.offset) / w.scale, raw)) return {};
  return make_error(fmt::format("{} cannot carry {}: it does not fit {} ({}){}", w.what, value, type_name(w.type),
                                range_text(w.type),
                                w.scale != 1 || w.offset != 0 ? fmt::format(" after scale {} and offset {}", w.scale, w.offset)
                                                              : std::string()));
}

void S7Driver::send(Write& w, double value) noexcept {
  uint64_t raw = 0;
  if (!value_to_raw(w.type, (value - w.offset) / w.scale, raw)) {
    const bool same = w.out_of_range && (value == w.refused_value || (std::isnan(value) && std::isnan(w.refused_value)));
    if (!same) ++failed_[w.plc];
    w.out_of_range = true;
    w.refused_value = value;
    if (!w.range_logged) {
      w.range_logged = true;
      log(io::LinkEvent::Level::kError,
          w.sent ? io::LogLine("{}: {} does not fit {} ({}); not sent, the PLC keeps {} (once per item)", w.what,
                               value, type_name(w.type), w.range, w.last)
                       .text
                 : io::LogLine("{}: {} does not fit {} ({}); not sent, the PLC keeps its value (once per item)",
                               w.what, value, type_name(w.type), w.range)
                       .text);
    }
    return;
  }
  w.out_of_range = false;
  const WriteTicket t = engine_.write_raw(w.item, raw);
  if (t.id == 0) {
    ++rejected_[w.plc];  // the engine's queue is full: try again next cycle
    return;
  }
  w.ticket = t;
  w.last = value;
  w.sent = true;
  w.resend = false;
}

// Link state changes seen since the last call: logged (rate-limited), and a
// PLC that (re)connected gets every one of its outputs sent again.
void S7Driver::track_status(int64_t now) noexcept {
  for (size_t i = 0; i < plcs_.size(); ++i) {
    PlcStatus st;
    if (!engine_.try_status(plcs_[i], st)) continue;
    PlcTrack& t = track_[i];
    const std::string& name = settings_.plcs[i].name;
    const uint64_t new_sessions = st.connects - t.connects;
    if (st.connects != t.connects) {
      // A new session: the PLC may have restarted with its reset values.
      for (Write& w : writes_) {
        if (w.plc == i) w.resend = true;
      }
      t.connects = st.connects;
    }
    const bool was_ready = t.state == PlcState::kReady;
    const bool ready = st.state == PlcState::kReady;
    if (new_sessions > 0) t.ever_ready = true;  // even if it is gone again by now
    if (!t.ever_ready && !ready && st.connect_failures > 0 && !t.said_unreachable) {
      t.said_unreachable = true;
      log(io::LinkEvent::Level::kError,
          fmt::format("PLC {} ({}:{}) unreachable at start: {}; retrying with backoff", name,
                      settings_.plcs[i].address, settings_.plcs[i].port,
                      st.last_error[0] ? st.last_error : "no answer"));
    }
    // Link changes since the last look. We look every 100 ms and a link can go
    // down and up (or up and down) in between, so count from the sessions made
    // (each an up; each up but a current one followed by a down), not from the
    // two states alone: ups = n, downs = n + was_ready - ready.
    const int64_t changes = 2 * static_cast<int64_t>(new_sessions) + (was_ready ? 1 : 0) - (ready ? 1 : 0);
    if (changes > 0) t.unlogged += static_cast<uint32_t>(changes);
    if (t.log_budget < kLogBurst && now >= t.next_refill_ns) {
      ++t.log_budget;
      t.next_refill_ns = now + kLogIntervalNs;
    }
    if (t.unlogged > 0 && t.log_budget > 0) {
      if (t.log_budget == kLogBurst) t.next_refill_ns = now + kLogIntervalNs;
      --t.log_budget;
      log_link_change(i, st);
      t.unlogged = 0;
    }
    t.state = st.state;
  }
}

void S7Driver::log_link_change(size_t i, const PlcStatus& st) noexcept {
  const PlcTrack& t = track_[i];
  const std::string& name = settings_.plcs[i].name;
  // Changes the rate limit held back: say how many, so a flapping link shows.
  const io::LogLine held = t.unlogged > 1 ? io::LogLine(" ({} link changes since the last message)", t.unlogged)
                                          : io::LogLine("");
  if (st.state == PlcState::kReady) {
    log(io::LinkEvent::Level::kInfo,
        io::LogLine("PLC {} connected (PDU {}, {} parallel jobs){}", name, st.pdu_size, st.amq, held.text).text);
  } else {
    log(io::LinkEvent::Level::kWarning,
        io::LogLine("PLC {} disconnected: {}; its channels are bad until it is back{}", name,
                    st.last_error[0] ? st.last_error : "connection lost", held.text)
            .text);
  }
}

void S7Driver::publish_status() noexcept {
  std::fill(pending_.begin(), pending_.end(), 0);
  for (const Write& w : writes_) pending_[w.plc] += w.ticket.id != 0;
  for (size_t i = 0; i < plcs_.size(); ++i) {
    PlcStatus st;
    if (!engine_.try_status(plcs_[i], st)) continue;
    io::publish_link_row(link_row(static_cast<uint32_t>(i)), static_cast<uint8_t>(link_state(st.state)),
                         st.state == PlcState::kReady ? Quality::kGood : Quality::kBad, st, st.rtt_buckets,
                         {acked_[i], failed_[i], pending_[i], rejected_[i]});
  }
}

void S7Driver::on_stop() noexcept {
  // Stopping: the tasks have set their outputs to their safe values. Send those,
  // and give the PLCs a moment to acknowledge them, so shutdown loses no write.
  io::cycle_until_sent(
      1000000000, 10000000, [this](int64_t now) { cycle(now); },
      [this] {
        bool pending = false;
        for (const Write& w : writes_) pending |= w.ticket.id != 0 || (w.resend && !w.out_of_range);
        return pending;
      });
  track_status(kernel_rt::monotonic_now_ns());
  publish_status();
}

const io::DriverKind kDriverKind{&kConfigKind, &io::create_prepared<S7Driver>, &add_commands};

}  // namespace rtplc::s7
