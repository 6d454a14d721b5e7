// Modbus TCP and RTU frames and request PDUs, slave side (see pdu.h).
#include "io/drivers/modbus/pdu.h"

namespace rtplc::modbus {
namespace {

void put16(std::vector<uint8_t>& v, uint32_t x) {
  v.push_back(static_cast<uint8_t>(x >> 8));
  v.push_back(static_cast<uint8_t>(x));
}

constexpr size_t kRtuMaxFrame = 256;  // unit + 253-byte PDU + CRC

// The FrameOps of TCP are next_frame and append_frame.
ptrdiff_t tcp_frame_length(const uint8_t* in, size_t len) {
  Frame f;
  switch (next_frame(in, len, f)) {
    case FrameStatus::kIncomplete: return 0;
    case FrameStatus::kBad: return kNotAFrame;
    case FrameStatus::kComplete: break;
  }
  return static_cast<ptrdiff_t>(f.frame_len);
}

bool tcp_open(const uint8_t* frame, size_t len, Frame& out) {
  return next_frame(frame, len, out) == FrameStatus::kComplete && out.frame_len == len;
}

void tcp_seal(const Frame& req, const uint8_t* pdu, size_t pdu_len, FrameFault fault, std::vector<uint8_t>& out) {
  out.clear();
  const uint16_t tid = fault == FrameFault::kWrongId ? static_cast<uint16_t>(req.transaction + 1) : req.transaction;
  append_frame(out, tid, req.unit, pdu, pdu_len);
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

bool rtu_open(const uint8_t* frame, size_t len, Frame& out) {
  if (len < 4) return false;
  const uint16_t crc = static_cast<uint16_t>(frame[len - 2] | frame[len - 1] << 8);
  if (crc != crc16(frame, len - 2)) return false;
  out = Frame{};
  out.unit = frame[0];
  out.pdu = frame + 1;
  out.pdu_len = len - 3;
  out.frame_len = len;
  return true;
}

void rtu_seal(const Frame& req, const uint8_t* pdu, size_t pdu_len, FrameFault fault, std::vector<uint8_t>& out) {
  out.clear();
  out.push_back(fault == FrameFault::kWrongId ? static_cast<uint8_t>(req.unit + 1) : req.unit);
  out.insert(out.end(), pdu, pdu + pdu_len);
  uint16_t crc = crc16(out.data(), out.size());
  if (fault == FrameFault::kBadCrc) crc = static_cast<uint16_t>(crc ^ 0xFFFF);
  out.push_back(static_cast<uint8_t>(crc));
  out.push_back(static_cast<uint8_t>(crc >> 8));
}

}  // namespace

const FrameOps kTcpFrames{"TCP", true, tcp_frame_length, tcp_open, tcp_seal};
const FrameOps kRtuFrames{"RTU", false, rtu_frame_length, rtu_open, rtu_seal};

uint16_t crc16(const uint8_t* p, size_t len) {
  uint16_t crc = 0xFFFF;
  for (size_t i = 0; i < len; ++i) {
    crc = static_cast<uint16_t>(crc ^ p[i]);
    for (int b = 0; b < 8; ++b) crc = (crc & 1) ? static_cast<uint16_t>((crc >> 1) ^ 0xA001) : static_cast<uint16_t>(crc >> 1);
  }
  return crc;
}

FrameStatus next_frame(const uint8_t* buf, size_t len, Frame& frame) {
  if (len < 7) return FrameStatus::kIncomplete;
  // Length counts the unit id and the PDU: at least a function code, at most
  // the 253-byte PDU of the serial line the protocol inherits.
  const size_t n = be16(buf + 4);
  if (be16(buf + 2) != 0 || n < 2 || n > 254) return FrameStatus::kBad;
  if (len < 6 + n) return FrameStatus::kIncomplete;
  frame.transaction = be16(buf);
  frame.unit = buf[6];
  frame.pdu = buf + 7;
  frame.pdu_len = n - 1;
  frame.frame_len = 6 + n;
  return FrameStatus::kComplete;
}

void append_frame(std::vector<uint8_t>& out, uint16_t transaction, uint8_t unit, const uint8_t* pdu,
                  size_t pdu_len) {
  put16(out, transaction);
  put16(out, 0);
  put16(out, static_cast<uint32_t>(pdu_len + 1));
  out.push_back(unit);
  out.insert(out.end(), pdu, pdu + pdu_len);
}

uint8_t parse_request(const uint8_t* pdu, size_t len, Request& out) {
  if (len < 1) return kExceptionIllegalFunction;
  out = Request{};
  out.function = pdu[0];
  switch (out.function) {
    case 1: case 2: case 3: case 4: case 5: case 6: case 15: case 16: break;
    default: return kExceptionIllegalFunction;
  }
  if (len < 5) return kExceptionIllegalValue;
  out.address = be16(pdu + 1);
  const uint16_t word = be16(pdu + 3);
  switch (out.function) {
    case 1:
    case 2:
    case 3:
    case 4: {
      const uint16_t most = out.function <= 2 ? 2000 : 125;
      if (len != 5 || word < 1 || word > most) return kExceptionIllegalValue;
      out.count = word;
      break;
    }
    case 5:
      if (len != 5 || (word != 0xFF00 && word != 0)) return kExceptionIllegalValue;
      out.count = 1;
      out.value = word != 0 ? 1 : 0;
      break;
    case 6:
      if (len != 5) return kExceptionIllegalValue;
      out.count = 1;
      out.value = word;
      break;
    default: {  // 15, 16
      if (len < 6) return kExceptionIllegalValue;
      const bool regs = out.function == 16;
      const size_t bytes = pdu[5];
      if (word < 1 || word > (regs ? 123 : 1968) || bytes != (regs ? word * 2u : (word + 7u) / 8u) ||
          len != 6 + bytes) {
        return kExceptionIllegalValue;
      }
      out.count = word;
      out.data = pdu + 6;
      break;
    }
  }
  if (!out.in_address_space()) return kExceptionIllegalAddress;
  return 0;
}

std::vector<uint8_t> exception_reply(uint8_t function, uint8_t code) {
  return {static_cast<uint8_t>(function | 0x80), code};
}

std::vector<uint8_t> bits_reply(uint8_t function, const uint8_t* bits, uint16_t count) {
  std::vector<uint8_t> r{function};
  const auto bytes = static_cast<uint8_t>((count + 7) / 8);
  r.push_back(bytes);
  for (uint32_t b = 0; b < bytes; ++b) {
    uint8_t v = 0;
    for (uint32_t i = 0; i < 8 && b * 8 + i < count; ++i) {
      if (bits[b * 8 + i]) v = static_cast<uint8_t>(v | 1u << i);
    }
    r.push_back(v);
  }
  return r;
}

std::vector<uint8_t> registers_reply(uint8_t function, const uint16_t* registers, uint16_t count) {
  std::vector<uint8_t> r{function, static_cast<uint8_t>(count * 2)};
  for (uint32_t i = 0; i < count; ++i) put16(r, registers[i]);
  return r;
}

std::vector<uint8_t> write_reply(const uint8_t* pdu) { return std::vector<uint8_t>(pdu, pdu + 5); }

}  // namespace rtplc::modbus
