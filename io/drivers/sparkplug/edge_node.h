// The Sparkplug B 3.0 edge node as a state machine (docs/sparkplug.md,
// "Behaviour"), apart from any socket so that tests drive it message by
// message: what it publishes when the session comes up, when the primary host
// says online or offline, when a command arrives, when a value changes, when a
// device appears, changes or stops, and when the session ends.
//
//   offline      no broker session: changes go into the store
//   waiting      a session, but the primary host is not online (primary_host
//                set): changes go into the store, nothing is born
//   online       NBIRTH (seq 0), a DBIRTH per device, then the stored changes
//                (is_historical) at replay_rate, then live DATA by exception
//
// One seq counter 0..255 across NBIRTH, DBIRTH, NDATA, DDATA and DDEATH; the
// NBIRTH and the NDEATH (the session's will) carry the session's bdSeq.
//
// Everything here runs on the driver's link thread (it allocates); the
// counters are atomics the driver's bridge thread copies into its link row.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "common/quality.h"
#include "common/result.h"
#include "io/drivers/sparkplug/config.h"
#include "io/drivers/sparkplug/payload.h"

namespace rtplc::sparkplug {

// One metric of a device: a channel of the process image.
struct MetricDef {
  std::string name;      // the channel's label
  uint32_t channel = 0;  // the image's channel index (the sampler's key)
  bool digital = false;  // Boolean, else Double
  bool writable = false; // a DCMD may write it (a set-point listed in `writable`)
  double deadband = 0;   // absolute; 0: every change
};

// A device: a task and the channels its program uses.
struct DeviceDef {
  std::string name;  // the task's name
  bool running = true;
  std::vector<MetricDef> metrics;
  bool operator==(const DeviceDef& o) const;
};

// One reading of a channel.
struct Sample {
  double value = 0;
  Quality quality = Quality::kBad;
  bool forced = false;
  uint64_t timestamp_ms = 0;  // ms since 1970 (Sparkplug's time)
};

struct NodeCounters {
  std::atomic<uint64_t> sessions{0};        // broker sessions that came up
  std::atomic<uint64_t> sessions_lost{0};
  std::atomic<uint64_t> node_births{0};     // NBIRTHs sent (first and rebirths)
  std::atomic<uint64_t> published{0};       // messages handed to the broker
  std::atomic<uint64_t> publish_errors{0};
  std::atomic<uint64_t> writes_applied{0};  // DCMD metrics that set a set-point
  std::atomic<uint64_t> writes_refused{0};  // command metrics refused (not writable, bad value, ...)
  std::atomic<uint64_t> bad_commands{0};    // command payloads refused whole (malformed, retained, ...)
  std::atomic<uint64_t> stored{0};          // changes in the store now
  std::atomic<uint64_t> dropped{0};         // changes the full store dropped
  std::atomic<uint64_t> replayed{0};        // stored changes sent after births
  std::atomic<uint32_t> seq{0};             // the last seq sent
  std::atomic<uint64_t> bdseq{0};           // this session's bdSeq
  std::atomic<uint8_t> phase{0};            // EdgeNode::Phase
};

class EdgeNode {
 public:
  enum class Phase : uint8_t { kOffline = 0, kWaiting = 1, kOnline = 2 };

  // Publishes one message (QoS, retain); false when the session cannot take it.
  using Publish = std::function<bool(const std::string& topic, std::string payload, int qos, bool retain)>;
  // Sets a set-point through the operator API; the text on success, or why not.
  using Write = std::function<Result<std::string>(const std::string& label, double value)>;
  // Reads one channel now.
  using Sampler = std::function<Sample(uint32_t channel)>;
  // A line for the runtime's log (warning: a refusal or a fault).
  using Log = std::function<void(bool warning, const std::string& line)>;

  EdgeNode(const SparkplugSettings& s, Publish publish, Write write, Sampler sampler, Log log);

  // Topics.
  std::string node_topic(std::string_view type) const;  // spBv1.0/G/NBIRTH/N
  std::string device_topic(std::string_view type, const std::string& device) const;
  std::string state_topic() const;  // spBv1.0/STATE/HOST ("" without a primary host)
  // What to subscribe to before the births: NCMD, DCMD (+ STATE).
  std::vector<std::string> subscriptions() const;

  // The will of a session with this bdSeq: the NDEATH payload.
  std::string death_payload(uint64_t bdseq, uint64_t now_ms) const;

  // The devices now (the driver tells on every change of tasks, programs or
  // channels); a changed or removed device gets its DDEATH, a new or changed
  // one its DBIRTH when online.
  void set_devices(std::vector<DeviceDef> devices, uint64_t now_ms);

  // The session came up with this bdSeq (its will carries the same).
  void session_up(uint64_t bdseq, uint64_t now_ms);
  // The session ended (lost or closed).
  void session_down();
  // An orderly end: publishes NDEATH (the caller disconnects after).
  void shutdown(uint64_t now_ms);
  // A message on a subscribed topic.
  void on_message(const std::string& topic, std::string_view payload, bool retained, uint64_t now_ms);
  // Every sample period: exceptions, the store's replay. `dirty`, when given,
  // says per device whether anything it reads may have changed (the driver
  // knows from the image's publication counters); the others are not sampled.
  void tick(uint64_t now_ms, const std::vector<bool>* dirty = nullptr);

  // True when the primary host went offline: the caller ends this session
  // (NDEATH sent) and connects again with a new bdSeq.
  bool wants_reconnect() const { return reconnect_; }

  Phase phase() const { return phase_; }
  const NodeCounters& counters() const { return counters_; }
  const std::vector<DeviceDef>& devices() const { return devices_; }

 private:
  struct Last {
    bool has = false;
    Sample s;
  };
  struct DeviceState {
    bool born = false;
    uint64_t generation = 0;  // bumps when the definition changes
    std::vector<Last> last;   // per metric: the last value sent or stored
    std::vector<uint64_t> alias;
  };
  struct Stored {
    uint32_t device = 0, metric = 0;
    uint64_t generation = 0;
    Sample s;
    bool historical = true;
  };

  void births(uint64_t now_ms);
  void device_birth(uint32_t d, uint64_t now_ms);
  void device_death(uint32_t d, uint64_t now_ms);
  bool send(const std::string& topic, const Payload& p, int qos = 0);
  uint64_t next_seq();
  bool changed(const MetricDef& m, const Last& l, const Sample& s) const;
  void put_metric(Metric& m, uint32_t d, uint32_t i, const Sample& s, bool with_name) const;
  void store(uint32_t d, uint32_t i, const Sample& s, bool historical);
  void replay(uint64_t now_ms);
  void on_state(std::string_view payload, uint64_t now_ms);
  void on_ncmd(std::string_view payload);
  void on_dcmd(const std::string& device, std::string_view payload);
  void refuse(const std::string& why);

  const SparkplugSettings& s_;
  Publish publish_;
  Write write_;
  Sampler sampler_;
  Log log_;
  std::string ns_;  // "spBv1.0/GROUP/"

  Phase phase_ = Phase::kOffline;
  bool reconnect_ = false;
  bool rebirth_ = false;        // a Node Control/Rebirth waits for the next tick
  uint64_t generation_ = 0;     // device definitions handed out
  uint64_t bdseq_ = 0;
  uint8_t seq_ = 0;
  bool seq_started_ = false;
  uint64_t next_alias_ = 1;
  int64_t host_timestamp_ = -1;  // the newest STATE timestamp seen

  std::vector<DeviceDef> devices_;
  std::vector<DeviceState> state_;
  std::deque<Stored> store_;
  double replay_budget_ = 0;
  uint64_t replay_ms_ = 0;
  NodeCounters counters_;
};

}  // namespace rtplc::sparkplug
