// How a Modbus slave finds requests in the bytes it receives and wraps its
// answers, for TCP and for RTU: one small table of operations per transport,
// in the manner of libmodbus's backends, so the request handling above it
// (FakeSlave today, the modbus-server kind next) is written once. Pure
// functions over bytes, no I/O: the fuzzer drives them directly.
//   TCP  MBAP header (transaction id, protocol 0, length, unit) + PDU.
//   RTU  unit + PDU + CRC-16 (poly 0xA001, init 0xFFFF, low byte first).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace rtplc::modbus {

// One request as the transport delivered it; `pdu` points into the frame.
struct Request {
  uint8_t unit = 0;
  uint16_t transaction = 0;  // TCP only
  const uint8_t* pdu = nullptr;
  size_t pdu_len = 0;
};

// How the answer's framing is to be spoilt (a fault the slave injects).
enum class FrameFault : uint8_t {
  kNone,
  kWrongId,  // TCP: another transaction id; RTU: another unit id
  kBadCrc,   // RTU: the CRC of the answer is wrong; TCP has no CRC and answers normally
};

inline constexpr ptrdiff_t kNotAFrame = -1;

struct FrameOps {
  const char* name;  // "TCP", "RTU"
  // TCP: each master has its own connection, which the slave may close.
  // RTU: one shared line that cannot be hung up; its unit 0 is broadcast.
  bool connections;
  // The length of the request at the front of `in`: > 0 a whole frame of that
  // many bytes, 0 not all of it yet, kNotAFrame garbage (TCP hangs up, RTU
  // discards what it holds and waits for the next frame).
  ptrdiff_t (*frame_length)(const uint8_t* in, size_t len);
  // The request inside a whole frame; false when the frame fails its
  // integrity check (RTU: its CRC), which a slave answers with silence.
  bool (*open)(const uint8_t* frame, size_t len, Request& out);
  // `out` = the framed answer to `req` carrying `pdu`.
  void (*seal)(const Request& req, const uint8_t* pdu, size_t pdu_len, FrameFault fault, std::vector<uint8_t>& out);
};

extern const FrameOps kTcpFrames;
extern const FrameOps kRtuFrames;

// Modbus RTU's CRC-16 over `len` bytes (sent low byte first).
uint16_t crc16(const uint8_t* p, size_t len);

}  // namespace rtplc::modbus
