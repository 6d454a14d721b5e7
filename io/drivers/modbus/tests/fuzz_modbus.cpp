// libFuzzer target (issue 9, fuzzing): every place where bytes from the wire
// meet our Modbus code, on arbitrary input.
//   master side  a reply, TCP or RTU, to one of our client's requests: libmodbus
//                parses it, our Client classifies the outcome, and a good
//                answer's words go through every item decoding and format.
//                A TCP reply also goes through the event loop's own framing
//                (pdu.h's next_frame, request.h's check_answer), and the
//                request it answers must read back through parse_request.
//   slave side   a stream of requests, TCP or RTU, through pdu.h's framing
//                tables (TCP's are next_frame/append_frame, which the
//                modbus-server kind uses too) and the fake slave's request
//                handling (pdu.h's parse_request, also the server's): answers
//                must be framed consistently, and what parse_request accepts
//                must be in bounds.
// Input byte 0 chooses: bits 0-1 the mode (0 TCP reply, 1 RTU reply, 2 TCP
// requests, 3 RTU requests); bit 2 patches the reply's transaction id (TCP) or
// appends its CRC (RTU), bit 3 patches the TCP length or the RTU unit, so the
// fuzzer gets past libmodbus's checks it cannot see into (it is not
// instrumented). Reply modes: byte 1 the request (bits 0-1 table, bit 2 a
// write instead), byte 2 the count, bytes 3-4 the start; the rest is the reply.
// Seeds: io/drivers/modbus/tests/corpus/.
#include <sys/socket.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "io/drivers/modbus/client.h"
#include "io/drivers/modbus/fake_slave.h"
#include "io/drivers/modbus/pdu.h"
#include "io/drivers/modbus/request.h"

using namespace rtplc::modbus;

namespace {

constexpr uint8_t kUnit = 1;

const std::vector<Address>& word_items() {
  static const std::vector<Address> items = [] {
    std::vector<Address> v;
    for (const char* t : {"hr:0", "hr:0:i16", "hr:0:u32", "hr:0:i32", "hr:0:f32", "hr:0:f32:swapped", "hr:0:i32:swapped"}) {
      v.push_back(*parse_address(t));
    }
    return v;
  }();
  return items;
}

// The TCP event loop's path (tcp_master.cpp): every whole frame in the
// stream checked against the request, as the loop does after matching its
// transaction id.
void own_framing(Table table, bool write, uint16_t count, uint16_t start, const std::vector<uint8_t>& stream) {
  const uint16_t written[2] = {static_cast<uint16_t>(start ^ 0x5A5A), count};
  Asked rq;
  if (write) {
    Address a = table == Table::kCoil ? *parse_address("coil:0") : *parse_address(count % 2 ? "hr:0" : "hr:0:u32");
    a.address = start;
    rq = write_request(kUnit, a, written);
  } else {
    rq = read_request(kUnit, table, start, count);
  }
  uint8_t frame[kMaxRequestFrame];
  const size_t n = frame_request(rq, start, frame);
  Frame f;
  Request back;
  if (next_frame(frame, n, f) != FrameStatus::kComplete || f.frame_len != n || f.transaction != start) __builtin_trap();
  // Read back as a slave reads it: the same request, or (exception 2) one
  // whose range runs past address 65535, which the config never asks for.
  const uint8_t refused = parse_request(f.pdu, f.pdu_len, back);
  if (refused == 2 ? uint32_t{rq.address} + rq.count <= 65536
                   : refused != 0 || back.function != rq.function || back.address != rq.address) {
    __builtin_trap();
  }
  size_t used = 0;
  while (used < stream.size()) {
    if (next_frame(stream.data() + used, stream.size() - used, f) != FrameStatus::kComplete) break;
    if (f.frame_len > stream.size() - used || f.pdu + f.pdu_len != stream.data() + used + f.frame_len) __builtin_trap();
    uint16_t words[2001];
    words[count] = 0xBEEF;  // nothing is written past the count asked for
    const Outcome o = check_answer(rq, f, words);
    if (words[count] != 0xBEEF) __builtin_trap();
    if (o.ok() && !write && is_bit_table(table)) {
      for (uint16_t i = 0; i < count; ++i) {
        if (words[i] > 1) __builtin_trap();
      }
    }
    if (o.kind == Outcome::Kind::kException && (o.code < 1 || o.code > 11)) __builtin_trap();
    (void)outcome_text(o);
    used += f.frame_len;
  }
}

void master_side(bool rtu, uint8_t flags, const uint8_t* data, size_t size) {
  if (size < 4) return;
  const auto table = static_cast<Table>(data[0] & 3);
  const bool write = (data[0] & 4) != 0;
  const uint16_t count = static_cast<uint16_t>(1 + data[1] % (is_bit_table(table) ? 255 : 125));
  const uint16_t start = static_cast<uint16_t>(data[2] << 8 | data[3]);
  std::vector<uint8_t> reply(data + 4, data + size);
  if (rtu) {
    if ((flags & 8) && !reply.empty()) reply[0] = kUnit;
    if (flags & 4) {
      const uint16_t crc = crc16(reply.data(), reply.size());
      reply.push_back(static_cast<uint8_t>(crc));
      reply.push_back(static_cast<uint8_t>(crc >> 8));
    }
  } else {
    if ((flags & 4) && reply.size() >= 2) {  // a fresh libmodbus TCP context's first transaction is 1
      reply[0] = 0;
      reply[1] = 1;
    }
    if ((flags & 8) && reply.size() >= 6) {
      const size_t len = reply.size() - 6;
      reply[4] = static_cast<uint8_t>(len >> 8);
      reply[5] = static_cast<uint8_t>(len);
    }
  }
  if (!rtu) own_framing(table, write, count, start, reply);
  int sv[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0) return;
  // The reply waits in the socket, then end of stream: no input ever waits for a timeout.
  if (!reply.empty() && ::write(sv[1], reply.data(), reply.size()) != static_cast<ssize_t>(reply.size())) {
    ::close(sv[0]);
    ::close(sv[1]);
    return;
  }
  ::shutdown(sv[1], SHUT_WR);
  auto c = rtu ? Client::rtu({"/dev/null", 19200, 'N', 8, 1}) : Client::tcp("127.0.0.1", 502);
  if (!c) __builtin_trap();
  c->set_timeout_ns(1000000);
  c->set_unit(kUnit);
  c->attach(sv[0]);
  uint16_t words[2000] = {};
  Outcome o;
  if (write) {
    Address a = table == Table::kCoil ? *parse_address("coil:0") : *parse_address(count % 2 ? "hr:0" : "hr:0:u32");
    a.address = start;
    o = c->write(a, words);
  } else {
    o = c->read(table, start, count, words);
    if (o.ok() && !is_bit_table(table)) {
      for (Address a : word_items()) {
        if (width(a) > count) continue;
        (void)format_value(a, decode(a, words + count - width(a)));
      }
    }
    if (o.ok() && is_bit_table(table)) {
      for (uint16_t i = 0; i < count; ++i) {
        if (words[i] > 1) __builtin_trap();  // bits come out as 0/1
      }
    }
  }
  if (o.kind == Outcome::Kind::kException && (o.code < 1 || o.code > 255)) __builtin_trap();
  (void)outcome_text(o);
  c->close();  // closes sv[0]
  ::close(sv[1]);
}

uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }

void slave_side(bool rtu, const uint8_t* data, size_t size) {
  static FakeSlave tcp_slave;
  static FakeSlave rtu_slave([] {
    FakeSlaveOptions o;
    o.serial.device = "unused";  // never started: only its request handling runs
    return o;
  }());
  FakeSlave& slave = rtu ? rtu_slave : tcp_slave;
  const FrameOps& ops = rtu ? kRtuFrames : kTcpFrames;
  std::vector<uint8_t> in(data, data + size);
  std::vector<Response> out;
  (void)slave.serve(ops, in, out);
  for (const Response& r : out) {
    if (r.action != Response::Action::kReply) continue;
    const std::vector<uint8_t>& b = r.bytes;
    if (rtu) {
      if (b.size() < 4) __builtin_trap();
      const uint16_t crc = static_cast<uint16_t>(b[b.size() - 2] | b[b.size() - 1] << 8);
      const uint16_t want = crc16(b.data(), b.size() - 2);
      if (crc != want && crc != static_cast<uint16_t>(want ^ 0xFFFF)) __builtin_trap();
    } else {
      if (b.size() < 8 || be16(b.data() + 4) != b.size() - 6) __builtin_trap();
    }
  }
  // One frame as a whole, whatever framing says about it.
  (void)slave.respond(ops, data, size);
  // The input as one bare PDU: a request parse_request accepts is within the
  // specification's limits, and the reply to it is as long as it says.
  Request rq;
  if (parse_request(data, size, rq) == 0) {
    const bool bits = rq.function == 1 || rq.function == 2 || rq.function == 5 || rq.function == 15;
    const uint16_t most = rq.function <= 2 ? 2000 : rq.function <= 4 ? 125 : rq.function == 15 ? 1968 : rq.function == 16 ? 123 : 1;
    if (rq.count < 1 || rq.count > most || !rq.in_address_space()) __builtin_trap();
    if (rq.function <= 4) {
      static uint16_t zeros[125] = {};
      static uint8_t no_bits[2000] = {};
      const std::vector<uint8_t> reply =
          bits ? bits_reply(rq.function, no_bits, rq.count) : registers_reply(rq.function, zeros, rq.count);
      if (reply.size() != 2u + reply[1]) __builtin_trap();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint8_t mode = data[0] & 3;
  if (mode < 2) master_side(mode == 1, data[0], data + 1, size - 1);
  else slave_side(mode == 3, data + 1, size - 1);
  return 0;
}
