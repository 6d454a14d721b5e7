// The s7 driver's bridge thread (see s7_driver.h).
#include "sched/s7_driver.h"

#include <cstring>

#include "common/text.h"
#include "io/s7/address.h"
#include "io/s7/protocol.h"
#include "kernel_rt/clock.h"
#include "sched/periodic.h"

namespace rtplc::sched {
namespace {

io::Quality to_image(s7::Quality q) {
  switch (q) {
    case s7::Quality::kGood: return io::Quality::kGood;
    case s7::Quality::kStale: return io::Quality::kStale;
    case s7::Quality::kBad: return io::Quality::kBad;
  }
  return io::Quality::kBad;
}


}  // namespace

S7Driver::S7Driver(std::string name, io::ProcessImage& image, uint32_t region, int64_t period_ns,
                   int priority, int engine_priority, int cpu, const config::S7DriverSettings& settings,
                   std::vector<S7WriteWiring> writes, uint32_t first_link)
    : name_(std::move(name)),
      image_(image),
      region_(region),
      period_ns_(period_ns),
      priority_(priority),
      cpu_(cpu),
      settings_(settings),
      write_wiring_(std::move(writes)),
      first_link_(first_link),
      engine_([&] {
        s7::EngineOptions o;
        o.max_plcs = std::max<size_t>(settings.plcs.size(), 1);
        o.sched_fifo_priority = engine_priority;
        o.cpu = cpu;
        return o;
      }()) {}

S7Driver::~S7Driver() {
  request_stop();
  join();
  if (started_engine_) engine_.stop();
}

Result<void> S7Driver::prepare() {
  const size_t n = settings_.plcs.size();
  acked_.assign(n, 0);
  failed_.assign(n, 0);
  rejected_.assign(n, 0);
  pending_.assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const config::S7PlcConfig& pc = settings_.plcs[i];
    s7::PlcConfig c;
    c.name = pc.name;
    c.address = pc.address;
    c.port = pc.port;
    c.connection.local_tsap = pc.local_tsap.value_or(0x0100);
    c.connection.remote_tsap = pc.remote_tsap.value_or(
        s7::remote_tsap(static_cast<s7::ConnectionType>(pc.connection_type), pc.rack, pc.slot));
    c.connection.setup = s7::SetupParams{pc.amq, pc.amq, pc.pdu};
    c.poll_period_ms = static_cast<uint32_t>(std::max(1.0, pc.poll_s * 1000.0));
    c.reply_timeout_ms = static_cast<uint32_t>(std::max(1.0, pc.reply_timeout_s * 1000.0));
    auto id = engine_.connect(c);
    if (!id) return make_error("PLC " + pc.name + ": " + id.error());
    plcs_.push_back(*id);
    io::LinkStatus& ls = image_.link(first_link_ + static_cast<uint32_t>(i));
    copy_text(ls.name, sizeof ls.name, pc.name);
    copy_text(ls.driver, sizeof ls.driver, name_);
    copy_text(ls.address, sizeof ls.address, pc.address + ":" + std::to_string(pc.port));
  }
  auto plc_index = [&](const std::string& plc) -> int {
    for (size_t i = 0; i < n; ++i) {
      if (settings_.plcs[i].name == plc) return static_cast<int>(i);
    }
    return -1;
  };
  auto add = [&](const config::S7ChannelMap& m, int& plc) -> Result<s7::ItemId> {
    plc = plc_index(m.plc);
    if (plc < 0) return make_error("channel " + m.channel + ": no PLC named " + m.plc);
    auto addr = s7::parse_address(m.item);
    if (!addr) return make_error("channel " + m.channel + ": " + addr.error());
    s7::ItemConfig ic;
    ic.address = *addr;
    ic.scale = m.scale;
    ic.offset = m.offset;
    return engine_.add_item(plcs_[static_cast<size_t>(plc)], ic);
  };
  for (size_t i = 0; i < settings_.reads.size(); ++i) {
    int plc = -1;
    auto item = add(settings_.reads[i], plc);
    if (!item) return make_error(item.error());
    reads_.push_back({*item, static_cast<uint32_t>(i)});
  }
  for (size_t i = 0; i < settings_.writes.size(); ++i) {
    int plc = -1;
    auto item = add(settings_.writes[i], plc);
    if (!item) return make_error(item.error());
    Write w;
    w.item = *item;
    w.from = write_wiring_[i];
    w.mode = settings_.writes[i].mode;
    w.plc = static_cast<uint32_t>(plc);
    writes_.push_back(w);
  }
  return {};
}

Result<void> S7Driver::start(int64_t first_release_ns) {
  first_release_ = first_release_ns;
  if (auto r = engine_.start(); !r) return make_error("driver " + name_ + ": " + r.error());
  started_engine_ = true;
  exchange(kernel_rt::monotonic_now_ns());  // channels exist (bad) before the first cycle
  auto t = start_driver_thread(name_, "s7", priority_, cpu_, [this] { run(); });
  if (!t) return make_error(t.error());
  thread_ = std::move(t).value();
  return {};
}

void S7Driver::join() {
  if (thread_.joinable()) thread_.join();
}

void S7Driver::exchange(int64_t now) noexcept {
  // Reads: the engine's latest sample of every item, in one snapshot.
  const uint32_t k = image_.begin_write(region_);
  for (const Read& r : reads_) {
    const s7::Sample s = engine_.read(r.item);
    // A lost PLC's last value stays, with its quality saying so.
    image_.put(region_, k, r.index, s.value, to_image(s.quality_at(now)), s.timestamp_ns);
  }
  image_.end_write(region_, k, now, 0);

  // Writes: each ends acknowledged, failed (then sent again) or still pending.
  for (Write& w : writes_) {
    if (w.ticket.id != 0) {
      const s7::WriteResult res = engine_.write_result(w.ticket);
      if (res.state == s7::WriteState::kAcknowledged) {
        ++acked_[w.plc];
        w.ticket = {};
      } else if (res.state == s7::WriteState::kFailed || res.state == s7::WriteState::kRejected ||
                 res.state == s7::WriteState::kUnknown) {
        ++failed_[w.plc];
        w.ticket = {};
        w.resend = true;
      }
    }
    double value = 0;
    const uint32_t zero = 0;
    if (!image_.read_values(w.from.source_region, &w.from.source_index, &zero, 1, &value, 3)) continue;
    const bool changed = !w.sent || value != w.last;
    const bool due = w.mode == config::S7WriteMode::kEveryCycle || changed || w.resend;
    if (!due || w.ticket.id != 0) continue;  // one write per item in flight: the newest wins next
    const s7::WriteTicket t = engine_.write(w.item, value);
    if (t.id == 0) {
      ++rejected_[w.plc];  // the engine's queue is full: try again next cycle
      continue;
    }
    w.ticket = t;
    w.last = value;
    w.sent = true;
    w.resend = false;
  }
}

void S7Driver::publish_status() noexcept {
  std::fill(pending_.begin(), pending_.end(), 0);
  for (const Write& w : writes_) pending_[w.plc] += w.ticket.id != 0;
  for (size_t i = 0; i < plcs_.size(); ++i) {
    const s7::PlcStatus st = engine_.status(plcs_[i]);
    io::LinkStatus& ls = image_.link(first_link_ + static_cast<uint32_t>(i));
    const auto r = std::memory_order_relaxed;
    ls.state.store(static_cast<uint8_t>(st.state), r);
    ls.pdu.store(st.pdu_size, r);
    ls.amq.store(st.amq, r);
    ls.rtt_p50_us.store(st.rtt_p50_us, r);
    ls.rtt_p99_us.store(st.rtt_p99_us, r);
    ls.connects.store(st.connects, r);
    ls.reconnects.store(st.reconnects, r);
    ls.timeouts.store(st.timeouts, r);
    ls.errors.store(st.errors, r);
    ls.polls_completed.store(st.polls_completed, r);
    ls.polls_missed.store(st.polls_missed, r);
    ls.polls_offline.store(st.polls_offline, r);
    ls.writes_acked.store(acked_[i], r);
    ls.writes_failed.store(failed_[i], r);
    ls.writes_pending.store(pending_[i], r);
    ls.writes_rejected.store(rejected_[i], r);
  }
}

void S7Driver::run() noexcept {
  int64_t release = first_release_;
  int64_t next_status = 0;
  while (!stop_.load(std::memory_order_relaxed)) {
    kernel_rt::sleep_until_ns(release);
    const int64_t now = kernel_rt::monotonic_now_ns();
    exchange(now);
    if (now >= next_status) {
      publish_status();
      next_status = now + 250000000;
    }
    release = next_release(release, period_ns_, now);
  }
  // Stopping: the tasks have set their outputs to their safe values. Send those,
  // and give the PLCs a moment to acknowledge them, so shutdown loses no write.
  const int64_t give_up = kernel_rt::monotonic_now_ns() + 1000000000;
  for (;;) {
    exchange(kernel_rt::monotonic_now_ns());
    bool pending = false;
    for (const Write& w : writes_) pending |= w.ticket.id != 0 || w.resend;
    if (!pending || kernel_rt::monotonic_now_ns() > give_up) break;
    kernel_rt::sleep_until_ns(kernel_rt::monotonic_now_ns() + 10000000);
  }
  publish_status();
}

}  // namespace rtplc::sched
