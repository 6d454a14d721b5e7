// The can driver's I/O thread, bridge thread and kind (see driver.h).
#include "io/drivers/can/driver.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

#include "io/drivers/can/cli.h"
#include "io/drivers/planned_link.h"
#include "io/drivers/lifecycle.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/periodic.h"

namespace rtplc::can {
namespace {

constexpr int64_t kStatusPeriodNs = 100000000;
constexpr int64_t kMs = 1000000;

int64_t seconds_to_ns(double s) {
  return static_cast<int64_t>(std::llround(s * 1e9));
}

using Line = io::LogLine;

}  // namespace

CanDriver::CanDriver(const io::DriverSetup& setup, const TransportOps& transport,
                     fieldbus::LinkScheduler::Clock clock)
    : io::Driver(setup, "can"),
      settings_(settings_of(*setup.config)),
      transport_(transport),
      rx_(std::make_unique<link::SnapshotSlot<RxSample>[]>(settings_.receive.size())),
      tx_done_(std::make_unique<link::SnapshotSlot<TxOutcome>[]>(settings_.transmit.size())),
      queue_(std::max<size_t>(16, 2 * settings_.transmit.size())) {
  uint32_t in = 0;
  for (const FrameMap& fm : settings_.receive) {
    filters_.push_back({fm.id, fm.extended, kMaxExtendedId});
    RxTrack t;
    t.first = in;
    in += static_cast<uint32_t>(fm.signals.size());
    rx_track_.push_back(t);
  }
  uint32_t out = 0;
  for (const FrameMap& fm : settings_.transmit) {
    TxTrack t;
    t.first = out;
    out += static_cast<uint32_t>(fm.signals.size());
    tx_track_.push_back(t);
  }
  // The I/O thread sends what the bridge queued between receives: waiting at
  // most half a driver period keeps a queued frame from waiting longer.
  io_wait_ns_ = std::clamp<int64_t>(setup.period_ns / 2, 1 * kMs, 20 * kMs);
  describe_link(0, settings_.interface, fmt::format("{} ({})", settings_.interface, transport.name));
  if (settings_.plan) {
    // The config checked the plan against the frames (config.cpp, check_plan).
    const fieldbus::LinkPlan& lp = *settings_.plan;
    const fieldbus::LinkTiming& timing = *lp.design.timing;
    for (int n = 0; n <= 8; ++n) wire_[n] = timing.packet(n);
    fieldbus::SchedulerSetup ss;
    ss.t1 = lp.plan.t1;
    ss.ln = lp.plan.ln_max;
    for (uint32_t i = 0; i < settings_.transmit.size(); ++i) {
      const FrameMap& fm = settings_.transmit[i];
      if (fm.tx_class == FrameMap::Class::kUrgent) {
        tx_track_[i].slot = static_cast<uint32_t>(urgent_tx_.size());
        urgent_tx_.push_back(i);
        ss.urgent.push_back(wire_[fm.length]);
      } else if (const fieldbus::LoopPlan* loop = lp.loop(fm.loop)) {
        tx_track_[i].slot = static_cast<uint32_t>(periodic_tx_.size());
        periodic_tx_.push_back(i);
        const int64_t frames = int64_t{1} << loop->shift;
        ss.periodic.push_back({frames, std::max<int64_t>(loop->offset, 0) % frames, wire_[fm.length]});
      }
    }
    sched_ = std::make_unique<fieldbus::LinkScheduler>(std::move(ss), clock);
    io::describe_planned_link(link_row(0), lp);
  }
}

CanDriver::~CanDriver() {
  request_stop();
  join();
  on_joined();
}

BusCounters CanDriver::counters() const {
  BusCounters c;
  (void)bus_.try_load(c);
  return c;
}

Result<void> CanDriver::can_send(uint32_t j, double value) const {
  uint32_t first = 0;
  for (const FrameMap& fm : settings_.transmit) {
    if (j < first + fm.signals.size()) {
      const SignalMap& sig = fm.signals[j - first];
      uint8_t data[8] = {};
      if (pack(sig.layout, value, data)) return {};
      const char* enc = sig.layout.encoding == Encoding::kFloat      ? "float"
                        : sig.layout.encoding == Encoding::kUnsigned ? "unsigned"
                                                                     : "signed";
      return make_error(fmt::format("its signal {} in frame {} cannot carry {}: {} {}-byte value after scale {} and "
                                    "offset {}",
                                    sig.channel, id_text(fm.id, fm.extended), value, enc, sig.layout.length,
                                    sig.layout.scale, sig.layout.offset));
    }
    first += static_cast<uint32_t>(fm.signals.size());
  }
  return {};
}

Result<void> CanDriver::on_start() {
  return start_io();
}

Result<void> CanDriver::load_bulk() {
  bulk_data_.clear();
  bulk_next_.clear();
  for (const BulkTransfer& b : settings_.bulk) {
    std::ifstream in(b.file, std::ios::binary);
    if (!in) return make_error(fmt::format("cannot read the bulk transfer file {}", b.file));
    bulk_data_.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    bulk_next_.push_back(0);  // due at the first cycle
  }
  return {};
}

Result<void> CanDriver::start_io() {
  if (auto b = load_bulk(); !b) return make_error(fmt::format("can driver '{}': {}", name(), b.error()));
  auto p = Port::open(transport_, settings_.interface, filters_, settings_.error_frames);
  if (!p) return make_error(fmt::format("can driver '{}': {}", name(), p.error()));
  port_ = std::move(*p);
  BusCounters c;
  c.up = 1;
  bus_.store(c);
  io::LinkStatus& ls = link_row(0);
  ls.connects.store(1, std::memory_order_relaxed);
  auto t = kernel_rt::start_driver_thread(name(), "can-io", setup().helper_priority, setup().cpu,
                                          [this] { io_loop(); });
  if (!t) return make_error(t.error());
  io_thread_ = std::move(*t);
  io_started_ = true;
  return {};
}

void CanDriver::on_joined() noexcept {
  if (io_started_) {
    io_stop_.store(true, std::memory_order_relaxed);
    io_thread_.join();
    io_started_ = false;
  }
  port_.close();
}

// ---- I/O thread -------------------------------------------------------------

void CanDriver::io_loop() noexcept {
  BusCounters c = bus_.writer_value();
  std::vector<bool> short_logged(settings_.receive.size(), false);
  bool send_failing = false;
  bool recv_failing = false;
  while (!io_stop_.load(std::memory_order_relaxed)) {
    bool changed = false;
    TxJob job;
    while (queue_.pop(job)) {
      const int err = port_.send(job.f);
      if (err == 0) {
        ++c.frames_tx;
        if (send_failing) log(io::LinkEvent::Level::kInfo, "CAN sends work again");
        send_failing = false;
        if (c.bus_offs == c.restarts) c.up = 1;
      } else {
        ++c.tx_failed;
        if (err == ENETDOWN) c.up = 0;
        if (!send_failing) {
          log(io::LinkEvent::Level::kError,
              Line("sending {} failed: {}", frame_chars(job.f).s, std::strerror(err)).text);
        }
        send_failing = true;
      }
      tx_done_[job.frame].store(TxOutcome{job.seq, err});
      changed = true;
    }
    Frame f;
    int err = 0;
    switch (port_.recv(f, io_wait_ns_, &err)) {
      case RecvResult::kTimeout:
        break;
      case RecvResult::kError:
        ++c.rx_errors;
        if (!recv_failing) {
          log(io::LinkEvent::Level::kError, Line("receiving failed: {}", std::strerror(err)).text);
        }
        recv_failing = true;
        changed = true;
        kernel_rt::sleep_until_ns(kernel_rt::monotonic_now_ns() + io_wait_ns_);  // no busy loop on a dead socket
        break;
      case RecvResult::kFrame:
        recv_failing = false;
        changed = true;
        if (f.error) {
          ++c.error_frames;
          const ErrorReport e = decode_error(f);
          if (e.bus_off) {
            ++c.bus_offs;
            c.up = 0;
          }
          if (e.restarted) {
            ++c.restarts;
            c.up = 1;
          }
          if (e.error_passive) c.passive = 1;
          if (e.back_to_active) c.passive = 0;
          const auto level = e.bus_off ? io::LinkEvent::Level::kError
                             : e.restarted || e.back_to_active ? io::LinkEvent::Level::kInfo
                                                               : io::LinkEvent::Level::kWarning;
          log(level, Line("CAN controller: {}", error_text(e)).text);
          break;
        }
        for (size_t i = 0; i < settings_.receive.size(); ++i) {
          const FrameMap& fm = settings_.receive[i];
          if (fm.id != f.id || fm.extended != f.extended) continue;
          if (f.len < fm.length) {
            ++c.bad_frames;
            if (!short_logged[i]) {
              short_logged[i] = true;
              log(io::LinkEvent::Level::kError,
                  Line("frame {} has {} data bytes, its signals need {}; ignored", id_chars(f.id, f.extended).s, f.len,
                       fm.length)
                      .text);
            }
            break;
          }
          ++c.frames_rx;
          RxSample s = rx_[i].writer_value();
          std::memcpy(s.data, f.data, sizeof s.data);
          s.len = f.len;
          ++s.count;
          s.at_ns = kernel_rt::monotonic_now_ns();
          rx_[i].store(s);
          break;
        }
        break;
    }
    if (changed) bus_.store(c);
  }
}

// ---- bridge thread ----------------------------------------------------------

void CanDriver::cycle(int64_t now) noexcept {
  (void)bus_.try_load(seen_);  // a miss keeps the last counters
  const bool up = seen_.up != 0;
  if (up != was_up_) {
    log(up ? io::LinkEvent::Level::kInfo : io::LinkEvent::Level::kError,
        up ? "CAN bus up again" : "CAN bus off or down: outputs are not delivered");
    was_up_ = up;
  }
  const uint32_t k = begin_snapshot();
  receive(k, now);
  if (sched_) {
    transmit_planned(k, now);
  } else {
    transmit(k, now);
  }
  end_snapshot(k, now);
  if (now >= next_status_) {
    publish_status();
    next_status_ = now + kStatusPeriodNs;
  }
}

void CanDriver::receive(uint32_t k, int64_t now) noexcept {
  for (uint32_t i = 0; i < rx_track_.size(); ++i) {
    RxTrack& t = rx_track_[i];
    const FrameMap& fm = settings_.receive[i];
    (void)rx_[i].try_load(t.last);  // a miss keeps the last sample
    // The frame's age by the one rule every consumer of its channels applies
    // (its claim's max age is the frame's timeout): here only to say so in the log.
    const bool fresh = t.last.count > 0 && io::judge_quality(Quality::kGood, 0.0, t.last.at_ns, now,
                                                             seconds_to_ns(fm.timeout_s)) == Quality::kGood;
    if (fresh && t.stale && t.seen) {
      log(io::LinkEvent::Level::kInfo, Line("frame {} is received again", id_chars(fm.id, fm.extended).s).text);
    }
    if (!fresh && !t.stale) {
      rx_timeouts_.fetch_add(1, std::memory_order_relaxed);
      log(io::LinkEvent::Level::kWarning,
          Line("frame {} not received for {} ms: its channels are stale", id_chars(fm.id, fm.extended).s,
               std::llround(fm.timeout_s * 1e3))
              .text);
    }
    t.seen = t.seen || fresh;
    t.stale = !fresh;
    for (uint32_t s = 0; s < fm.signals.size(); ++s) {
      const double v = t.last.count > 0 ? unpack(fm.signals[s].layout, t.last.data) : 0.0;
      // Good as received, at the frame's time: readers judge its age.
      const Quality q = t.last.count > 0 ? Quality::kGood : Quality::kBad;
      put_input(k, t.first + s, v, q, t.last.at_ns);
    }
  }
}

bool CanDriver::pack_frame(uint32_t i, int64_t now, uint8_t (&data)[8], uint64_t& held) noexcept {
  TxTrack& t = tx_track_[i];
  const FrameMap& fm = settings_.transmit[i];
  std::memcpy(data, t.data, sizeof data);
  held = 0;
  bool sendable = true;
  bool refused = false;
  for (uint32_t s = 0; s < fm.signals.size(); ++s) {
    double v = 0;
    if (output_to_send(t.first + s, v, now) != io::SendDecision::kSend) {
      // Held (on_bad: hold, or no snapshot this cycle): the signal keeps the
      // bytes sent last; before a first send there are none to keep.
      held |= uint64_t{1} << s;
      sendable = sendable && t.sent;
      continue;
    }
    if (!pack(fm.signals[s].layout, v, data)) {
      sendable = false;
      refused = true;
      if (!t.refusal_logged) {
        rejected_.fetch_add(1, std::memory_order_relaxed);
        log(io::LinkEvent::Level::kError,
            Line("{} = {} does not fit its signal in frame {}; the frame is not sent", fm.signals[s].channel, v,
                 id_chars(fm.id, fm.extended).s)
                .text);
      }
      continue;
    }
  }
  t.refusal_logged = refused;
  // A frame whose every signal is held still goes at its period (or its
  // plan's frame) with the bytes sent last: the peer keeps what it has, and a
  // drive watching the frame's period does not see a controller gone.
  return sendable;
}

// ---- on a plan: the bridge is the link's scheduler ---------------------------

void CanDriver::transmit_planned(uint32_t k, int64_t now) noexcept {
  if (!sched_started_) {
    // Frame 0 starts at the first release: every T_1 frame then starts on a cycle.
    sched_->start(first_release_ns() > 0 ? first_release_ns() : now);
    sched_started_ = true;
  }
  const bool up = seen_.up != 0;
  for (uint32_t i = 0; i < tx_track_.size(); ++i) {
    TxTrack& t = tx_track_[i];
    const FrameMap& fm = settings_.transmit[i];
    uint64_t held = 0;
    t.staged_ok = pack_frame(i, now, t.staged, held);
    const bool delivered = t.staged_ok && up && t.sent && t.last_err == 0;
    for (uint32_t s = 0; s < fm.signals.size(); ++s) {
      put_delivery(k, t.first + s, t.sent ? unpack(fm.signals[s].layout, t.data) : 0.0,
                   delivered && ((held >> s) & 1) == 0 ? Quality::kGood : Quality::kBad, now);
    }
    if (fm.tx_class == FrameMap::Class::kUrgent && t.staged_ok &&
        (!t.sent || t.force || std::memcmp(t.staged, t.data, sizeof t.data) != 0)) {
      sched_->urgent_ready(t.slot, now);
    }
  }
  if (bulk_active_ == SIZE_MAX) {
    for (size_t b = 0; b < bulk_data_.size(); ++b) {
      if (bulk_next_[b] > now || bulk_data_[b].empty()) continue;
      bulk_active_ = b;
      bulk_offset_ = 0;
      const double every = settings_.bulk[b].every_s;
      bulk_next_[b] = every > 0 ? now + seconds_to_ns(every) : INT64_MAX;
      sched_->nonrt_ready(now);
      break;
    }
  }
  sched_->tick(now, *this);
}

int CanDriver::send_now(uint32_t i) noexcept {
  TxTrack& t = tx_track_[i];
  const FrameMap& fm = settings_.transmit[i];
  Frame f;
  f.id = fm.id;
  f.extended = fm.extended;
  f.len = fm.length;
  std::memcpy(f.data, t.staged, sizeof f.data);
  const int err = port_.send(f);
  t.last_err = err;
  if (err != 0) {
    ++planned_failed_;
    if (!planned_failure_logged_) {
      log(io::LinkEvent::Level::kError, Line("sending {} failed: {}", frame_chars(f).s, std::strerror(err)).text);
    }
    planned_failure_logged_ = true;
    return err;
  }
  planned_failure_logged_ = false;
  ++planned_tx_;
  std::memcpy(t.data, t.staged, sizeof t.data);
  t.sent = true;
  t.force = false;
  return 0;
}

fieldbus::SendOutcome CanDriver::send_periodic(uint32_t slot) noexcept {
  const uint32_t i = periodic_tx_[slot];
  if (!tx_track_[i].staged_ok) return fieldbus::SendOutcome::kNothing;
  return send_now(i) == 0 ? fieldbus::SendOutcome::kSent : fieldbus::SendOutcome::kFailed;
}

fieldbus::SendOutcome CanDriver::send_urgent(uint32_t slot) noexcept {
  const uint32_t i = urgent_tx_[slot];
  if (!tx_track_[i].staged_ok) return fieldbus::SendOutcome::kNothing;
  return send_now(i) == 0 ? fieldbus::SendOutcome::kSent : fieldbus::SendOutcome::kFailed;
}

fieldbus::Nanos CanDriver::send_nonrt(fieldbus::Nanos budget, bool& more) noexcept {
  more = false;
  if (bulk_active_ == SIZE_MAX) return 0;
  const std::vector<uint8_t>& data = bulk_data_[bulk_active_];
  const BulkTransfer& b = settings_.bulk[bulk_active_];
  fieldbus::Nanos used = 0;
  while (bulk_offset_ < data.size()) {
    const size_t n = std::min<size_t>(8, data.size() - bulk_offset_);
    if (used + wire_[n] > budget) break;
    Frame f;
    f.id = b.id;
    f.extended = b.extended;
    f.len = static_cast<uint8_t>(n);
    std::memcpy(f.data, data.data() + bulk_offset_, n);
    if (const int err = port_.send(f); err != 0) {
      ++planned_failed_;
      break;  // the rest waits for the next frame
    }
    ++planned_tx_;
    used += wire_[n];
    bulk_offset_ += n;
  }
  more = bulk_offset_ < data.size();
  if (!more) {
    bulk_active_ = SIZE_MAX;
    ++transfers_done_;
  }
  return used;
}

void CanDriver::transmit(uint32_t k, int64_t now) noexcept {
  const bool up = seen_.up != 0;
  for (uint32_t i = 0; i < tx_track_.size(); ++i) {
    TxTrack& t = tx_track_[i];
    const FrameMap& fm = settings_.transmit[i];
    if (t.in_flight != 0) {
      TxOutcome o;
      if (tx_done_[i].try_load(o) && o.seq == t.in_flight) {
        t.in_flight = 0;
        t.last_err = o.err;
      }
    }
    uint8_t data[8];
    uint64_t held = 0;
    const bool sendable = pack_frame(i, now, data, held);
    const bool delivered = sendable && up && t.sent && t.last_err == 0;
    for (uint32_t s = 0; s < fm.signals.size(); ++s) {
      put_delivery(k, t.first + s, t.sent ? unpack(fm.signals[s].layout, t.data) : 0.0,
                   delivered && ((held >> s) & 1) == 0 ? Quality::kGood : Quality::kBad, now);
    }
    if (!sendable) {
      t.force = false;  // nothing we can vouch for to send, not even at stop
      continue;
    }
    const bool changed = std::memcmp(data, t.data, sizeof data) != 0;
    const bool due = !t.sent || now >= t.next_due || t.force || (fm.on_change && changed);
    if (!due) continue;
    TxJob job;
    job.frame = i;
    job.seq = t.next_seq;
    job.f.id = fm.id;
    job.f.extended = fm.extended;
    job.f.len = fm.length;
    std::memcpy(job.f.data, data, sizeof data);
    if (!queue_.push(job)) continue;  // the I/O thread is behind: next cycle
    ++t.next_seq;
    t.in_flight = job.seq;
    std::memcpy(t.data, data, sizeof data);
    t.sent = true;
    t.force = false;
    // Each frame keeps its own grid; after a stall it restarts from now.
    const int64_t period = seconds_to_ns(fm.period_s);
    t.next_due = t.next_due + period > now ? t.next_due + period : now + period;
  }
}

void CanDriver::publish_status() noexcept {
  const BusCounters& c = seen_;
  io::LinkStatus& ls = link_row(0);
  const auto r = std::memory_order_relaxed;
  uint64_t pending = 0;
  for (const TxTrack& t : tx_track_) pending += t.in_flight != 0;
  ls.state.store(static_cast<uint8_t>(c.up ? io::LinkState::kUp : io::LinkState::kDown), r);
  ls.quality.store(static_cast<uint8_t>(c.up ? Quality::kGood : Quality::kBad), r);
  ls.reconnects.store(c.restarts, r);
  ls.timeouts.store(rx_timeouts_.load(r), r);
  ls.errors.store(c.error_frames + c.bad_frames + c.rx_errors, r);
  ls.polls_completed.store(c.frames_rx, r);
  ls.polls_missed.store(c.bus_offs, r);
  ls.writes_acked.store(c.frames_tx + planned_tx_, r);
  ls.writes_failed.store(c.tx_failed + planned_failed_, r);
  if (sched_) io::publish_planned_link(ls, *sched_);
  ls.writes_pending.store(pending, r);
  ls.writes_rejected.store(rejected_.load(r), r);
}

void CanDriver::on_stop() noexcept {
  if (sched_) {
    // The tasks have set their outputs to their safe values: every frame goes
    // once more with them, outside the schedule (the link is ending).
    cycle(kernel_rt::monotonic_now_ns());
    for (uint32_t i = 0; i < tx_track_.size(); ++i) {
      if (tx_track_[i].staged_ok) (void)send_now(i);
    }
    publish_status();
    return;
  }
  // The tasks have set their outputs to their safe values: send every frame
  // once more with them, and give the I/O thread a moment to put them out.
  for (TxTrack& t : tx_track_) t.force = true;
  io::cycle_until_sent(
      500 * kMs, 2 * kMs, [this](int64_t now) { cycle(now); },
      [this] {
        bool pending = false;
        for (const TxTrack& t : tx_track_) pending |= t.force || t.in_flight != 0;
        return pending;
      });
  publish_status();
}

namespace {

Result<std::unique_ptr<io::Driver>> create(const io::DriverSetup& setup) {
  return std::unique_ptr<io::Driver>(std::make_unique<CanDriver>(setup, socketcan_transport()));
}

}  // namespace

const io::DriverKind kDriverKind{&kConfigKind, &create, &add_commands};

}  // namespace rtplc::can
