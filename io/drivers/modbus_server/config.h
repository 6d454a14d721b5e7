// The `modbus-server` driver kind's settings (issue 9, item 2; spec
// io-links.md, "Where data comes from"): a Modbus TCP server inside the
// runtime through which a SCADA or HMI reads channels of the process image
// (inputs, outputs, set-points), each exposed at a register or bit of one of
// the four tables, and writes set-points through holding registers or coils.
// Who may connect: an allow-list of client IPv4 addresses and networks, at
// most `max_clients` at once. Parsed by config.cpp, kept in
// DriverConfig::settings as a ServerSettings.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "config/driver_kinds.h"
#include "io/drivers/modbus/address.h"

namespace rtplc::modbus_server {

using modbus::Address;

// A client address the server accepts: (ip & mask) == network.
struct AllowRule {
  uint32_t network = 0;  // host byte order
  uint32_t mask = 0;
  bool matches(uint32_t ip) const { return (ip & mask) == network; }
};

// One channel at one item. Its engineering value maps to the register(s) as
// raw = (value - offset) / scale, rounded for integer types (reads), and back
// as value = raw * scale + offset (writes). A bit is 1 for a non-zero value.
struct ExposeItem {
  std::string label;  // the channel's label in the program ("ProcVal")
  Address item;       // table, address, type, word order
  double scale = 1.0;
  double offset = 0.0;
  SourcePos pos, label_pos;
};

struct ServerSettings {
  std::string bind = "127.0.0.1";
  uint16_t port = 502;
  std::vector<uint8_t> units;  // answered; empty: every unit id
  uint32_t max_clients = 16;
  double timeout_s = 60;       // a client silent this long is disconnected
  std::vector<AllowRule> allow;  // never empty after parsing (default: 127.0.0.0/8)
  std::string allow_text;        // "127.0.0.0/8" as the link row and logs show it
  std::vector<ExposeItem> items;
  // The set-points a client may write (by label); none unless listed. Modbus
  // TCP has no authentication: whoever `allow` lets in may write these.
  std::vector<std::string> writable;
  std::vector<SourcePos> writable_pos;

  bool allows(uint32_t ip) const;
  bool answers(uint8_t unit) const;
};

// The settings a modbus-server driver's parser stored (empty for another kind).
const ServerSettings& settings_of(const config::DriverConfig& d);

// "10.0.0.0/24" or "10.0.0.7" -> a rule; false when it is neither.
bool parse_allow(const std::string& text, AllowRule& out);

extern const config::DriverKind kConfigKind;

}  // namespace rtplc::modbus_server
