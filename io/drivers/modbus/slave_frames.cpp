// The slave side's TCP and RTU framing (see slave_frames.h).
#include "io/drivers/modbus/slave_frames.h"

namespace rtplc::modbus {
namespace {

constexpr size_t kTcpHeader = 7;     // transaction, protocol, length, unit
constexpr size_t kRtuMaxFrame = 256; // unit + 253-byte PDU + CRC

uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }
void put16(std::vector<uint8_t>& v, uint32_t x) {
  v.push_back(static_cast<uint8_t>(x >> 8));
  v.push_back(static_cast<uint8_t>(x));
}

// TCP: the MBAP length field counts the unit and the PDU.
ptrdiff_t tcp_frame_length(const uint8_t* in, size_t len) {
  if (len < kTcpHeader) return 0;
  const size_t body = be16(in + 4);
  if (body < 2 || body > 254 || be16(in + 2) != 0) return kNotAFrame;
  if (len < 6 + body) return 0;
  return static_cast<ptrdiff_t>(6 + body);
}

bool tcp_open(const uint8_t* frame, size_t len, Request& out) {
  if (len < kTcpHeader + 1) return false;
  out.transaction = be16(frame);
  out.unit = frame[6];
  out.pdu = frame + kTcpHeader;
  out.pdu_len = len - kTcpHeader;
  return true;
}

void tcp_seal(const Request& req, const uint8_t* pdu, size_t pdu_len, FrameFault fault, std::vector<uint8_t>& out) {
  out.clear();
  put16(out, fault == FrameFault::kWrongId ? static_cast<uint16_t>(req.transaction + 1) : req.transaction);
  put16(out, 0);
  put16(out, static_cast<uint32_t>(pdu_len + 1));
  out.push_back(req.unit);
  out.insert(out.end(), pdu, pdu + pdu_len);
}

// RTU has no length field: a request's length follows from its function code
// (the ones a master sends; FC 15 and 16 carry a byte count). Frames of other
// codes are taken as whatever has arrived, since a master writes a frame at
// once and the slave answers them "illegal function" anyway.
ptrdiff_t rtu_frame_length(const uint8_t* in, size_t len) {
  if (len < 2) return 0;
  size_t need = 0;
  switch (in[1]) {
    case 1: case 2: case 3: case 4: case 5: case 6: need = 8; break;
    case 15: case 16:
      if (len < 7) return 0;
      need = 9 + size_t{in[6]};
      break;
    default:
      if (len < 4) return 0;
      need = len;
  }
  if (need > kRtuMaxFrame) return kNotAFrame;
  return len < need ? 0 : static_cast<ptrdiff_t>(need);
}

bool rtu_open(const uint8_t* frame, size_t len, Request& out) {
  if (len < 4) return false;
  const uint16_t crc = static_cast<uint16_t>(frame[len - 2] | frame[len - 1] << 8);
  if (crc != crc16(frame, len - 2)) return false;
  out.unit = frame[0];
  out.transaction = 0;
  out.pdu = frame + 1;
  out.pdu_len = len - 3;
  return true;
}

void rtu_seal(const Request& req, const uint8_t* pdu, size_t pdu_len, FrameFault fault, std::vector<uint8_t>& out) {
  out.clear();
  out.push_back(fault == FrameFault::kWrongId ? static_cast<uint8_t>(req.unit + 1) : req.unit);
  out.insert(out.end(), pdu, pdu + pdu_len);
  uint16_t crc = crc16(out.data(), out.size());
  if (fault == FrameFault::kBadCrc) crc = static_cast<uint16_t>(crc ^ 0xFFFF);
  out.push_back(static_cast<uint8_t>(crc));
  out.push_back(static_cast<uint8_t>(crc >> 8));
}

}  // namespace

uint16_t crc16(const uint8_t* p, size_t len) {
  uint16_t crc = 0xFFFF;
  for (size_t i = 0; i < len; ++i) {
    crc = static_cast<uint16_t>(crc ^ p[i]);
    for (int b = 0; b < 8; ++b) crc = (crc & 1) ? static_cast<uint16_t>((crc >> 1) ^ 0xA001) : static_cast<uint16_t>(crc >> 1);
  }
  return crc;
}

const FrameOps kTcpFrames{"TCP", true, tcp_frame_length, tcp_open, tcp_seal};
const FrameOps kRtuFrames{"RTU", false, rtu_frame_length, rtu_open, rtu_seal};

}  // namespace rtplc::modbus
