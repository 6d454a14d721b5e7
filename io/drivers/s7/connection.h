// One S7 connection as a state machine without I/O (spec: s7-client.md, "The engine
// we want"): bytes in, bytes out, events. The epoll engine, the blocking session of
// the command line and the fuzzer all drive the same machine, so what the fuzzer
// proves about it holds for the engine.
//
//   kIdle --open()--> kAwaitConfirm --CC--> kAwaitSetup --setup ack--> kReady
//   any state --malformed frame, COTP disconnect, refused setup--> kFailed
//
// In kReady the owner sends up to the negotiated AmQ jobs; replies are matched to
// them by PDU reference, and a reply whose reference matches nothing in flight is
// dropped and counted (a late answer to a job we gave up on, or a confused peer),
// never delivered to the wrong request.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.h"
#include "io/drivers/s7/protocol.h"

namespace rtplc::s7 {

struct ConnectionConfig {
  uint16_t local_tsap = 0x0100;
  uint16_t remote_tsap = 0x0102;  // PG, rack 0, slot 2
  SetupParams setup{8, 8, 960};   // what we ask for; the PLC may grant less
};

class Connection {
 public:
  enum class State : uint8_t { kIdle, kAwaitConfirm, kAwaitSetup, kReady, kFailed };
  enum class Event : uint8_t { kNone, kReady, kReply, kFailed };

  // A matched reply. `header`'s spans point into the machine's buffer and stay valid
  // until the next feed() or next_event().
  struct Reply {
    uint32_t cookie = 0;
    uint16_t pdu_ref = 0;
    S7Header header;
  };

  // The most jobs we ever keep in flight, whatever the PLC grants.
  static constexpr size_t kMaxInFlight = 32;

  Connection() : Connection(ConnectionConfig{}) {}
  explicit Connection(ConnectionConfig cfg);

  // Starts a connection: queues the COTP connection request.
  void open();
  // Forgets everything (after the socket closed) and returns to kIdle.
  void reset();

  State state() const { return state_; }
  const std::string& error() const { return error_; }
  // What the PLC granted (valid in kReady).
  const SetupParams& negotiated() const { return negotiated_; }
  size_t max_in_flight() const { return max_in_flight_; }
  size_t in_flight() const { return in_flight_.size(); }
  bool can_send() const { return state_ == State::kReady && in_flight_.size() < max_in_flight_; }
  uint64_t dropped_replies() const { return dropped_; }

  // Bytes waiting to be sent; after sending n of them call consume_outbox(n).
  ByteSpan outbox() const { return ByteSpan(out_).subspan(out_pos_); }
  void consume_outbox(size_t n);

  // Appends received bytes.
  void feed(ByteSpan bytes);
  // Processes buffered bytes; returns the next event (kNone: need more bytes).
  Event next_event(Reply& reply);

  // Queues a job. `frame` is a whole encoded job frame (TPKT..data) whose PDU
  // reference is rewritten. Fails if not ready or AmQ is exhausted. Returns the
  // reference used.
  Result<uint16_t> send_job(uint32_t cookie, ByteSpan frame);
  Result<uint16_t> send_read(uint32_t cookie, std::span<const VarSpec> vars);
  Result<uint16_t> send_write(uint32_t cookie, std::span<const VarSpec> vars, std::span<const ByteSpan> values);

  // Gives up on a job (its reply, if it ever comes, will be dropped).
  void forget(uint16_t pdu_ref);

  // Fails the connection from outside (e.g. a timeout), so the state is consistent.
  void fail(std::string message);

 private:
  Event handle_frame(ByteSpan frame, Reply& reply);
  Event handle_s7(ByteSpan payload, Reply& reply);
  Event failed(std::string message);
  uint16_t next_ref();
  void compact();

  struct InFlight {
    uint16_t ref;
    uint32_t cookie;
  };

  ConnectionConfig cfg_;
  State state_ = State::kIdle;
  std::string error_;
  SetupParams negotiated_;
  size_t max_in_flight_ = 1;
  uint16_t ref_counter_ = 0;
  uint16_t setup_ref_ = 0;
  uint64_t dropped_ = 0;
  std::vector<InFlight> in_flight_;
  Bytes out_;
  size_t out_pos_ = 0;
  Bytes in_;
  size_t in_pos_ = 0;
  Bytes fragments_;  // payload of COTP DT units without EOT, joined
  Bytes assembled_;  // a whole fragmented PDU, while its reply is being read
  Bytes scratch_;
};

}  // namespace rtplc::s7
