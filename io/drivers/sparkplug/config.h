// The `sparkplug` driver kind's settings (docs/sparkplug.md): the broker and how
// to reach it, the Sparkplug identity of this box (group, edge node), the
// primary host it waits for, which channels it publishes with which deadband,
// which set-points a DCMD may write, and the store kept while nobody listens.
// Parsed by config.cpp, kept in DriverConfig::settings as SparkplugSettings.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "config/driver_kinds.h"

namespace rtplc::sparkplug {

struct SparkplugSettings {
  // Broker: host and port; tls for mqtts:// (then ca, and cert/key for a
  // client certificate).
  std::string host = "127.0.0.1";
  uint16_t port = 1883;
  bool tls = false;
  std::string ca_file, cert_file, key_file;
  std::string username, password;
  double keepalive_s = 10;
  bool mqtt5 = true;  // MQTT 5 (else 3.1.1)

  std::string group;         // group_id
  std::string node;          // edge_node_id
  std::string primary_host;  // host_id whose STATE we wait for; "" = none

  bool publish_all = true;
  std::vector<std::string> publish;  // labels, when !publish_all
  std::vector<SourcePos> publish_pos;
  std::map<std::string, double> deadband;  // label -> absolute deadband (engineering units)
  std::map<std::string, SourcePos> deadband_pos;
  std::vector<std::string> writable;  // set-points a DCMD may write
  std::vector<SourcePos> writable_pos;
  bool aliases = false;  // DATA messages carry aliases instead of names

  uint32_t store_and_forward = 10000;  // changes kept while offline (0: none)
  uint32_t replay_rate = 2000;         // stored changes replayed per second after the births
  uint32_t max_command_bytes = 65536;  // a larger NCMD/DCMD is refused unread
  SourcePos pos;

  std::string broker_text() const;  // "127.0.0.1:1883", "mqtts://host:8883"
};

const SparkplugSettings& settings_of(const config::DriverConfig& d);

// "127.0.0.1:1883", "mqtt://host", "mqtts://host:8883" -> s.host, s.port, s.tls
// (the config's `broker`, the CLI's BROKER); false with `why` otherwise.
bool parse_broker(const std::string& text, SparkplugSettings& s, std::string& why);

// Group, edge node and host ids: UTF-8 without the MQTT specials / + # (3.0).
bool valid_id(const std::string& id);

extern const config::DriverKind kConfigKind;

}  // namespace rtplc::sparkplug
