// Packet times of real links from a bit rate and a frame layout (docs/fieldbus.md,
// "Packet times of CAN and Modbus RTU"; spec io-links.md, "Fieldbus bandwidth
// allocation": the planner works from the link's bit rate). Worst cases only:
// every stuff bit CAN can insert, every silent interval Modbus RTU requires.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "fieldbus/units.h"

namespace rtplc::fieldbus {

enum class FrameLayout : uint8_t { kCan11, kCan29, kModbusRtu };

std::optional<FrameLayout> parse_layout(std::string_view text);  // "can-11", "can-29", "modbus-rtu"
const char* to_string(FrameLayout l);
// Largest payload of one packet: 8 bytes for classic CAN, 250 for an RTU reply.
int max_payload(FrameLayout l);

// Bits on the wire of one CAN data frame with `data_bytes` (0..8), worst-case
// stuffing and the 3-bit intermission included:
//   11-bit id: 47 + 8n bits plus floor((34 + 8n - 1) / 4) stuff bits
//   29-bit id: 67 + 8n bits plus floor((54 + 8n - 1) / 4) stuff bits
int64_t can_frame_bits(FrameLayout l, int data_bytes);

// Modbus RTU: 11 bits per character (start, 8 data, parity or second stop,
// stop) and a 3.5-character silent interval after every frame.
inline constexpr int kModbusBitsPerChar = 11;
// A request (function 03: address, function, start, count, CRC) is 8 characters.
inline constexpr int kModbusRequestChars = 8;
// A reply carries address, function, byte count and CRC around its data.
inline constexpr int kModbusReplyOverheadChars = 5;

struct LinkTiming {
  FrameLayout layout;
  double bit_rate;  // bits per second

  // One packet with `bytes` of payload.
  //   CAN: one data frame.
  //   Modbus RTU: the characters the payload adds to the node's reply (the
  //   request and the empty reply are the server overhead, see below).
  Nanos packet(int bytes) const;
  // What one visit of the server costs a node with nothing to send.
  //   CAN: one poll or token frame of `server_bytes` data bytes.
  //   Modbus RTU: the request (`server_bytes` characters, 8 by default) and an
  //   empty reply, each followed by its silent interval.
  Nanos server_overhead(int server_bytes) const;
  // "CAN 11-bit id at 500kbit/s".
  std::string describe() const;
};

}  // namespace rtplc::fieldbus
