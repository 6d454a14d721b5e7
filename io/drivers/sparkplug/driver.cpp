// The sparkplug driver and its kind (see driver.h).
#include "io/drivers/sparkplug/driver.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <random>

#include "blocks/registry.h"
#include "common/files.h"
#include "io/drivers/lifecycle.h"
#include "io/drivers/sparkplug/cli.h"
#include "io/drivers/sparkplug/mqtt_session.h"
#include "io/link/backoff.h"
#include "kernel_rt/clock.h"

namespace rtplc::sparkplug {
namespace {

constexpr int64_t kMinBackoffNs = 200 * kernel_rt::kNsPerMs;
constexpr int64_t kMaxBackoffNs = 10 * kernel_rt::kNsPerSec;
// A device whose regions did not publish is still sampled this often: its
// values' ages turn them stale without any new snapshot.
constexpr int64_t kFullSampleNs = 100 * kernel_rt::kNsPerMs;

// The link row's own figures (docs/sparkplug.md, "Statistics").
constexpr const char* kGauges[] = {"births", "seq", "bdSeq", "queued", "dropped", "replayed"};

uint64_t now_ms() { return static_cast<uint64_t>(kernel_rt::realtime_now_ns() / kernel_rt::kNsPerMs); }

}  // namespace

SparkplugDriver::SparkplugDriver(const io::DriverSetup& setup)
    : io::Driver(setup, "sparkplug"), settings_(settings_of(*setup.config)) {}

SparkplugDriver::~SparkplugDriver() {
  request_stop();
  join();
  link_stop_.store(true, std::memory_order_relaxed);
  if (link_.joinable()) link_.join();
}

Result<void> SparkplugDriver::prepare() {
  const io::ProcessImage& img = *setup().image;
  auto known = [&] {
    std::string k;
    for (uint32_t i = 0; i < img.channel_count() && i < 12; ++i) k += (i ? ", " : "") + std::string(img.channel(i).label);
    if (img.channel_count() > 12) k += ", ...";
    return k;
  };
  auto find = [&](const std::string& label, SourcePos at, const char* key) -> Result<int> {
    const int c = img.find_channel(label);
    if (c < 0) {
      return make_error(fmt::format("'{}' at line {}: no channel is labelled \"{}\" in the tasks' programs (they have: {})",
                                    key, at.line, label, known()));
    }
    return c;
  };
  for (size_t i = 0; i < settings_.publish.size(); ++i) {
    if (auto r = find(settings_.publish[i], settings_.publish_pos[i], "publish"); !r) return make_error(r.error());
  }
  for (const auto& [label, at] : settings_.deadband_pos) {
    if (auto r = find(label, at, "deadband"); !r) return make_error(r.error());
  }
  for (size_t i = 0; i < settings_.writable.size(); ++i) {
    auto c = find(settings_.writable[i], settings_.writable_pos[i], "writable");
    if (!c) return make_error(c.error());
    if (img.channel(static_cast<uint32_t>(*c)).dir != static_cast<uint8_t>(io::ChannelDir::kSetpoint)) {
      return make_error(fmt::format("'writable' at line {}: \"{}\" is not a set-point; only set-points are written "
                                    "from the network", settings_.writable_pos[i].line, settings_.writable[i]));
    }
    if (!settings_.publish_all &&
        std::find(settings_.publish.begin(), settings_.publish.end(), settings_.writable[i]) == settings_.publish.end()) {
      return make_error(fmt::format("'writable' at line {}: \"{}\" is not in 'publish': a host writes only what it sees",
                                    settings_.writable_pos[i].line, settings_.writable[i]));
    }
  }
  if (!setup().state_prefix.empty()) bdseq_path_ = setup().state_prefix + ".sparkplug-" + name() + ".bdseq";
  if (!bdseq_path_.empty()) {
    if (auto text = read_file_bounded(bdseq_path_, 64); text) {
      unsigned v = 0;
      const auto [end, ec] = std::from_chars(text->data(), text->data() + text->size(), v);
      if (ec == std::errc() && v <= 255) bdseq_ = v;
    }
  }
  // The node's hooks run on the link thread only (link_run).
  auto publish = [this](const std::string& topic, std::string payload, int qos, bool retain) {
    return session_ && session_->publish(topic, payload, qos, retain);
  };
  auto write = [this](const std::string& label, double value) -> Result<std::string> {
    if (!setup().set_point) return make_error("no runtime behind this driver sets set-points");
    return setup().set_point(label, value);
  };
  auto logline = [this](bool warning, const std::string& line) {
    log(warning ? io::LinkEvent::Level::kWarning : io::LinkEvent::Level::kInfo, line);
    if (warning) set_link_error(0, line);  // the link thread: the row's last_error has this one writer
  };
  node_ = std::make_unique<EdgeNode>(settings_, publish, write, [this](uint32_t c) { return sample(c); }, logline);
  describe_link(0, name(), fmt::format("{} {}/{}", settings_.broker_text(), settings_.group, settings_.node));
  for (uint32_t g = 0; g < std::size(kGauges); ++g) name_gauge(0, g, kGauges[g]);
  return {};
}

uint64_t SparkplugDriver::next_bdseq() {
  bdseq_ = (bdseq_ + 1) % 256;
  if (!bdseq_path_.empty()) {
    // Before the will carries it: after a crash the next session's differs.
    if (auto w = write_file_atomically(bdseq_path_, fmt::format("{}\n", bdseq_), 0600); !w) {
      log(io::LinkEvent::Level::kWarning, fmt::format("cannot keep bdSeq in {}: {}", bdseq_path_, w.error()));
    }
  }
  return bdseq_;
}

Sample SparkplugDriver::sample(uint32_t channel) const {
  const io::ChannelValue v = setup().image->read_channel(channel);
  Sample s;
  s.value = v.value;
  s.quality = v.fresh ? v.quality : Quality::kBad;
  s.forced = v.forced;
  const int64_t wall = v.timestamp_ns > 0 ? v.timestamp_ns + clock_offset_ns_ : kernel_rt::realtime_now_ns();
  s.timestamp_ms = static_cast<uint64_t>(std::max<int64_t>(wall, 0) / kernel_rt::kNsPerMs);
  return s;
}

uint64_t SparkplugDriver::layout_signature() const {
  const io::ProcessImage& img = *setup().image;
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](uint64_t v) { h = (h ^ v) * 1099511628211ull; };
  const uint32_t n = img.channel_count();
  // ChannelDesc::users changes only when a program starts, is swapped in or
  // rolled back: the task's swap count moves with it.
  mix(n);
  for (uint32_t t = 0; t < img.header().n_tasks; ++t) {
    const io::TaskInfo& ti = img.task_info(t);
    mix(ti.state.load(std::memory_order_relaxed) == static_cast<uint8_t>(io::TaskState::kRunning));
    mix(ti.swaps.load(std::memory_order_relaxed));
  }
  return h;
}

std::vector<DeviceDef> SparkplugDriver::read_devices() const {
  const io::ProcessImage& img = *setup().image;
  std::vector<DeviceDef> out;
  const uint32_t n = img.channel_count();
  for (uint32_t t = 0; t < img.header().n_tasks && t < 16; ++t) {
    const io::TaskInfo& ti = img.task_info(t);
    DeviceDef d;
    d.name = ti.name;
    const auto state = static_cast<io::TaskState>(ti.state.load(std::memory_order_relaxed));
    d.running = state == io::TaskState::kRunning || state == io::TaskState::kStarting;
    for (uint32_t c = 0; c < n; ++c) {
      if (!(img.channel_users(c) & (1u << t))) continue;
      const io::ChannelDesc& cd = img.channel(c);
      const std::string label = cd.label;
      if (!settings_.publish_all &&
          std::find(settings_.publish.begin(), settings_.publish.end(), label) == settings_.publish.end()) {
        continue;
      }
      MetricDef m;
      m.name = label;
      m.channel = c;
      m.digital = cd.kind == static_cast<uint8_t>(Kind::kDigital);
      m.writable = cd.dir == static_cast<uint8_t>(io::ChannelDir::kSetpoint) &&
                   std::find(settings_.writable.begin(), settings_.writable.end(), label) != settings_.writable.end();
      if (auto db = settings_.deadband.find(label); db != settings_.deadband.end()) m.deadband = db->second;
      d.metrics.push_back(std::move(m));
    }
    out.push_back(std::move(d));
  }
  return out;
}

void SparkplugDriver::mark_dirty(int64_t now_ns) {
  const io::ProcessImage& img = *setup().image;
  const std::vector<DeviceDef>& devs = node_->devices();
  if (device_regions_.size() != devs.size()) {
    device_regions_.assign(devs.size(), DeviceRegions{});
    for (size_t d = 0; d < devs.size(); ++d) {
      std::vector<uint32_t>& rs = device_regions_[d].regions;
      for (const MetricDef& m : devs[d].metrics) {
        const io::ChannelDesc& cd = img.channel(m.channel);
        rs.push_back(cd.region);
        if (cd.has_delivery) rs.push_back(cd.delivery_region);
      }
      std::sort(rs.begin(), rs.end());
      rs.erase(std::unique(rs.begin(), rs.end()), rs.end());
      device_regions_[d].seen.assign(rs.size(), ~uint64_t{0});
    }
  }
  dirty_.assign(devs.size(), false);
  for (size_t d = 0; d < devs.size(); ++d) {
    DeviceRegions& dr = device_regions_[d];
    bool dirty = now_ns - dr.sampled_ns >= kFullSampleNs;
    for (size_t i = 0; i < dr.regions.size(); ++i) {
      const uint64_t pub = img.ring(dr.regions[i]).published.load(std::memory_order_acquire);
      if (pub != dr.seen[i]) dirty = true;
      dr.seen[i] = pub;
    }
    if (dirty) dr.sampled_ns = now_ns;
    dirty_[d] = dirty;
  }
}

Result<void> SparkplugDriver::on_start() {
  kernel_rt::ThreadSpec spec;
  spec.name = "spb-" + name();
  spec.fifo_priority = setup().helper_priority;
  if (setup().cpu >= 0) spec.cpu = static_cast<unsigned>(setup().cpu);
  link_stop_.store(false, std::memory_order_relaxed);
  auto t = kernel_rt::start_thread(spec, [this] { link_run(); });
  if (!t) return make_error(t.error());
  link_ = std::move(*t);
  return {};
}

void SparkplugDriver::on_joined() noexcept {
  link_stop_.store(true, std::memory_order_relaxed);
  if (link_.joinable()) link_.join();
  publish_counters();
}

// The link thread: sessions with backoff, the node's ticks every driver period.
void SparkplugDriver::link_run() {
  std::unique_ptr<MqttSession>& session = session_;
  std::mt19937_64 rng(std::random_device{}());
  uint32_t failures = 0;
  int64_t next_dial = 0;
  uint64_t bdseq = 0;
  bool answered = true;  // the last CONNECT got a CONNACK (so the next needs a new bdSeq)
  uint64_t signature = 0;
  bool have_devices = false;
  // The devices again whenever tasks, programs or channels changed (and the
  // first time): before the births of a session, and at every tick.
  auto refresh_devices = [&] {
    const uint64_t sig = layout_signature();
    if (have_devices && sig == signature) return;
    node_->set_devices(read_devices(), now_ms());
    device_regions_.clear();
    signature = sig;
    have_devices = true;
  };
  const int64_t period = std::max<int64_t>(setup().period_ns, kernel_rt::kNsPerMs);
  int64_t next_tick = kernel_rt::monotonic_now_ns();
  const std::string client_id = "rtplc-" + settings_.group + "-" + settings_.node;
  bool said_down = false;

  auto drop_session = [&](const std::string& why) {
    node_->session_down();
    session.reset();
    ++failures;
    next_dial = kernel_rt::monotonic_now_ns() +
                link::backoff_delay_ns(failures, kMinBackoffNs, kMaxBackoffNs, rng());
    link_state_.store(static_cast<uint8_t>(io::LinkState::kDown), std::memory_order_relaxed);
    set_link_error(0, why);
    if (!said_down) log(io::LinkEvent::Level::kWarning, fmt::format("broker {}: {}", settings_.broker_text(), why));
    said_down = true;
  };

  while (!link_stop_.load(std::memory_order_relaxed)) {
    const int64_t now = kernel_rt::monotonic_now_ns();
    if (!session && now >= next_dial) {
      // A new bdSeq per CONNECT the broker answered (Sparkplug 3.0: one more
      // than the previous CONNECT's); a dial that never got an answer (the
      // broker down, the network cut) sent no session the broker knows of.
      if (answered) bdseq = next_bdseq();
      answered = false;
      session = std::make_unique<MqttSession>(settings_, client_id);
      link_state_.store(static_cast<uint8_t>(io::LinkState::kConnecting), std::memory_order_relaxed);
      if (auto r = session->connect(node_->node_topic("NDEATH"), node_->death_payload(bdseq, now_ms()), 1); !r) {
        drop_session(r.error());
        continue;
      }
    }
    if (session) {
      // Rounded up: a wait of 0 ms would spin through the tick's last millisecond.
      const int wait_ms =
          static_cast<int>(std::clamp<int64_t>((next_tick - now + kernel_rt::kNsPerMs - 1) / kernel_rt::kNsPerMs, 1, 50));
      switch (session->loop(wait_ms)) {
        case MqttSession::Event::kUp:
          answered = true;
          for (const std::string& t : node_->subscriptions()) session->subscribe(t, 1);
          failures = 0;
          if (said_down) log(io::LinkEvent::Level::kInfo, fmt::format("broker {}: connected", settings_.broker_text()));
          said_down = false;
          refresh_devices();
          node_->session_up(bdseq, now_ms());
          link_state_.store(static_cast<uint8_t>(node_->phase() == EdgeNode::Phase::kOnline ? io::LinkState::kUp
                                                                                              : io::LinkState::kConnecting),
                            std::memory_order_relaxed);
          break;
        case MqttSession::Event::kRefused:
          answered = true;
          drop_session(session->error());
          continue;
        case MqttSession::Event::kDown:
          drop_session(session->error());
          continue;
        case MqttSession::Event::kNone: break;
      }
      for (MqttSession::Message& m : session->take_messages()) {
        node_->on_message(m.topic, m.payload, m.retained, now_ms());
      }
      if (node_->wants_reconnect()) {
        node_->shutdown(now_ms());
        session->disconnect();
        session.reset();
        next_dial = kernel_rt::monotonic_now_ns();  // at once: a new session waits for the host
        link_state_.store(static_cast<uint8_t>(io::LinkState::kConnecting), std::memory_order_relaxed);
        continue;
      }
    } else {
      kernel_rt::sleep_until_ns(std::min(next_dial, next_tick));
    }
    if (kernel_rt::monotonic_now_ns() >= next_tick) {
      next_tick += period;
      if (next_tick < kernel_rt::monotonic_now_ns()) next_tick = kernel_rt::monotonic_now_ns() + period;
      clock_offset_ns_ = kernel_rt::realtime_now_ns() - kernel_rt::monotonic_now_ns();
      refresh_devices();
      mark_dirty(kernel_rt::monotonic_now_ns());
      node_->tick(now_ms(), &dirty_);
      if (session && session->up()) {
        link_state_.store(static_cast<uint8_t>(node_->phase() == EdgeNode::Phase::kOnline ? io::LinkState::kUp
                                                                                            : io::LinkState::kConnecting),
                          std::memory_order_relaxed);
      }
    }
  }
  // An orderly end: the tasks are stopped (outputs at their safe values); the
  // last values, DDEATHs... and NDEATH before the DISCONNECT.
  if (session && session->up()) {
    clock_offset_ns_ = kernel_rt::realtime_now_ns() - kernel_rt::monotonic_now_ns();
    node_->tick(now_ms());
    node_->shutdown(now_ms());
    session->disconnect();
  }
  link_state_.store(static_cast<uint8_t>(io::LinkState::kDown), std::memory_order_relaxed);
}

// The link row (docs/sparkplug.md, "Statistics").
void SparkplugDriver::cycle(int64_t now) noexcept {
  publish_counters();
  end_snapshot(begin_snapshot(), now);
}

void SparkplugDriver::publish_counters() noexcept {
  const auto r = std::memory_order_relaxed;
  io::LinkStatus& ls = link_row(0);
  const auto state = static_cast<io::LinkState>(link_state_.load(r));
  ls.state.store(static_cast<uint8_t>(state == io::LinkState::kUnused ? io::LinkState::kDown : state), r);
  ls.quality.store(static_cast<uint8_t>(state == io::LinkState::kUp ? Quality::kGood : Quality::kBad), r);
  const NodeCounters& c = node_->counters();
  ls.connects.store(c.sessions.load(r), r);
  ls.reconnects.store(c.sessions_lost.load(r), r);
  ls.errors.store(c.publish_errors.load(r) + c.bad_commands.load(r), r);
  ls.polls_completed.store(c.published.load(r), r);
  ls.polls_missed.store(c.dropped.load(r), r);
  ls.writes_acked.store(c.writes_applied.load(r), r);
  ls.writes_rejected.store(c.writes_refused.load(r), r);
  ls.gauges[0].store(c.node_births.load(r), r);
  ls.gauges[1].store(c.seq.load(r), r);
  ls.gauges[2].store(c.bdseq.load(r), r);
  ls.gauges[3].store(c.stored.load(r), r);
  ls.gauges[4].store(c.dropped.load(r), r);
  ls.gauges[5].store(c.replayed.load(r), r);
}

const io::DriverKind kDriverKind{&kConfigKind, &io::create_prepared<SparkplugDriver>, &add_commands};

}  // namespace rtplc::sparkplug
