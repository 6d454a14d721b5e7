// The `modbus` I/O driver (issue 9, item 1; spec io-links.md, "PLC"): the
// bridge between the process image and the driver's lanes (lane.h): one event
// loop for all its TCP slaves (tcp_master.h) and one line per RTU device
// (line.h). The bridge thread never blocks:
//   reads   each item's latest sample -> the driver's inputs, good while its
//           slave answers its block, bad (last value kept) after a timeout, an
//           exception or a lost connection.
//   writes  the task's output, scaled back to raw and range-checked, -> the
//           line's queue when it changed (or every cycle), and every output of a
//           slave again after it reconnected. A value out of range for its item
//           is refused here (counted rejected, logged once) and never sent.
//           Its delivery entry is bad while its slave is down or its last write
//           failed.
//   status  each slave's counters -> its generic link row; a line on a
//           fieldbus plan also puts its per-class delays in its first slave's
//           row (line.h, io/drivers/planned_link.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "io/drivers/driver.h"
#include "io/drivers/modbus/config.h"
#include "io/drivers/modbus/lane.h"

namespace rtplc::modbus {

class ModbusDriver final : public io::Driver {
 public:
  explicit ModbusDriver(const io::DriverSetup& setup);
  ~ModbusDriver() override;
  Result<void> prepare();
  Result<void> can_send(uint32_t j, double value) const override;

 private:
  struct Write {
    char what[48] = {};  // "hr:2:f32", for the log without allocating
    uint32_t lane = 0;
    uint32_t slave = 0;
    double last = 0;
    bool sent = false;
    bool resend = false;
    bool failed = false;
    bool refusal_logged = false;
    uint64_t in_flight = 0;  // sequence of the job the line has not answered yet
    uint64_t next_seq = 1;
  };
  struct SlaveTrack {
    UnitStatus st;
    uint64_t connects = 0;
    uint64_t acked = 0, failed = 0, rejected = 0, pending = 0;
  };

  Result<void> on_start() override;
  void cycle(int64_t now_ns) noexcept override;
  void on_stop() noexcept override;
  void on_joined() noexcept override;
  void track_status() noexcept;
  void publish_status() noexcept;
  bool slave_up(uint32_t slave) const {
    return track_[slave].st.state == static_cast<uint8_t>(io::LinkState::kUp);
  }

  const ModbusSettings& settings_;
  Exchange exchange_;
  std::vector<std::unique_ptr<Lane>> lanes_;
  std::vector<ItemSample> reads_;  // last sample per read map
  std::vector<Write> writes_;
  std::vector<SlaveTrack> track_;
  std::vector<uint8_t> planned_row_;  // 1: the first slave of a line on a plan (its row has the classes)
  int64_t next_status_ = 0;
};

extern const io::DriverKind kDriverKind;

}  // namespace rtplc::modbus
