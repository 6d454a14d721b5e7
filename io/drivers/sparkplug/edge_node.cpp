// The Sparkplug B edge node's state machine (see edge_node.h).
#include "io/drivers/sparkplug/edge_node.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

namespace rtplc::sparkplug {
namespace {

constexpr uint32_t kReplayBatch = 100;  // stored changes per replayed DDATA

bool same_metric(const MetricDef& a, const MetricDef& b) {
  return a.name == b.name && a.channel == b.channel && a.digital == b.digital && a.writable == b.writable &&
         a.deadband == b.deadband;
}

}  // namespace

bool DeviceDef::operator==(const DeviceDef& o) const {
  return name == o.name && running == o.running && metrics.size() == o.metrics.size() &&
         std::equal(metrics.begin(), metrics.end(), o.metrics.begin(), same_metric);
}

EdgeNode::EdgeNode(const SparkplugSettings& s, Publish publish, Write write, Sampler sampler, Log log)
    : s_(s),
      publish_(std::move(publish)),
      write_(std::move(write)),
      sampler_(std::move(sampler)),
      log_(std::move(log)),
      ns_("spBv1.0/" + s.group + "/") {}

std::string EdgeNode::node_topic(std::string_view type) const { return ns_ + std::string(type) + "/" + s_.node; }
std::string EdgeNode::device_topic(std::string_view type, const std::string& device) const {
  return node_topic(type) + "/" + device;
}
std::string EdgeNode::state_topic() const {
  return s_.primary_host.empty() ? std::string() : "spBv1.0/STATE/" + s_.primary_host;
}

std::vector<std::string> EdgeNode::subscriptions() const {
  std::vector<std::string> t{node_topic("NCMD"), node_topic("DCMD") + "/+"};
  if (!s_.primary_host.empty()) t.push_back(state_topic());
  return t;
}

std::string EdgeNode::death_payload(uint64_t bdseq, uint64_t now_ms) const {
  Payload p;
  p.set_timestamp(now_ms);
  Metric* m = p.add_metrics();
  m->set_name("bdSeq");
  m->set_timestamp(now_ms);
  set_int64(*m, static_cast<int64_t>(bdseq));
  return p.SerializeAsString();
}

bool EdgeNode::send(const std::string& topic, const Payload& p, int qos) {
  if (!publish_(topic, p.SerializeAsString(), qos, false)) {
    counters_.publish_errors.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  counters_.published.fetch_add(1, std::memory_order_relaxed);
  if (p.has_seq()) counters_.seq.store(static_cast<uint32_t>(p.seq()), std::memory_order_relaxed);
  return true;
}

uint64_t EdgeNode::next_seq() {
  seq_ = static_cast<uint8_t>(seq_ + 1);  // 0..255, then 0 again
  return seq_;
}

void EdgeNode::session_up(uint64_t bdseq, uint64_t now_ms) {
  bdseq_ = bdseq;
  reconnect_ = false;
  counters_.bdseq.store(bdseq, std::memory_order_relaxed);
  counters_.sessions.fetch_add(1, std::memory_order_relaxed);
  if (s_.primary_host.empty()) {
    births(now_ms);
  } else {
    phase_ = Phase::kWaiting;  // until the host's STATE says online
    counters_.phase.store(static_cast<uint8_t>(phase_), std::memory_order_relaxed);
  }
}

void EdgeNode::session_down() {
  if (phase_ != Phase::kOffline) counters_.sessions_lost.fetch_add(1, std::memory_order_relaxed);
  phase_ = Phase::kOffline;
  counters_.phase.store(static_cast<uint8_t>(phase_), std::memory_order_relaxed);
  for (DeviceState& d : state_) d.born = false;
  rebirth_ = false;
  reconnect_ = false;  // this session is over: the next one starts clean
}

void EdgeNode::shutdown(uint64_t now_ms) {
  if (phase_ == Phase::kOffline) return;
  // An orderly end: the host learns it now, not from the will a keep-alive later.
  (void)publish_(node_topic("NDEATH"), death_payload(bdseq_, now_ms), 1, false);
  session_down();
  counters_.sessions_lost.fetch_sub(1, std::memory_order_relaxed);  // ended, not lost
}

void EdgeNode::births(uint64_t now_ms) {
  phase_ = Phase::kOnline;
  counters_.phase.store(static_cast<uint8_t>(phase_), std::memory_order_relaxed);
  rebirth_ = false;
  next_alias_ = 1;
  for (DeviceState& d : state_) d.born = false;
  Payload p;
  p.set_timestamp(now_ms);
  seq_ = 0;
  p.set_seq(0);
  auto node_metric = [&](const char* name) {
    Metric* m = p.add_metrics();
    m->set_name(name);
    m->set_timestamp(now_ms);
    if (s_.aliases) m->set_alias(next_alias_++);
    return m;
  };
  set_int64(*node_metric("bdSeq"), static_cast<int64_t>(bdseq_));
  set_bool(*node_metric("Node Control/Rebirth"), false);
  set_string(*node_metric("Properties/Software"), "rtplc");
  set_uint64(*node_metric("Properties/Devices"), devices_.size());
  send(node_topic("NBIRTH"), p, 0);
  counters_.node_births.fetch_add(1, std::memory_order_relaxed);
  for (uint32_t d = 0; d < devices_.size(); ++d) {
    if (devices_[d].running) device_birth(d, now_ms);
  }
  replay_ms_ = now_ms;
  replay_budget_ = 0;
}

void EdgeNode::put_metric(Metric& m, uint32_t d, uint32_t i, const Sample& s, bool with_name) const {
  const MetricDef& def = devices_[d].metrics[i];
  if (with_name || !s_.aliases) m.set_name(def.name);
  if (s_.aliases) m.set_alias(state_[d].alias[i]);
  set_metric_value(m, def.digital, s.value, s.quality, s.forced, s.timestamp_ms);
}

void EdgeNode::device_birth(uint32_t d, uint64_t now_ms) {
  DeviceState& st = state_[d];
  const DeviceDef& dev = devices_[d];
  st.last.assign(dev.metrics.size(), Last{});
  st.alias.assign(dev.metrics.size(), 0);
  Payload p;
  p.set_timestamp(now_ms);
  p.set_seq(next_seq());
  for (uint32_t i = 0; i < dev.metrics.size(); ++i) {
    if (s_.aliases) st.alias[i] = next_alias_++;
    const Sample s = sampler_(dev.metrics[i].channel);
    put_metric(*p.add_metrics(), d, i, s, true);
    st.last[i] = Last{true, s};
  }
  st.born = send(device_topic("DBIRTH", dev.name), p, 0);
}

void EdgeNode::device_death(uint32_t d, uint64_t now_ms) {
  DeviceState& st = state_[d];
  if (!st.born) return;
  Payload p;
  p.set_timestamp(now_ms);
  p.set_seq(next_seq());
  send(device_topic("DDEATH", devices_[d].name), p, 0);
  st.born = false;
}

void EdgeNode::set_devices(std::vector<DeviceDef> devices, uint64_t now_ms) {
  std::vector<DeviceState> next(devices.size());
  std::vector<bool> kept(devices_.size(), false);
  for (uint32_t n = 0; n < devices.size(); ++n) {
    auto old = std::find_if(devices_.begin(), devices_.end(), [&](const DeviceDef& o) { return o.name == devices[n].name; });
    if (old != devices_.end() && *old == devices[n]) {
      const auto o = static_cast<uint32_t>(old - devices_.begin());
      next[n] = std::move(state_[o]);
      kept[o] = true;
    } else {
      next[n].generation = ++generation_;
    }
  }
  // A device that stopped, changed (a swap with other channels) or is gone: its DDEATH.
  for (uint32_t o = 0; o < devices_.size(); ++o) {
    if (!kept[o]) device_death(o, now_ms);
  }
  devices_ = std::move(devices);
  state_ = std::move(next);
  if (phase_ == Phase::kOnline) {
    for (uint32_t d = 0; d < devices_.size(); ++d) {
      if (devices_[d].running && !state_[d].born) device_birth(d, now_ms);
    }
  }
}

bool EdgeNode::changed(const MetricDef& m, const Last& l, const Sample& s) const {
  if (!l.has) return true;
  if (l.s.quality != s.quality || l.s.forced != s.forced) return true;
  if (std::isnan(l.s.value) != std::isnan(s.value)) return true;
  if (m.digital) return (l.s.value != 0) != (s.value != 0);
  if (m.deadband <= 0) return l.s.value != s.value;
  return std::fabs(s.value - l.s.value) >= m.deadband;
}

void EdgeNode::store(uint32_t d, uint32_t i, const Sample& s, bool historical) {
  if (s_.store_and_forward == 0) {
    counters_.dropped.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (store_.size() >= s_.store_and_forward) {
    store_.pop_front();  // the oldest goes first: the newest values matter most
    counters_.dropped.fetch_add(1, std::memory_order_relaxed);
  }
  store_.push_back(Stored{d, i, state_[d].generation, s, historical});
  counters_.stored.store(store_.size(), std::memory_order_relaxed);
}

void EdgeNode::tick(uint64_t now_ms, const std::vector<bool>* dirty) {
  if (phase_ == Phase::kOnline && rebirth_) births(now_ms);
  const bool online = phase_ == Phase::kOnline;
  for (uint32_t d = 0; d < devices_.size(); ++d) {
    DeviceState& st = state_[d];
    const DeviceDef& dev = devices_[d];
    if (!dev.running || (online && !st.born)) continue;
    if (dirty && d < dirty->size() && !(*dirty)[d]) continue;
    if (st.last.size() != dev.metrics.size()) st.last.assign(dev.metrics.size(), Last{});
    Payload p;
    for (uint32_t i = 0; i < dev.metrics.size(); ++i) {
      const Sample s = sampler_(dev.metrics[i].channel);
      Last& l = st.last[i];
      if (!changed(dev.metrics[i], l, s)) continue;
      const bool had = l.has;
      l = Last{true, s};
      if (!online) {
        if (had) store(d, i, s, true);  // a first reading is no change: the birth will carry it
      } else if (!store_.empty()) {
        store(d, i, s, false);  // behind the replay, in order
      } else {
        put_metric(*p.add_metrics(), d, i, s, false);
      }
    }
    if (p.metrics_size() > 0) {
      p.set_timestamp(now_ms);
      p.set_seq(next_seq());
      send(device_topic("DDATA", dev.name), p, 0);
    }
  }
  if (online && !store_.empty()) replay(now_ms);
}

void EdgeNode::replay(uint64_t now_ms) {
  replay_budget_ += static_cast<double>(now_ms - replay_ms_) * s_.replay_rate / 1000.0;
  replay_budget_ = std::min(replay_budget_, static_cast<double>(std::max<uint32_t>(s_.replay_rate, kReplayBatch)));
  replay_ms_ = now_ms;
  while (!store_.empty() && replay_budget_ >= 1) {
    const uint32_t d = store_.front().device;
    Payload p;
    while (!store_.empty() && store_.front().device == d && replay_budget_ >= 1 &&
           static_cast<uint32_t>(p.metrics_size()) < kReplayBatch) {
      const Stored e = store_.front();
      store_.pop_front();
      replay_budget_ -= 1;
      if (d >= state_.size() || e.generation != state_[d].generation || !state_[d].born ||
          e.metric >= devices_[d].metrics.size()) {
        counters_.dropped.fetch_add(1, std::memory_order_relaxed);  // its device changed meanwhile
        continue;
      }
      Metric* m = p.add_metrics();
      put_metric(*m, d, e.metric, e.s, false);
      if (e.historical) m->set_is_historical(true);
      counters_.replayed.fetch_add(1, std::memory_order_relaxed);
    }
    if (p.metrics_size() > 0) {
      p.set_timestamp(now_ms);
      p.set_seq(next_seq());
      send(device_topic("DDATA", devices_[d].name), p, 0);
    }
  }
  counters_.stored.store(store_.size(), std::memory_order_relaxed);
}

void EdgeNode::refuse(const std::string& why) {
  counters_.bad_commands.fetch_add(1, std::memory_order_relaxed);
  log_(true, why);
}

void EdgeNode::on_message(const std::string& topic, std::string_view payload, bool retained, uint64_t now_ms) {
  if (!s_.primary_host.empty() && topic == state_topic()) {
    on_state(payload, now_ms);
    return;
  }
  const bool ncmd = topic == node_topic("NCMD");
  const std::string dcmd = node_topic("DCMD") + "/";
  const bool is_dcmd = topic.size() > dcmd.size() && topic.compare(0, dcmd.size(), dcmd) == 0;
  if (!ncmd && !is_dcmd) return;  // not ours (a broker may send more than we asked)
  if (retained) {
    // A retained command would be carried out again at every connect.
    refuse(fmt::format("refused a retained command on {}: commands are never retained", topic));
    return;
  }
  if (ncmd) on_ncmd(payload);
  else on_dcmd(topic.substr(dcmd.size()), payload);
}

void EdgeNode::on_state(std::string_view payload, uint64_t now_ms) {
  // STATE is retained by design: the host's last word is there at every connect.
  nlohmann::json j = nlohmann::json::parse(payload.begin(), payload.end(), nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("online") || !j["online"].is_boolean() ||
      !j.contains("timestamp") || !j["timestamp"].is_number_integer()) {
    refuse(fmt::format("ignored a STATE of {} that is not {{\"online\": true|false, \"timestamp\": ms}}",
                       s_.primary_host));
    return;
  }
  const bool online = j["online"].get<bool>();
  const int64_t ts = j["timestamp"].get<int64_t>();
  if (ts < host_timestamp_) {
    log_(false, fmt::format("ignored a stale STATE of {} (timestamp {} is older than {})", s_.primary_host, ts,
                            host_timestamp_));
    return;
  }
  host_timestamp_ = ts;
  if (online && phase_ == Phase::kWaiting) {
    log_(false, fmt::format("primary host {} is online: births", s_.primary_host));
    births(now_ms);
  } else if (!online && phase_ == Phase::kOnline) {
    log_(true, fmt::format("primary host {} went offline: NDEATH, then a new session waits for it", s_.primary_host));
    reconnect_ = true;
  }
}

void EdgeNode::on_ncmd(std::string_view payload) {
  auto cmd = decode_command(payload, s_.max_command_bytes);
  if (!cmd) {
    refuse("refused an NCMD: " + cmd.error());
    return;
  }
  for (const CommandMetric& c : *cmd) {
    const bool rebirth = c.name == "Node Control/Rebirth" || (s_.aliases && c.has_alias && c.alias == 2);
    if (rebirth && c.has_value && c.value != 0) {
      rebirth_ = true;  // done at the next tick: a burst of them is one rebirth
      continue;
    }
    counters_.writes_refused.fetch_add(1, std::memory_order_relaxed);
    log_(true, fmt::format("refused NCMD metric {}: the node takes only Node Control/Rebirth = true",
                           c.name.empty() ? fmt::format("alias {}", c.alias) : c.name));
  }
}

void EdgeNode::on_dcmd(const std::string& device, std::string_view payload) {
  auto dev = std::find_if(devices_.begin(), devices_.end(), [&](const DeviceDef& d) { return d.name == device; });
  if (dev == devices_.end()) {
    refuse(fmt::format("refused a DCMD for device {}: no task of that name", device));
    return;
  }
  const auto d = static_cast<uint32_t>(dev - devices_.begin());
  auto cmd = decode_command(payload, s_.max_command_bytes);
  if (!cmd) {
    refuse(fmt::format("refused a DCMD for {}: {}", device, cmd.error()));
    return;
  }
  for (const CommandMetric& c : *cmd) {
    int found = -1;
    for (uint32_t i = 0; i < dev->metrics.size() && found < 0; ++i) {
      if (!c.name.empty() ? dev->metrics[i].name == c.name
                          : (s_.aliases && i < state_[d].alias.size() && state_[d].alias[i] == c.alias)) {
        found = static_cast<int>(i);
      }
    }
    const std::string what = c.name.empty() ? fmt::format("alias {}", c.alias) : c.name;
    auto no = [&](const std::string& why) {
      counters_.writes_refused.fetch_add(1, std::memory_order_relaxed);
      log_(true, fmt::format("refused DCMD {}/{}: {}", device, what, why));
    };
    if (found < 0) {
      no("no such metric on this device");
      continue;
    }
    const MetricDef& m = dev->metrics[static_cast<size_t>(found)];
    if (!m.writable) {
      no("not writable (only the set-points listed in `writable` are)");
      continue;
    }
    if (!c.has_value) {
      no(c.why_no_value);
      continue;
    }
    auto r = write_(m.name, c.value);
    if (!r) {
      no(r.error());
      continue;
    }
    counters_.writes_applied.fetch_add(1, std::memory_order_relaxed);
    log_(false, fmt::format("DCMD {}/{}: {}", device, m.name, *r));
  }
}

}  // namespace rtplc::sparkplug
