// The modbus driver's bridge thread and its kind (see driver.h).
#include "io/drivers/modbus/driver.h"

#include "common/text.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "io/drivers/modbus/cli.h"
#include "io/drivers/planned_link.h"
#include "io/drivers/lifecycle.h"
#include "io/drivers/link_row.h"
#include "kernel_rt/clock.h"

namespace rtplc::modbus {
namespace {

constexpr int64_t kStatusPeriodNs = 100000000;

}  // namespace

ModbusDriver::ModbusDriver(const io::DriverSetup& setup)
    : io::Driver(setup, "modbus"),
      settings_(settings_of(*setup.config)),
      exchange_(settings_.reads.size(), settings_.writes.size(), settings_.slaves.size()) {}

ModbusDriver::~ModbusDriver() {
  request_stop();
  join();
  on_joined();  // also when it never started: the line threads may run after prepare()
}

Result<void> ModbusDriver::prepare() {
  const auto& s = settings_;
  LineOptions opt;
  opt.driver = name();
  opt.wake_ns = setup().period_ns;
  // Lines only move bytes: below every task, so a slave never delays one.
  opt.priority = setup().helper_priority;
  opt.cpu = setup().cpu;
  opt.events = setup().events;
  for (uint32_t i = 0; i < s.slaves.size(); ++i) describe_link(i, s.slaves[i].name, s.slaves[i].peer());
  Lanes lanes = make_lanes(s, exchange_, opt);
  lanes_ = std::move(lanes.lanes);
  planned_row_.assign(s.slaves.size(), 0);
  std::set<std::string> planned_lines;
  for (uint32_t i = 0; i < s.slaves.size(); ++i) {
    // A line on a plan shows its classes in its first slave's row (the
    // line's Exchange::planned slot).
    const auto& plan = s.slaves[i].plan;
    if (!plan || !planned_lines.insert(s.slaves[i].device).second) continue;
    io::describe_planned_link(link_row(i), *plan);
    planned_row_[i] = 1;
  }
  auto slave_index = [&](const std::string& name) -> uint32_t {
    for (uint32_t i = 0; i < s.slaves.size(); ++i) {
      if (s.slaves[i].name == name) return i;
    }
    return 0;  // the parser refused maps naming no slave
  };
  reads_.assign(s.reads.size(), ItemSample{});
  for (const ChannelMap& m : s.writes) {
    Write w;
    copy_text(w.what, sizeof w.what, to_string(m.item));
    w.slave = slave_index(m.slave);
    w.lane = lanes.lane_of_slave[w.slave];
    writes_.push_back(w);
  }
  track_.assign(s.slaves.size(), SlaveTrack{});
  return {};
}

Result<void> ModbusDriver::can_send(uint32_t j, double value) const {
  if (j >= settings_.writes.size()) return {};
  const ChannelMap& m = settings_.writes[j];
  // As the bridge encodes it: a bit is any non-zero, a register the scaled raw value.
  if (m.item.type == ItemType::kBit) return {};
  const double raw = (value - m.offset) / m.scale;
  if (fits(m.item, raw)) return {};
  const Result<void> why = check_value(m.item, raw);
  return make_error(fmt::format("slave {} item {} cannot carry {}{}: {}", m.slave, to_string(m.item), value,
                                m.scale != 1 || m.offset != 0 ? fmt::format(" (raw {})", raw) : std::string(),
                                why ? std::string("out of range") : why.error()));
}

Result<void> ModbusDriver::on_start() {
  for (auto& l : lanes_) {
    if (auto r = l->start(); !r) return make_error(r.error());
  }
  return {};
}

void ModbusDriver::on_joined() noexcept {
  for (auto& l : lanes_) l->join();
}

void ModbusDriver::cycle(int64_t now) noexcept {
  if (now >= next_status_) {
    track_status();
    publish_status();
    next_status_ = now + kStatusPeriodNs;
  }
  const uint32_t k = begin_snapshot();
  for (uint32_t i = 0; i < reads_.size(); ++i) {
    exchange_.samples[i].try_load(reads_[i]);  // a miss keeps the last sample
    const ItemSample& smp = reads_[i];
    const Quality q = smp.good && std::isfinite(smp.value) ? Quality::kGood : Quality::kBad;
    put_input(k, i, smp.value, q, smp.timestamp_ns);
  }
  for (uint32_t j = 0; j < writes_.size(); ++j) {
    Write& w = writes_[j];
    const ChannelMap& m = settings_.writes[j];
    if (w.in_flight != 0) {
      WriteOutcome out;
      if (exchange_.outcomes[j].try_load(out) && out.seq == w.in_flight) {
        w.in_flight = 0;
        if (out.ok) {
          ++track_[w.slave].acked;
          w.failed = false;
          w.refusal_logged = false;
        } else {
          ++track_[w.slave].failed;
          w.failed = true;
          w.resend = true;
          if (out.exception != 0 && !w.refusal_logged) {
            w.refusal_logged = true;
            log(io::LinkEvent::Level::kError,
                io::LogLine("slave {}: write of {} refused: {} (exception {})", m.slave, w.what,
                            exception_name(out.exception), out.exception)
                    .text);
          }
        }
      }
    }
    const bool up = slave_up(w.slave);
    double value = 0;
    // Not good: its on_bad policy (hold: no write, the slave keeps what it has).
    const bool sendable = output_to_send(j, value, now) == io::SendDecision::kSend;
    double raw = m.item.type == ItemType::kBit ? (value != 0 ? 1.0 : 0.0) : (value - m.offset) / m.scale;
    if (m.item.type != ItemType::kBit && m.item.type != ItemType::kF32) raw = std::round(raw);
    const bool in_range = fits(m.item, raw);
    const Quality delivered = up && !w.failed && w.sent && sendable && in_range ? Quality::kGood : Quality::kBad;
    put_delivery(k, j, w.last, delivered, now);
    if (!sendable) continue;
    const bool changed = !w.sent || value != w.last;
    const bool due = m.mode == WriteMode::kEveryCycle || changed || w.resend;
    if (!due || w.in_flight != 0) continue;  // one write per item in flight: the newest wins next
    if (!in_range) {
      if (changed) {
        ++track_[w.slave].rejected;
        log(io::LinkEvent::Level::kError,
            io::LogLine("slave {}: {} = {} is out of range for {}; not sent", m.slave, w.what, value,
                        type_name(m.item.type))
                .text);
      }
      w.last = value;
      w.sent = true;
      w.failed = true;
      continue;
    }
    if (!up && w.sent) continue;  // sent again once the slave is back (track_status)
    WriteJob job;
    job.write = j;
    job.seq = w.next_seq;
    encode(m.item, raw, job.words);
    if (!lanes_[w.lane]->push(job)) {
      ++track_[w.slave].rejected;  // the line's queue is full: try again next cycle
      continue;
    }
    ++w.next_seq;
    w.in_flight = job.seq;
    w.last = value;
    w.sent = true;
    w.resend = false;
  }
  end_snapshot(k, now);
}

// A slave that (re)connected gets every one of its outputs sent again (it may
// have restarted with its reset values).
void ModbusDriver::track_status() noexcept {
  for (uint32_t i = 0; i < track_.size(); ++i) {
    SlaveTrack& t = track_[i];
    if (!exchange_.status[i].try_load(t.st)) continue;
    if (t.st.connects != t.connects) {
      for (Write& w : writes_) {
        if (w.slave == i) w.resend = true;
      }
      t.connects = t.st.connects;
    }
  }
}

void ModbusDriver::publish_status() noexcept {
  for (SlaveTrack& t : track_) t.pending = 0;
  for (const Write& w : writes_) track_[w.slave].pending += w.in_flight != 0;
  for (uint32_t i = 0; i < track_.size(); ++i) {
    const SlaveTrack& t = track_[i];
    const UnitStatus& st = t.st;
    io::LinkStatus& ls = link_row(i);
    io::publish_link_row(ls, st.state, slave_up(i) ? Quality::kGood : Quality::kBad, st, st.buckets,
                         {t.acked, t.failed, t.pending, t.rejected});
    fieldbus::LinkFigures fig;
    if (planned_row_[i] && exchange_.planned[i].try_load(fig)) io::publish_planned_link(ls, fig);
  }
}

void ModbusDriver::on_stop() noexcept {
  // The tasks have set their outputs to their safe values: queue those (the
  // lines send what is queued before they end), and give the slaves a moment.
  io::cycle_until_sent(
      1000000000, 5000000, [this](int64_t now) { cycle(now); },
      [this] {
        bool pending = false;
        for (uint32_t j = 0; j < writes_.size(); ++j) {
          pending |= writes_[j].in_flight != 0 && slave_up(writes_[j].slave);
        }
        return pending;
      });
  track_status();
  publish_status();
}

const io::DriverKind kDriverKind{&kConfigKind, &io::create_prepared<ModbusDriver>, &add_commands};

}  // namespace rtplc::modbus
