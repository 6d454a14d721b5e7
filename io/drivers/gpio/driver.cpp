// The gpio driver's I/O thread, bridge thread and kind (see driver.h).
#include "io/drivers/gpio/driver.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>

#include "io/drivers/gpio/cli.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/periodic.h"

namespace rtplc::gpio {
namespace {

constexpr int64_t kStatusPeriodNs = 100000000;
constexpr int64_t kMs = 1000000;

using Line = io::LogLine;

const char* role_text(Role r) {
  return r == Role::kInput ? "inputs" : r == Role::kOutput ? "outputs" : "counters";
}

}  // namespace

GpioDriver::GpioDriver(const io::DriverSetup& setup, const ChipOps& ops)
    : io::Driver(setup, "gpio"), settings_(settings_of(*setup.config)), ops_(ops) {
  uint32_t in = 0;
  uint32_t out = 0;
  // Inputs and counters provide in the order listed (inputs first, as the
  // claims say); outputs consume in theirs.
  for (const LineMap& m : settings_.lines) {
    Track t;
    auto it = std::find(chip_names_.begin(), chip_names_.end(), m.chip);
    t.chip = static_cast<uint32_t>(it - chip_names_.begin());
    if (it == chip_names_.end()) chip_names_.push_back(m.chip);
    t.index = m.role == Role::kOutput ? out++ : in++;
    if (m.role == Role::kCounter || (m.role == Role::kInput && m.debounce_ns > 0)) {
      t.edge_slot = static_cast<int>(event_track_.size());
      event_track_.push_back(static_cast<uint32_t>(tracks_.size()));
    }
    tracks_.push_back(t);
  }
  edges_ = std::make_unique<link::SnapshotSlot<EdgeState>[]>(event_track_.size());
  chip_errors_.assign(chip_names_.size(), 0);
  io_wait_ns_ = std::clamp<int64_t>(setup.period_ns, 1 * kMs, 20 * kMs);
  for (uint32_t c = 0; c < chip_names_.size(); ++c) {
    describe_link(c, chip_names_[c], fmt::format("GPIO chip {} ({})", chip_names_[c], ops.name));
  }
}

GpioDriver::~GpioDriver() {
  request_stop();
  join();
  on_joined();
}

EdgeState GpioDriver::edges_of(size_t line) const {
  EdgeState s;
  if (line < tracks_.size() && tracks_[line].edge_slot >= 0) (void)edges_[static_cast<size_t>(tracks_[line].edge_slot)].try_load(s);
  return s;
}

Result<void> GpioDriver::on_start() {
  return start_io();
}

Result<void> GpioDriver::start_io() {
  auto fail = [&](const LineMap* m, const std::string& why) {
    on_joined();
    if (m == nullptr) return make_error(fmt::format("gpio driver '{}': {}", name(), why));
    return make_error(fmt::format("gpio driver '{}': {} entry {} at line {}:{}: {}", name(), role_text(m->role),
                                  m->channel, m->line_pos.line, m->line_pos.col, why));
  };
  for (const std::string& c : chip_names_) {
    auto h = ops_.open(ops_.context, c);
    if (!h) return fail(nullptr, h.error());
    chips_.push_back(*h);
  }
  const std::string consumer = "rtplc-" + name();
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const LineMap& m = settings_.lines[i];
    Track& t = tracks_[i];
    void* chip = chips_[t.chip];
    LineRequest req;
    req.offset = m.offset;
    if (!m.line_name.empty()) {
      const int off = ops_.find(chip, m.line_name);
      if (off < 0) {
        return fail(&m, fmt::format("chip {} has no line named '{}' (`rtplc gpio info {}` lists its lines)", m.chip,
                                    m.line_name, m.chip));
      }
      req.offset = static_cast<unsigned>(off);
    } else if (m.offset >= ops_.chip_info(chip).lines) {
      return fail(&m, fmt::format("chip {} has {} lines (0..{}), not line {}", m.chip, ops_.chip_info(chip).lines,
                                  ops_.chip_info(chip).lines - 1, m.offset));
    }
    req.output = m.role == Role::kOutput;
    req.active_low = m.active_low;
    req.bias = m.bias;
    req.edge = m.role == Role::kCounter ? m.edge : t.edge_slot >= 0 ? Edge::kBoth : Edge::kNone;
    req.initial = m.safe;
    auto l = ops_.request(chip, req, consumer.c_str());
    if (!l) return fail(&m, l.error());
    t.line = *l;
    if (req.output) t.last_set = m.safe;
    if (t.edge_slot >= 0) {
      EdgeState s;
      const int v = ops_.get(t.line);
      s.level = v > 0 ? 1 : 0;
      s.ok = v >= 0 ? 1 : 0;
      s.last_ns = kernel_rt::monotonic_now_ns();
      s.alive_ns = s.last_ns;  // read just now
      edges_[static_cast<size_t>(t.edge_slot)].store(s);
      t.seen = s;
      event_lines_.push_back(t.line);
    }
  }
  for (uint32_t c = 0; c < chips_.size(); ++c) link_row(c).connects.store(1, std::memory_order_relaxed);
  if (!event_lines_.empty()) {
    auto th = kernel_rt::start_driver_thread(name(), "gpio-io", setup().helper_priority, setup().cpu,
                                             [this] { io_loop(); });
    if (!th) return fail(nullptr, th.error());
    io_thread_ = std::move(*th);
    io_started_ = true;
  }
  return {};
}

void GpioDriver::on_joined() noexcept {
  if (io_started_) {
    io_stop_.store(true, std::memory_order_relaxed);
    io_thread_.join();
    io_started_ = false;
  }
  // Released lines keep their last level on most chips; the tasks' safe
  // values were driven by the last cycle.
  for (Track& t : tracks_) {
    if (t.line != nullptr) ops_.release(t.line);
    t.line = nullptr;
  }
  for (void* c : chips_) ops_.close(c);
  chips_.clear();
  event_lines_.clear();
}

// ---- I/O thread -------------------------------------------------------------

void GpioDriver::io_loop() noexcept {
  const size_t n = event_lines_.size();
  std::vector<EdgeState> st(n);
  std::vector<int64_t> raw_at(n, 0);   // debounced inputs: when the raw level last changed
  std::vector<uint8_t> raw(n, 0);
  std::vector<int64_t> counted_at(n, 0);
  std::vector<bool> counted_any(n, false);
  std::unique_ptr<bool[]> ready(new bool[n]);
  for (size_t e = 0; e < n; ++e) {
    st[e] = edges_[e].writer_value();
    raw[e] = st[e].level;
  }
  bool failing = false;
  while (!io_stop_.load(std::memory_order_relaxed)) {
    // A debounced input waiting to settle wakes the loop when it may have.
    int64_t wait = io_wait_ns_;
    const int64_t now = kernel_rt::monotonic_now_ns();
    for (size_t e = 0; e < n; ++e) {
      const LineMap& m = settings_.lines[event_track_[e]];
      if (m.role == Role::kInput && raw[e] != st[e].level) {
        wait = std::clamp<int64_t>(raw_at[e] + m.debounce_ns - now, 0, wait);
      }
    }
    const int r = ops_.wait(event_lines_, wait, ready.get());
    if (r < 0) {
      if (!failing) log(io::LinkEvent::Level::kError, Line("waiting for GPIO events failed: {}", std::strerror(-r)).text);
      failing = true;
      for (size_t e = 0; e < n; ++e) {
        ++st[e].errors;
        st[e].ok = 0;
        edges_[e].store(st[e]);
      }
      kernel_rt::sleep_until_ns(kernel_rt::monotonic_now_ns() + io_wait_ns_);  // no busy loop
      continue;
    }
    failing = false;
    for (size_t e = 0; e < n; ++e) {
      const LineMap& m = settings_.lines[event_track_[e]];
      if (r > 0 && ready[e]) {
        EdgeEvent evs[16];
        const int got = ops_.read_events(event_lines_[e], evs, 16);
        if (got < 0) {
          ++st[e].errors;
          st[e].ok = 0;
        } else {
          st[e].ok = 1;
        }
        for (int j = 0; j < got; ++j) {
          const EdgeEvent& ev = evs[j];
          if (m.role == Role::kCounter) {
            const bool kind = m.edge == Edge::kBoth || (m.edge == Edge::kRising) == ev.rising;
            if (kind && (!counted_any[e] || ev.ts_ns - counted_at[e] >= m.debounce_ns)) {
              ++st[e].count;
              st[e].last_ns = ev.ts_ns;
              counted_at[e] = ev.ts_ns;
              counted_any[e] = true;
            } else {
              ++st[e].ignored;
            }
            st[e].level = ev.rising ? 1 : 0;
          } else {
            const uint8_t lv = ev.rising ? 1 : 0;
            if (lv != raw[e]) {
              if (raw[e] != st[e].level) ++st[e].ignored;  // a bounce: the pending level did not hold
              raw[e] = lv;
              raw_at[e] = ev.ts_ns;
            }
          }
        }
      }
      if (m.role == Role::kInput && raw[e] != st[e].level &&
          kernel_rt::monotonic_now_ns() - raw_at[e] >= m.debounce_ns) {
        st[e].level = raw[e];
        st[e].last_ns = raw_at[e];
      }
      // Every pass, changed or not: the bridge stamps the value with alive_ns.
      st[e].alive_ns = kernel_rt::monotonic_now_ns();
      edges_[e].store(st[e]);
    }
  }
}

// ---- bridge thread ----------------------------------------------------------

void GpioDriver::cycle(int64_t now) noexcept {
  const uint32_t k = begin_snapshot();
  for (size_t i = 0; i < tracks_.size(); ++i) {
    Track& t = tracks_[i];
    const LineMap& m = settings_.lines[i];
    if (t.line == nullptr) {  // not started (a test cycling a driver it did not start)
      if (m.role == Role::kOutput) put_delivery(k, t.index, 0.0, Quality::kBad, now);
      else put_input(k, t.index, 0.0, Quality::kBad, now);
      continue;
    }
    if (t.edge_slot >= 0) {
      (void)edges_[static_cast<size_t>(t.edge_slot)].try_load(t.seen);  // a miss keeps the last state
      const EdgeState& s = t.seen;
      const double v = m.role == Role::kCounter ? static_cast<double>(s.count) : s.level;
      put_input(k, t.index, v, s.ok && s.alive_ns != 0 ? Quality::kGood : Quality::kBad, s.alive_ns);
      continue;
    }
    if (m.role == Role::kInput) {
      const int v = ops_.get(t.line);
      if (v < 0) {
        ++chip_errors_[t.chip];
        io_errors_.fetch_add(1, std::memory_order_relaxed);
        if (!t.failing) {
          log(io::LinkEvent::Level::kError, Line("reading {} {} failed: {}", m.chip, line_chars(m).s,
                                                 std::strerror(-v)).text);
        }
      } else if (t.failing) {
        log(io::LinkEvent::Level::kInfo, Line("reading {} {} works again", m.chip, line_chars(m).s).text);
      }
      t.failing = v < 0;
      put_input(k, t.index, v > 0 ? 1.0 : 0.0, v < 0 ? Quality::kBad : Quality::kGood, now);
      continue;
    }
    double v = 0;
    const io::SendDecision d = output_to_send(t.index, v, now);
    if (d == io::SendDecision::kNoRead) {
      // No consistent snapshot this cycle (the task is writing its region): not
      // a reason to move the line. Keep what was driven, say it as it was.
      put_delivery(k, t.index, t.last_set < 0 ? 0.0 : t.last_set,
                   t.vouched && t.last_err == 0 ? Quality::kGood : Quality::kBad, now);
      continue;
    }
    // Not good: the output's on_bad policy; hold keeps the level driven last
    // (the line's safe level until something was driven).
    const bool vouched = d == io::SendDecision::kSend;
    t.vouched = vouched;
    const int level = vouched ? (v != 0 ? 1 : 0) : t.last_set >= 0 ? t.last_set : m.safe;
    if (level != t.last_set || t.last_err != 0) {
      t.last_err = ops_.set(t.line, level);
      if (t.last_err == 0) {
        t.last_set = level;
        if (t.failing) log(io::LinkEvent::Level::kInfo, Line("driving {} {} works again", m.chip, line_chars(m).s).text);
        t.failing = false;
      } else {
        ++chip_errors_[t.chip];
        io_errors_.fetch_add(1, std::memory_order_relaxed);
        if (!t.failing) {
          log(io::LinkEvent::Level::kError, Line("driving {} {} failed: {}", m.chip, line_chars(m).s,
                                                 std::strerror(t.last_err)).text);
        }
        t.failing = true;
      }
    }
    put_delivery(k, t.index, t.last_set < 0 ? 0.0 : t.last_set,
                 vouched && t.last_err == 0 ? Quality::kGood : Quality::kBad, now);
  }
  end_snapshot(k, now);
  if (now >= next_status_) {
    publish_status();
    next_status_ = now + kStatusPeriodNs;
  }
}

void GpioDriver::publish_status() noexcept {
  const auto r = std::memory_order_relaxed;
  for (uint32_t c = 0; c < chip_names_.size(); ++c) {
    uint64_t pulses = 0, ignored = 0, errors = chip_errors_[c];
    bool ok = c < chips_.size();
    for (const Track& t : tracks_) {
      if (t.chip != c) continue;
      if (t.failing) ok = false;
      if (t.edge_slot < 0) continue;
      const EdgeState& s = t.seen;
      pulses += s.count;
      ignored += s.ignored;
      errors += s.errors;
      if (!s.ok) ok = false;
    }
    io::LinkStatus& ls = link_row(c);
    ls.state.store(static_cast<uint8_t>(ok ? io::LinkState::kUp : io::LinkState::kDown), r);
    ls.quality.store(static_cast<uint8_t>(ok ? Quality::kGood : Quality::kBad), r);
    ls.errors.store(errors, r);
    ls.polls_completed.store(pulses, r);
    ls.polls_missed.store(ignored, r);
  }
}

void GpioDriver::on_stop() noexcept {
  // The tasks have set their outputs to their safe values: drive them now.
  cycle(kernel_rt::monotonic_now_ns());
  publish_status();
}

namespace {

Result<std::unique_ptr<io::Driver>> create(const io::DriverSetup& setup) {
  return std::unique_ptr<io::Driver>(std::make_unique<GpioDriver>(setup, gpiod_chip_ops()));
}

}  // namespace

const io::DriverKind kDriverKind{&kConfigKind, &create, &add_commands};

}  // namespace rtplc::gpio
