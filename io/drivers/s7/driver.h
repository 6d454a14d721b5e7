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
//          acknowledged, failed or still pending. A write lost with the link is
//          sent again; one the PLC refused (no such DB, ...) is not, until the
//          value changes or the PLC reconnects: it would only be refused again.
//          An output the task marks bad (a swap dropped it) is not sent. Its
//          delivery entry is bad while its PLC is not connected or its last
//          write failed or was refused.
//   range:  an output is converted to its item's type (after scale and offset)
//          and never clamped or wrapped: 40000 for an INT item, NaN for a REAL,
//          -1 for a WORD are refused. Such a value is not sent (the PLC keeps
//          what it had), counts once in writes_failed per refused value, turns
//          the delivery entry bad until a value that fits is sent, and is
//          logged once per item with the type's range. Why not clamp: a PLC
//          holding 32767 where the task meant 40000 looks delivered, and is not.
//   status: each PLC's state, round-trip times and histogram, timeouts, errors,
//          reconnects and write counts -> the image's generic link rows.
//   log:    link down/up (the first few at once, then at most one per PLC every
//          few seconds; a message held back is logged when the interval ends,
//          with the PLC's state then and a count of the changes in between, so
//          the last word in the log is always the link's current state), a PLC
//          unreachable at start, and each item the PLC refuses, once per item,
//          with the S7 return code by name.
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
  ~S7Driver() override {
    request_stop();
    join();
  }
  // Registers PLCs and items with the engine (no network yet). Errors name the item.
  Result<void> prepare();
  Result<void> can_send(uint32_t j, double value) const override;

 private:
  struct Read {
    ItemId item;
    uint32_t index;
    Sample last;          // what was published last (kept when a read misses)
    bool refusal_logged = false;
    std::string what;     // "PLC f01 item DB1.DBD8:REAL"
  };
  struct Write {
    char range[48] = {};  // range_text(type), made once: the cycle logs without allocating
    ItemId item;
    config::WriteMode mode;
    uint32_t plc;  // index into plcs_
    DataType type = DataType::kByte;
    double scale = 1;
    double offset = 0;
    double last = 0;       // the value last sent
    bool sent = false;
    bool resend = false;
    bool failed = false;   // the last write ended failed or refused
    bool refusal_logged = false;
    bool out_of_range = false;  // the task's current value does not fit the type
    bool range_logged = false;
    double refused_value = 0;   // the value out_of_range refers to (counted once)
    WriteTicket ticket;
    std::string what;
  };
  struct PlcTrack {
    PlcState state = PlcState::kUnused;
    uint64_t connects = 0;
    bool ever_ready = false;
    bool said_unreachable = false;
    // Rate limit of down/up messages: a budget of messages, one more every
    // interval up to the burst; changes made while it is empty are counted and
    // summed up in the next message.
    uint32_t log_budget = 0;
    int64_t next_refill_ns = 0;
    uint32_t unlogged = 0;    // link changes since the last message
  };

  Result<void> on_start() override;
  void cycle(int64_t now_ns) noexcept override;
  void on_stop() noexcept override;
  void on_joined() noexcept override;
  void cycle_write(uint32_t j, uint32_t k, int64_t now_ns) noexcept;
  void send(Write& w, double value) noexcept;
  void track_status(int64_t now_ns) noexcept;
  void log_link_change(size_t i, const PlcStatus& st) noexcept;
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
