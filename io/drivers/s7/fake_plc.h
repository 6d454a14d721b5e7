// A fake S7 PLC for tests and benchmarks (issue 4, item 6b): one epoll thread serving
// any number of endpoints (thousands, on 127.0.0.0/8 addresses), each a PLC with its
// own memory and its own faults:
//   - a link delay per reply (fixed + uniform jitter), replies pipelined like a link;
//   - blackholing: accept and never answer, or never accept (SYNs go unanswered);
//   - disconnect in the middle of a reply, replies with a wrong PDU reference,
//     malformed replies (lying length fields), each with a probability;
//   - kill (listener and connections closed, connects refused) and restart.
// It ships beside the client it fakes (libmodbus's unit-test server is the model)
// and speaks through the same protocol.h encoders. Not for production use.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "common/result.h"
#include "io/drivers/s7/protocol.h"

namespace rtplc::s7 {

struct FakeBehavior {
  enum class Blackhole : uint8_t { kNone, kAcceptSilent, kNeverAccept };
  uint32_t delay_us = 0;   // added to every reply (COTP, setup and data)
  uint32_t jitter_us = 0;  // plus uniform 0..jitter
  Blackhole blackhole = Blackhole::kNone;
  double p_disconnect_mid_reply = 0;  // per data reply
  double p_wrong_ref = 0;
  double p_malformed = 0;
  uint16_t max_pdu = 480;  // what it grants at most
  uint16_t max_amq = 8;
  uint16_t db_count = 16;   // DB1..DBn exist; others answer "object does not exist"
  uint32_t area_size = 1024;  // bytes of every DB and of I, Q, M; counters/timers: elements
};

struct FakeEndpointSpec {
  std::string address = "127.0.0.1";
  uint16_t port = 0;  // 0: any free port
  FakeBehavior behavior;
};

struct FakeStats {
  uint64_t accepted = 0;
  uint64_t requests = 0;  // S7 jobs received
  uint64_t replies = 0;   // replies sent whole
  uint64_t faults = 0;    // replies damaged on purpose
};

class FakePlc {
 public:
  explicit FakePlc(uint64_t seed = 1);
  ~FakePlc();
  FakePlc(const FakePlc&) = delete;
  FakePlc& operator=(const FakePlc&) = delete;

  // Adds and starts listening on an endpoint; returns its index.
  Result<size_t> add_endpoint(const FakeEndpointSpec& spec);
  size_t endpoint_count() const;
  uint16_t port(size_t ep) const;
  std::string address(size_t ep) const;

  // Serves on a thread of its own until stop().
  Result<void> start();
  void stop();
  // Or serve on the calling thread until `stop_flag` turns true.
  void run(const std::atomic<bool>& stop_flag);

  // Thread-safe controls.
  void set_behavior(size_t ep, const FakeBehavior& b);
  void kill(size_t ep);     // closes the listener and every connection: connects get refused
  void restart(size_t ep);  // listens again on the same address and port
  void drop_connections(size_t ep);
  FakeStats stats(size_t ep) const;
  size_t connections(size_t ep) const;

  // PLC memory, thread-safe. Counters/timers: `offset` is the element index.
  void write_memory(size_t ep, Area area, uint16_t db, uint32_t offset, ByteSpan bytes);
  Bytes read_memory(size_t ep, Area area, uint16_t db, uint32_t offset, size_t len) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtplc::s7
