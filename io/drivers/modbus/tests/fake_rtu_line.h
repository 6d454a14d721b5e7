// The RTU tests' line: our fake slave on one end of a socat pty pair, the
// master (our client, the CLI, a modbus driver's `device:`) on the other, at
// 19200 baud 8N1. Parity N: a pty refuses even or odd parity through pyserial
// here, and has no UART to use it anyway. A test skips when available() is
// false (no socat) and fails when start() does:
//   FakeRtuLine line({7});
//   if (!line.available()) GTEST_SKIP() << line.why();
//   ASSERT_TRUE(line.start().ok());
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.h"
#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/modbus/tests/pty_pair.h"

namespace rtplc::modbus::testing {

class FakeRtuLine {
 public:
  static constexpr uint32_t kBaud = 19200;

  // The fake answers as `units` (empty: every unit); `delay_ns` is its
  // kMagicDelay's delay.
  explicit FakeRtuLine(std::vector<uint8_t> units, int64_t delay_ns = FakeSlaveOptions{}.delay_ns)
      : slave_(options(pty_, std::move(units), delay_ns)) {}

  bool available() const { return pty_.available(); }
  const std::string& why() const { return pty_.why(); }
  // Opens the fake's end of the pair and serves it.
  Result<void> start() { return slave_.start(); }

  FakeSlave& slave() { return slave_; }
  // The master's end: a driver's `device:`, the CLI's --rtu.
  const std::string& device() const { return pty_.b(); }
  // The master's end with the line's settings, for Client::rtu().
  SerialLine master() const { return {pty_.b(), kBaud, 'N', 8, 1}; }

 private:
  static FakeSlaveOptions options(const PtyPair& pty, std::vector<uint8_t> units, int64_t delay_ns) {
    FakeSlaveOptions o;
    o.serial = {pty.a(), kBaud, 'N', 8, 1};
    o.units = std::move(units);
    o.delay_ns = delay_ns;
    return o;
  }

  PtyPair pty_;  // before slave_: its options name the pair's end
  FakeSlave slave_;
};

}  // namespace rtplc::modbus::testing
