// The `modbus` driver kind's settings (issue 9, item 1; spec io-links.md, "PLC"):
// the slaves one runtime polls — over Modbus TCP (address, port, unit) or RTU
// (a serial device, its line settings, a unit id; slaves naming the same device
// share that line) — and the maps from the PLC blocks' channels to Modbus items:
//   X (prx/pwx) -> discrete inputs     Y (pry/pwy) -> coils
//   M (prm/pwm) -> coils at the slave's `m_offset`
//   R (prr/pwr) -> holding registers (or input registers for reads), 16 or
//                  32 bits, scaled.
// Read channels are `in/PLC<device>/pN.dN.cN`, written ones `out/PLC<device>/...`.
// Parsed by config.cpp; kept in DriverConfig::settings as a ModbusSettings.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "config/driver_kinds.h"
#include "config/map_entries.h"
#include "config/values.h"
#include "fieldbus/link_plan.h"
#include "io/drivers/modbus/address.h"

namespace rtplc::modbus {

using config::ChannelAddress;

struct SlaveConfig {
  std::string name;
  // TCP when `device` is empty.
  std::string address;  // numeric IPv4
  uint16_t port = 502;
  // RTU.
  std::string device;   // /dev/ttyUSB0
  uint32_t baud = 19200;
  char parity = 'E';    // N, E or O
  uint8_t data_bits = 8;
  uint8_t stop_bits = 1;
  uint8_t unit = 1;
  double poll_s = 0.1;
  double timeout_s = 0.5;   // per request
  uint8_t retries = 1;      // further attempts after a timeout, before the poll counts as failed
  uint16_t m_offset = 0;    // M channel address -> coil address + m_offset
  uint16_t max_registers = 125;  // batching caps per request
  uint16_t max_bits = 2000;
  SourcePos pos, name_pos, address_pos;
  // RTU: the fieldbus plan its line runs on (docs/fieldbus.md, "Running a link
  // on a plan"); every slave on one device names the same one. Null: unplanned.
  // Slaves naming one file share one LinkPlan: the file is read and planned once.
  std::shared_ptr<const fieldbus::LinkPlan> plan;
  std::string plan_file;
  SourcePos plan_pos;

  bool rtu() const { return !device.empty(); }
  std::string peer() const;  // "10.0.0.5:502 unit 1", "/dev/ttyUSB0 unit 7"
};

using config::WriteMode;  // config/map_entries.h

struct ChannelMap {
  char device = 'R';    // X, Y, M or R
  ChannelAddress addr;  // the block's p, d, c
  std::string channel;  // "pN.dN.cN"
  std::string slave;    // a name from `slaves`
  Address item;         // the Modbus item (table from the device, m_offset applied)
  double scale = 1.0;   // engineering value = raw * scale + offset (inverse on writes)
  double offset = 0.0;
  double poll_s = 0;    // 0: the slave's poll period
  WriteMode mode = WriteMode::kOnChange;
  SourcePos pos, channel_pos, slave_pos;
  // On a planned line: reads of a loop (sent in its windows) or non-RT (cut to
  // L_n, in what the frames leave); writes are urgent (first in their frame).
  enum class Traffic : uint8_t { kUnplanned, kPeriodic, kUrgent, kNonRt };
  Traffic traffic = Traffic::kUnplanned;
  std::string loop;
};

struct ModbusSettings {
  std::vector<SlaveConfig> slaves;
  std::vector<ChannelMap> reads;   // prx/pry/prm/prr
  std::vector<ChannelMap> writes;  // pwy/pwm/pwr
};

// The settings a modbus driver's parser stored (empty for another kind).
const ModbusSettings& settings_of(const config::DriverConfig& d);

std::string read_key(const ChannelMap& m);
std::string write_key(const ChannelMap& m);

extern const config::DriverKind kConfigKind;

}  // namespace rtplc::modbus
