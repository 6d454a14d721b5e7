// CAN and Modbus RTU frame times (see link_timing.h).
#include "fieldbus/link_timing.h"

#include <cmath>

namespace rtplc::fieldbus {

std::optional<FrameLayout> parse_layout(std::string_view text) {
  if (text == "can-11") return FrameLayout::kCan11;
  if (text == "can-29") return FrameLayout::kCan29;
  if (text == "modbus-rtu") return FrameLayout::kModbusRtu;
  return std::nullopt;
}

const char* to_string(FrameLayout l) {
  switch (l) {
    case FrameLayout::kCan11:
      return "can-11";
    case FrameLayout::kCan29:
      return "can-29";
    case FrameLayout::kModbusRtu:
      return "modbus-rtu";
  }
  return "?";
}

int max_payload(FrameLayout l) {
  return l == FrameLayout::kModbusRtu ? 250 : 8;
}

int64_t can_frame_bits(FrameLayout l, int data_bytes) {
  const int64_t n8 = 8 * static_cast<int64_t>(data_bytes);
  // The stuffed region runs from start of frame to the CRC; a stuff bit can
  // follow every 4 bits after the first 5, hence (bits - 1) / 4.
  if (l == FrameLayout::kCan29) return 67 + n8 + (54 + n8 - 1) / 4;
  return 47 + n8 + (34 + n8 - 1) / 4;
}

Nanos LinkTiming::packet(int bytes) const {
  if (layout == FrameLayout::kModbusRtu) {
    return bits_time(static_cast<int64_t>(bytes) * kModbusBitsPerChar, bit_rate);
  }
  return bits_time(can_frame_bits(layout, bytes), bit_rate);
}

Nanos LinkTiming::server_overhead(int server_bytes) const {
  if (layout == FrameLayout::kModbusRtu) {
    // Characters in halves so the two 3.5-character silences stay exact.
    const int64_t half_chars = 2 * (server_bytes + kModbusReplyOverheadChars) + 7 + 7;
    return bits_time(half_chars * kModbusBitsPerChar, 2 * bit_rate);
  }
  return bits_time(can_frame_bits(layout, server_bytes), bit_rate);
}

std::string LinkTiming::describe() const {
  std::string rate;
  if (bit_rate >= 1e6 && std::fmod(bit_rate, 1e5) == 0) {
    rate = std::to_string(bit_rate / 1e6);
  } else if (bit_rate >= 1e3 && std::fmod(bit_rate, 100) == 0) {
    rate = std::to_string(bit_rate / 1e3);
  } else {
    rate = std::to_string(bit_rate);
  }
  // std::to_string(double) prints six decimals; keep what matters.
  while (rate.find('.') != std::string::npos && (rate.back() == '0' || rate.back() == '.')) {
    const bool dot = rate.back() == '.';
    rate.pop_back();
    if (dot) break;
  }
  const char* unit = bit_rate >= 1e6 && std::fmod(bit_rate, 1e5) == 0   ? "Mbit/s"
                     : bit_rate >= 1e3 && std::fmod(bit_rate, 100) == 0 ? "kbit/s"
                                                                        : "bit/s";
  const char* name = layout == FrameLayout::kCan11   ? "CAN 11-bit id"
                     : layout == FrameLayout::kCan29 ? "CAN 29-bit id"
                                                     : "Modbus RTU";
  return std::string(name) + " at " + rate + unit;
}

}  // namespace rtplc::fieldbus
