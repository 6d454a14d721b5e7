// A blocking client for one PLC, for commissioning (`rtplc s7 read/write/info`) and
// tests: connect, read items, write items, one call at a time, each bounded by a
// timeout. It drives the same Connection state machine, planner and reply decoding
// as the engine, with poll() on its one socket instead of the engine's event loop
// (issue 4, item 4). Not for the runtime: use Engine there.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/result.h"
#include "io/drivers/s7/address.h"
#include "io/drivers/s7/connection.h"
#include "io/drivers/s7/link.h"
#include "io/drivers/s7/transfer.h"

namespace rtplc::s7 {

struct SessionOptions {
  std::string host;
  uint16_t port = 102;
  ConnectionConfig connection;
  int connect_timeout_ms = 3000;
  int reply_timeout_ms = 3000;
};

struct SessionInfo {
  Endpoint endpoint;
  SetupParams negotiated;
  double tcp_connect_ms = 0;  // SYN to established
  double setup_ms = 0;        // COTP + setup communication
};

// One item's outcome: a value, or the PLC's reason for refusing it.
struct ItemOutcome {
  uint8_t return_code = 0;
  uint64_t raw = 0;
  bool ok() const { return return_code == kItemOk; }
};

class Session {
 public:
  Session() = default;
  Result<void> connect(const SessionOptions& opt);
  void close();
  bool connected() const { return conn_.state() == Connection::State::kReady; }
  const SessionInfo& info() const { return info_; }

  // Reads every item with as few requests as the PDU allows. The Result fails when
  // the connection does; a single item the PLC refuses has its return code set.
  Result<std::vector<ItemOutcome>> read(std::span<const ItemAddress> items);
  // Writes raws[i] to items[i]; the outcome of each carries the PLC's return code.
  Result<std::vector<ItemOutcome>> write(std::span<const ItemAddress> items, std::span<const uint64_t> raws);

  // Round trip of the smallest read (one byte of M); item errors do not matter.
  Result<double> ping_ms();

 private:
  Result<void> flush();
  Result<Connection::Reply> await_reply(uint16_t ref);
  Result<void> pump_until_ready();

  SessionOptions opt_;
  SessionInfo info_;
  UniqueFd fd_;
  Connection conn_;
  std::vector<DataItem> scratch_;
};

}  // namespace rtplc::s7
