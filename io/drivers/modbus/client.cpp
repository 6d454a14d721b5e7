// The libmodbus master connection (see client.h).
#include "io/drivers/modbus/client.h"

#include <fmt/format.h>
#include <modbus/modbus.h>

#include <cerrno>
#include <cstring>

namespace rtplc::modbus {

std::string outcome_text(const Outcome& o) {
  switch (o.kind) {
    case Outcome::Kind::kOk: return "ok";
    case Outcome::Kind::kTimeout: return "timeout (no answer)";
    case Outcome::Kind::kException: return exception_text(o.code);
    case Outcome::Kind::kBadCrc: return "bad CRC (the answer was corrupted on the line)";
    case Outcome::Kind::kProtocol:
    case Outcome::Kind::kLink: return modbus_strerror(o.code);
  }
  return "?";
}

Result<Client> Client::tcp(const std::string& ipv4, uint16_t port) {
  Client c;
  c.ctx_ = modbus_new_tcp(ipv4.c_str(), port);
  if (!c.ctx_) return make_error(fmt::format("cannot set up Modbus TCP to {}:{}: {}", ipv4, port, modbus_strerror(errno)));
  return c;
}

Result<Client> Client::rtu(const SerialLine& line) {
  Client c;
  c.ctx_ = modbus_new_rtu(line.device.c_str(), static_cast<int>(line.baud), line.parity, line.data_bits,
                          line.stop_bits);
  if (!c.ctx_) return make_error(fmt::format("cannot set up Modbus RTU on {}: {}", line.device, modbus_strerror(errno)));
  return c;
}

Client::Client(Client&& o) noexcept : ctx_(o.ctx_), connected_(o.connected_) {
  o.ctx_ = nullptr;
  o.connected_ = false;
}

Client& Client::operator=(Client&& o) noexcept {
  if (this != &o) {
    this->~Client();
    ctx_ = o.ctx_;
    connected_ = o.connected_;
    o.ctx_ = nullptr;
    o.connected_ = false;
  }
  return *this;
}

Client::~Client() {
  if (!ctx_) return;
  close();
  modbus_free(ctx_);
  ctx_ = nullptr;
}

void Client::set_timeout_ns(int64_t ns) {
  const auto sec = static_cast<uint32_t>(ns / 1000000000);
  const auto usec = static_cast<uint32_t>((ns % 1000000000) / 1000);
  modbus_set_response_timeout(ctx_, sec, usec);
}

void Client::set_unit(uint8_t unit) { modbus_set_slave(ctx_, unit); }

Outcome Client::connect() {
  close();
  if (modbus_connect(ctx_) != 0) return Outcome{Outcome::Kind::kLink, errno};
  connected_ = true;
  return {};
}

void Client::attach(int fd) {
  close();
  modbus_set_socket(ctx_, fd);
  connected_ = true;
}

void Client::close() {
  if (connected_) modbus_close(ctx_);
  connected_ = false;
}

void Client::flush() {
  if (connected_) modbus_flush(ctx_);
}

// Classifies libmodbus's errno after a failed request.
Outcome Client::fail() {
  const int e = errno;
  if (e > MODBUS_ENOBASE && e <= EMBXGTAR) return Outcome{Outcome::Kind::kException, e - MODBUS_ENOBASE};
  if (e == ETIMEDOUT) return Outcome{Outcome::Kind::kTimeout, e};
  if (e == EMBBADCRC) return Outcome{Outcome::Kind::kBadCrc, e};
  if (e == EMBBADDATA || e == EMBBADEXC || e == EMBUNKEXC || e == EMBMDATA || e == EMBBADSLAVE) {
    return Outcome{Outcome::Kind::kProtocol, e};
  }
  // Reset, broken pipe, closed by the peer (libmodbus reports ECONNRESET), bad fd.
  close();
  return Outcome{Outcome::Kind::kLink, e};
}

Outcome Client::read(Table table, uint16_t start, uint16_t count, uint16_t* words) {
  if (!connected_) return Outcome{Outcome::Kind::kLink, ENOTCONN};
  int n = -1;
  if (is_bit_table(table)) {
    uint8_t bits[MODBUS_MAX_READ_BITS];
    n = table == Table::kCoil ? modbus_read_bits(ctx_, start, count, bits)
                              : modbus_read_input_bits(ctx_, start, count, bits);
    if (n == count) {
      for (uint16_t i = 0; i < count; ++i) words[i] = bits[i] ? 1 : 0;
    }
  } else {
    n = table == Table::kHoldingRegister ? modbus_read_registers(ctx_, start, count, words)
                                         : modbus_read_input_registers(ctx_, start, count, words);
  }
  if (n == count) return {};
  if (n >= 0) return Outcome{Outcome::Kind::kProtocol, EMBBADDATA};
  return fail();
}

Outcome Client::write(const Address& a, const uint16_t* words) {
  if (!connected_) return Outcome{Outcome::Kind::kLink, ENOTCONN};
  int n = -1;
  if (a.table == Table::kCoil) {
    n = modbus_write_bit(ctx_, a.address, words[0] != 0);
  } else if (a.table == Table::kHoldingRegister && width(a) == 1) {
    n = modbus_write_register(ctx_, a.address, words[0]);
  } else if (a.table == Table::kHoldingRegister) {
    n = modbus_write_registers(ctx_, a.address, 2, words);
  } else {
    return Outcome{Outcome::Kind::kException, 1};
  }
  if (n >= 0) return {};
  return fail();
}

}  // namespace rtplc::modbus
