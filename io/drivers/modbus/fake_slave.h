// A Modbus slave, TCP or RTU, with deterministic fault injection (issue 9,
// item 3), in the style of libmodbus's unit-test server: ordinary requests
// read and write four 65536-entry tables; a request whose address range covers
// a magic address misbehaves in one defined way, every time:
//   65281..65291  (0xFF01..0xFF0B)  answers with exception (address - 0xFF00)
//   65500  kMagicDelay      answers after `delay_ns`
//   65501  kMagicDrop       closes the connection instead of answering
//   65502  kMagicBadLength  answers reads with a byte count two bytes too long
//   65503  kMagicSilent     never answers
//   65504  kMagicBadId      answers with another transaction id (RTU: unit id)
//   65505  kMagicBadCrc     RTU: answers with a wrong CRC (TCP answers normally)
// Whole-slave faults for tests: set_silent() (accepts, never answers), kill()
// and restart() (gone, then back on the same port or device), a delay on every
// reply. Units not in `units` never answer (a dead unit on an RTU line);
// set_units() changes which do while it runs (a unit that comes back).
// The request handling (respond(), serve()) is the same for both transports;
// only the framing differs, through the FrameOps tables of pdu.h; requests
// are checked with pdu.h's parse_request as the modbus-server kind does.
// RTU specifics: a request with a bad CRC is ignored as a real slave would;
// a partial frame followed by a quiet gap is discarded (resynchronisation);
// unit 0 (broadcast) is acted upon and never answered; the drop fault cannot
// hang up a serial line, so it is silence there.
// One thread serves every client (or the serial line) with poll(); the tables
// are behind a mutex (this is a test peer, not an RT path).
// `rtplc modbus fake-slave` serves it.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/result.h"
#include "io/drivers/modbus/address.h"
#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/pdu.h"

namespace rtplc::modbus {

inline constexpr uint16_t kMagicExceptionBase = 0xFF00;
inline constexpr uint16_t kMagicDelay = 65500;
inline constexpr uint16_t kMagicDrop = 65501;
inline constexpr uint16_t kMagicBadLength = 65502;
inline constexpr uint16_t kMagicSilent = 65503;
inline constexpr uint16_t kMagicBadId = 65504;
inline constexpr uint16_t kMagicBadCrc = 65505;

struct FakeSlaveOptions {
  std::string bind = "127.0.0.1";
  uint16_t port = 0;             // 0: any free port
  SerialLine serial;             // serial.device given: RTU on that device instead of TCP
  std::vector<uint8_t> units;    // units that answer; empty: every unit
  int64_t delay_ns = 2000000000; // kMagicDelay's delay
  int64_t reply_delay_ns = 0;    // every reply waits this long (a slow slave)
};

// What the slave does about one request frame.
struct Response {
  enum class Action : uint8_t { kSilent, kReply, kDrop };
  Action action = Action::kSilent;
  int64_t delay_ns = 0;        // kReply: how long after the request
  std::vector<uint8_t> bytes;  // kReply: the framed answer
};

class FakeSlave {
 public:
  explicit FakeSlave(FakeSlaveOptions opt = {});
  ~FakeSlave();
  FakeSlave(const FakeSlave&) = delete;
  FakeSlave& operator=(const FakeSlave&) = delete;

  Result<void> start();
  void stop();
  uint16_t port() const { return port_; }  // TCP
  bool rtu() const { return !opt_.serial.device.empty(); }
  const FrameOps& frames() const { return rtu() ? kRtuFrames : kTcpFrames; }

  // The request handling without I/O (the serving thread and the fuzzer use
  // it): takes the whole frames from the front of `in` and says what to do
  // about each in `out`. False when the connection is to be closed (TCP: a
  // stream that is not Modbus TCP, or the drop fault); RTU never hangs up and
  // discards garbage instead.
  bool serve(const FrameOps& ops, std::vector<uint8_t>& in, std::vector<Response>& out);
  Response respond(const FrameOps& ops, const uint8_t* frame, size_t len);

  // Gone: the listener and every connection closed. restart() listens again.
  void kill();
  Result<void> restart();
  void set_silent(bool silent) { silent_.store(silent); }
  void set_units(std::vector<uint8_t> units);

  uint16_t get(Table t, uint16_t address) const;
  void set(Table t, uint16_t address, uint16_t value);
  // An engineering value at an item (encode()d), for tests and --set.
  void put(const Address& a, double value);
  double value(const Address& a) const;
  uint64_t requests() const { return requests_.load(); }
  // Every request in arrival order (function, address, span, CLOCK_MONOTONIC),
  // the first 100,000: a test checks a planned line's order and sizes with it.
  struct LoggedRequest {
    uint8_t function = 0;
    uint16_t address = 0;
    uint16_t count = 0;
    int64_t at_ns = 0;
  };
  std::vector<LoggedRequest> request_log() const;
  uint64_t writes() const { return writes_.load(); }
  // The answer PDU to one request PDU (function code onwards) against the
  // tables; `magic` says which fault, if any, the request's range covered.
  // Public for servers that run their own socket loop (bench/modbus's lean
  // fake serves a hundred slaves from one epoll loop with it).
  std::vector<uint8_t> answer(const uint8_t* pdu, size_t len, uint16_t& magic);

 private:
  struct Client {
    int fd = -1;
    std::vector<uint8_t> in;
    int64_t last_rx_ns = 0;
  };
  struct Pending {
    int fd;
    int64_t due_ns;
    std::vector<uint8_t> bytes;
  };
  void run();
  Result<void> listen();
  Result<void> open_serial();

  FakeSlaveOptions opt_;
  mutable std::mutex mu_;
  std::vector<uint16_t> tables_[4];
  std::vector<LoggedRequest> log_;  // under mu_
  std::atomic<int> listen_fd_{-1};  // TCP: the listener; RTU: the serial device
  std::atomic<bool> stop_{false};
  std::atomic<bool> silent_{false};
  std::atomic<bool> kill_{false};
  std::atomic<uint64_t> requests_{0}, writes_{0};
  uint16_t port_ = 0;
  std::thread thread_;
};

}  // namespace rtplc::modbus
