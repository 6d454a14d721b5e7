// One Modbus master connection over libmodbus, TCP or RTU (the transport table
// is libmodbus's own): the blocking requests the driver's I/O threads and the
// commissioning commands make, each ending in a small Outcome instead of errno
// juggling. Not thread-safe: one thread owns a client.
#pragma once

#include <cstdint>
#include <string>

#include "common/result.h"
#include "io/drivers/modbus/address.h"

struct _modbus;

namespace rtplc::modbus {

struct Outcome {
  enum class Kind : uint8_t {
    kOk,
    kTimeout,    // no (complete) answer in time
    kException,  // the slave answered with an exception `code`
    kProtocol,   // an answer that makes no sense (length, transaction or unit id, function)
    kBadCrc,     // RTU: an answer whose CRC is wrong (noise on the line, bad wiring or termination)
    kLink,       // the connection is gone (reset, refused, closed)
  };
  Kind kind = Kind::kOk;
  int code = 0;  // kException: the exception code; else the errno
  bool ok() const { return kind == Kind::kOk; }
};
// "timeout", "illegal data address (exception 2)", "connection reset by peer".
std::string outcome_text(const Outcome& o);

struct SerialLine {
  std::string device;
  uint32_t baud = 19200;
  char parity = 'E';
  uint8_t data_bits = 8;
  uint8_t stop_bits = 1;
};

class Client {
 public:
  static Result<Client> tcp(const std::string& ipv4, uint16_t port);
  static Result<Client> rtu(const SerialLine& line);
  Client() = default;
  Client(Client&& o) noexcept;
  Client& operator=(Client&& o) noexcept;
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;
  ~Client();

  void set_timeout_ns(int64_t ns);
  void set_unit(uint8_t unit);
  Outcome connect();
  // Takes an already open descriptor (a socketpair: the fuzzer) as connected,
  // instead of connect(); close() closes it.
  void attach(int fd);
  void close();
  bool connected() const { return connected_; }
  // Drops whatever is still in the receive buffer (a late reply after a timeout).
  void flush();

  // `count` registers, or bits (one 0/1 per word), from `start` of `table`.
  Outcome read(Table table, uint16_t start, uint16_t count, uint16_t* words);
  // One item: width(a) words (a bit as 0/1 in words[0]); one register with
  // FC 6, a pair with FC 16, a coil with FC 5.
  Outcome write(const Address& a, const uint16_t* words);

 private:
  Outcome fail();
  _modbus* ctx_ = nullptr;
  bool connected_ = false;
};

}  // namespace rtplc::modbus
