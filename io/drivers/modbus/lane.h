// How the modbus driver's bridge sees the threads that move its bytes: a lane
// serves some slaves, takes the bridge's writes (one producer, never waits)
// and stores samples, outcomes and counters into the Exchange (unit_book.h).
//   TcpMaster  every TCP slave of the driver, one event loop (tcp_master.h)
//   Line       one RTU device and its units, blocking I/O (line.h)
// make_lanes() builds them as the driver runs them; bench/modbus uses it too.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "common/result.h"
#include "io/drivers/modbus/config.h"
#include "io/drivers/modbus/unit_book.h"

namespace rtplc::modbus {

class Lane {
 public:
  virtual ~Lane() = default;
  virtual Result<void> start() = 0;
  virtual void request_stop() = 0;
  // Stops and waits for the thread: what the bridge queued last still goes out.
  virtual void join() = 0;
  // The bridge (one producer): false when the write's queue is full.
  virtual bool push(const WriteJob& job) = 0;
};

struct Lanes {
  std::vector<std::unique_ptr<Lane>> lanes;
  std::vector<uint32_t> lane_of_slave;  // settings.slaves index -> lanes index
};

// One TcpMaster for all TCP slaves (if any), then one Line per RTU device.
Lanes make_lanes(const ModbusSettings& s, Exchange& x, const LineOptions& opt);

}  // namespace rtplc::modbus
