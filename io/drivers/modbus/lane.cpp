// The lanes of one modbus driver (see lane.h).
#include "io/drivers/modbus/lane.h"

#include <map>
#include <string>

#include "io/drivers/modbus/line.h"
#include "io/drivers/modbus/tcp_master.h"

namespace rtplc::modbus {

Lanes make_lanes(const ModbusSettings& s, Exchange& x, const LineOptions& opt) {
  Lanes out;
  out.lane_of_slave.assign(s.slaves.size(), 0);
  std::vector<uint32_t> tcp;
  std::map<std::string, std::vector<uint32_t>> rtu_lines;
  for (uint32_t i = 0; i < s.slaves.size(); ++i) {
    if (s.slaves[i].rtu()) rtu_lines[s.slaves[i].device].push_back(i);
    else tcp.push_back(i);
  }
  if (!tcp.empty()) {
    for (uint32_t slave : tcp) out.lane_of_slave[slave] = 0;
    out.lanes.push_back(std::make_unique<TcpMaster>(s, tcp, x, opt));
  }
  for (auto& [device, slaves] : rtu_lines) {
    for (uint32_t slave : slaves) out.lane_of_slave[slave] = static_cast<uint32_t>(out.lanes.size());
    out.lanes.push_back(std::make_unique<Line>(s, slaves, x, opt));
  }
  return out;
}

}  // namespace rtplc::modbus
