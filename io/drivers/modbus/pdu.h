// Modbus as a slave or server sees it (Modbus Application Protocol v1.1b3,
// "Messaging on TCP/IP" v1.0b, "Serial Line" v1.02): finding request frames in
// the bytes received and framing the answers, for TCP (MBAP header) and RTU
// (unit + PDU + CRC-16); checking a request PDU's shape (function code,
// quantity limits, byte count); building the reply PDUs. Pure functions over
// bytes, no I/O, so the fuzzer drives them directly. Shared by the fake slave
// (fake_slave.h, TCP and RTU) and the `modbus-server` kind
// (io/drivers/modbus_server/, TCP), which differ only in the tables behind the
// requests.
//   TCP  MBAP header (transaction id, protocol 0, length, unit) + PDU:
//        next_frame() / append_frame().
//   RTU  unit + PDU + CRC-16 (poly 0xA001, init 0xFFFF, low byte first).
// FrameOps is the framing as one small table of operations per transport, in
// the manner of libmodbus's backends, so request handling written over it
// (FakeSlave::serve) serves both; kTcpFrames is made of next_frame and
// append_frame, so there is one MBAP implementation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace rtplc::modbus {

// A big-endian 16-bit field, as every Modbus field is.
inline uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }

inline constexpr uint8_t kExceptionIllegalFunction = 1;
inline constexpr uint8_t kExceptionIllegalAddress = 2;
inline constexpr uint8_t kExceptionIllegalValue = 3;
inline constexpr uint8_t kExceptionDeviceFailure = 4;
inline constexpr uint8_t kExceptionGatewayTarget = 11;

// One request or answer frame at the front of a buffer; `pdu` points into it.
struct Frame {
  uint16_t transaction = 0;  // TCP only
  uint8_t unit = 0;
  const uint8_t* pdu = nullptr;  // function code first
  size_t pdu_len = 0;
  size_t frame_len = 0;  // bytes to drop from the buffer after handling it
};

enum class FrameStatus : uint8_t {
  kIncomplete,  // wait for more bytes
  kComplete,    // `frame` describes the first frame
  kBad,         // not Modbus TCP (protocol id or length impossible): hang up
};

// TCP: looks at the first bytes of `buf` (a client's unhandled input).
FrameStatus next_frame(const uint8_t* buf, size_t len, Frame& frame);

// TCP: appends the MBAP header for `pdu_len` bytes of PDU, then the PDU.
void append_frame(std::vector<uint8_t>& out, uint16_t transaction, uint8_t unit, const uint8_t* pdu,
                  size_t pdu_len);

// How the answer's framing is to be spoilt (a fault the fake slave injects).
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
  // The request inside a whole frame of `len` bytes; false when the frame
  // fails its integrity check (RTU: its CRC), which a slave answers with silence.
  bool (*open)(const uint8_t* frame, size_t len, Frame& out);
  // `out` = the framed answer to `req` carrying `pdu`.
  void (*seal)(const Frame& req, const uint8_t* pdu, size_t pdu_len, FrameFault fault, std::vector<uint8_t>& out);
};

extern const FrameOps kTcpFrames;
extern const FrameOps kRtuFrames;

// Modbus RTU's CRC-16 over `len` bytes (sent low byte first).
uint16_t crc16(const uint8_t* p, size_t len);

// A request PDU whose shape is valid (its addresses are for the caller to judge).
struct Request {
  uint8_t function = 0;
  uint16_t address = 0;
  // Reads and FC 15/16: how many bits or registers; FC 5/6: 1.
  uint16_t count = 0;
  // FC 5: 0 or 1; FC 6: the register; FC 15/16: the first value byte follows.
  uint16_t value = 0;
  const uint8_t* data = nullptr;  // FC 15/16: the packed bits or big-endian registers
  // FC 16: register i of the request.
  uint16_t register_at(uint16_t i) const {
    return static_cast<uint16_t>(data[2 * i] << 8 | data[2 * i + 1]);
  }
  // FC 15: bit i of the request.
  bool bit_at(uint16_t i) const { return ((data[i / 8] >> (i % 8)) & 1) != 0; }
  // The request covers [address, address + count); false when that passes 65535.
  bool in_address_space() const { return uint32_t{address} + count <= 65536; }
};

// Checks the PDU of FC 1, 2, 3, 4, 5, 6, 15 or 16 against the specification's
// limits. 0 and `out` filled, or the exception code to answer: 1 for another
// function, 3 for a quantity or byte count out of bounds, 2 for a range that
// runs past address 65535.
uint8_t parse_request(const uint8_t* pdu, size_t len, Request& out);

// Reply PDUs.
std::vector<uint8_t> exception_reply(uint8_t function, uint8_t code);
// FC 1/2: `count` bits from bits[0..count); FC 3/4: `count` registers.
std::vector<uint8_t> bits_reply(uint8_t function, const uint8_t* bits, uint16_t count);
std::vector<uint8_t> registers_reply(uint8_t function, const uint16_t* registers, uint16_t count);
// FC 5, 6, 15, 16: the echo of the request's first five bytes.
std::vector<uint8_t> write_reply(const uint8_t* pdu);

}  // namespace rtplc::modbus
