// The `s7` I/O driver (spec s7-client.md; io-links.md "ETH"): the bridge
// between the process image and the S7 engine (engine.h).
//
// The engine runs its own epoll thread and owns every PLC connection. The
// bridge thread runs at the driver's period and never blocks on the network:
//   reads  (era/erd): the engine's latest sample of each item -> the driver's
//          inputs, with quality (good / stale / bad) and the time the PLC
//          answered. A PLC that is gone leaves its last value, marked bad or
//          stale; a value that is not a finite number is bad.
//   writes (ewa/ewd): the task's output -> engine.write() when it changed (or
//          every cycle, as configured), and every output again after its PLC
//          reconnected (a restarted PLC holds its reset values). Each write ends
//          acknowledged, failed (then sent again) or still pending. An output
//          the task marks bad (a swap dropped it) is not sent. Its delivery
//          entry is bad while its PLC is not connected or its last write failed.
//   status: each PLC's state, round-trip times and histogram, timeouts, errors,
//          reconnects and write counts -> the image's generic link rows.
//   log:    link down/up (at most one message per PLC every few seconds, with a
//          count of what was held back), a PLC unreachable at start, and each
//          item the PLC refuses, once per item, with the S7 return code by name.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "io/drivers/driver.h"
#include "io/drivers/s7/config.h"
#include "io/drivers/s7/engine.h"

namespace rtplc::s7 {

class S7Driver final : public io::Driver {
 public:
  explicit S7Driver(const io::DriverSetup& setup);
  // Registers PLCs and items with the engine (no network yet). Errors name the item.
  Result<void> prepare();

 private:
  struct Read {
    ItemId item;
    uint32_t index;
    Sample last;          // what was published last (kept when a read misses)
    bool refusal_logged = false;
    std::string what;     // "PLC f01 item DB1.DBD8:REAL"
  };
  struct Write {
    ItemId item;
    S7WriteMode mode;
    uint32_t plc;  // index into plcs_
    double last = 0;
    bool sent = false;
    bool resend = false;
    bool failed = false;  // the last write ended failed
    bool refusal_logged = false;
    WriteTicket ticket;
    std::string what;
  };
  struct PlcTrack {
    PlcState state = PlcState::kUnused;
    uint64_t connects = 0;
    bool ever_ready = false;
    bool said_unreachable = false;
    int64_t next_log_ns = 0;  // rate limit of down/up messages
    uint32_t held_back = 0;   // changes not logged because of it
  };

  Result<void> on_start() override;
  void cycle(int64_t now_ns) noexcept override;
  void on_stop() noexcept override;
  void on_joined() noexcept override;
  void track_status(int64_t now_ns) noexcept;
  void publish_status() noexcept;

  const S7DriverSettings& settings_;
  Engine engine_;
  std::vector<PlcId> plcs_;
  std::vector<PlcTrack> track_;
  std::vector<Read> reads_;
  std::vector<Write> writes_;
  // Per-PLC write outcomes counted here (the engine counts per engine).
  std::vector<uint64_t> acked_, failed_, rejected_, pending_;
  int64_t next_status_ = 0;
  bool engine_started_ = false;
};

extern const io::DriverKind kDriverKind;

}  // namespace rtplc::s7
