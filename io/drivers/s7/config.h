// The `s7` driver kind's settings (spec s7-client.md, io-links.md "ETH"): the
// Siemens PLCs one runtime talks to, and the maps from the blocks' (p, d, c)
// addresses to S7 items. `era`/`erd` read channels `in/ETH/pN.dN.cN`, `ewa`/`ewd`
// write channels `out/ETH/pN.dN.cN`. Parsed by driver_s7.cpp; kept in
// DriverConfig::settings as an S7DriverSettings.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "config/driver_kinds.h"
#include "config/map_entries.h"
#include "config/values.h"

namespace rtplc::s7 {

using config::ChannelAddress;

struct S7PlcConfig {
  std::string name;     // unique inside the driver
  std::string address;  // numeric IPv4
  uint16_t port = 102;
  // TSAPs: from rack/slot and the connection type, or given explicitly.
  uint8_t rack = 0;
  uint8_t slot = 1;
  uint8_t connection_type = 1;  // 1 PG, 2 OP, 3 S7 basic
  std::optional<uint16_t> local_tsap;
  std::optional<uint16_t> remote_tsap;
  double poll_s = 0.1;
  double reply_timeout_s = 1.0;
  uint16_t pdu = 480;
  uint16_t amq = 8;
  SourcePos pos, name_pos, address_pos;
};

struct S7ChannelMap {
  std::string channel;   // "pN.dN.cN" of the era/erd/ewa/ewd block
  ChannelAddress addr;
  std::string plc;       // a name from `plcs`
  std::string item;      // S7 address as `rtplc s7 read` takes it: DB1.DBD8:REAL, M0.1, ...
  double scale = 1.0;    // engineering value = raw * scale + offset (inverse on writes)
  double offset = 0.0;
  config::WriteMode mode = config::WriteMode::kOnChange;
  SourcePos pos, channel_pos, plc_pos, item_pos;
};

struct S7DriverSettings {
  std::vector<S7PlcConfig> plcs;
  std::vector<S7ChannelMap> reads;   // era / erd
  std::vector<S7ChannelMap> writes;  // ewa / ewd
};

// The settings an s7 driver's parser stored (empty for a config not parsed as s7).
const S7DriverSettings& settings_of(const config::DriverConfig& d);

// The channel key of a read (`in/ETH/...`) or write (`out/ETH/...`) map.
std::string read_key(const S7ChannelMap& m);
std::string write_key(const S7ChannelMap& m);

extern const config::DriverKind kConfigKind;

}  // namespace rtplc::s7
