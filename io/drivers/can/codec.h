// CAN frames and the values inside them (issue "CAN/GPIO", item 1; docs/can.md):
// a frame as the driver sees it (independent of <linux/can.h>, so the fake bus
// and the tests need no SocketCAN), a signal's place and encoding in a frame's
// 8 data bytes, and the pure functions that read and write one bit-exactly,
// plus the decoding of SocketCAN error frames (bus-off, restart, warnings).
#pragma once

#include <cstdint>
#include <string>

namespace rtplc::can {

inline constexpr uint32_t kMaxStandardId = 0x7FF;       // 11 bits
inline constexpr uint32_t kMaxExtendedId = 0x1FFFFFFF;  // 29 bits

struct Frame {
  uint32_t id = 0;        // 11 or 29 bits; for an error frame the CAN_ERR_* class bits
  bool extended = false;  // 29-bit identifier
  bool error = false;     // a SocketCAN error frame (CAN_ERR_FLAG)
  uint8_t len = 0;        // data length 0..8
  uint8_t data[8] = {};
};

// "123", "12345678x" (extended, as candump prints them): the id for messages.
std::string id_text(uint32_t id, bool extended);
// "123#11223344", cansend's notation.
std::string frame_text(const Frame& f);
// The same texts in fixed buffers, for a bridge's cycle (no allocation).
struct IdChars {
  char s[12];
};
struct FrameChars {
  char s[32];
};
IdChars id_chars(uint32_t id, bool extended) noexcept;
FrameChars frame_chars(const Frame& f) noexcept;

enum class Encoding : uint8_t { kUnsigned, kSigned, kFloat };
enum class ByteOrder : uint8_t { kLittle, kBig };  // little: Intel (first byte least significant)

// Where one channel's value lives in a frame: `length` bytes from `byte`
// (byte + length <= 8), read as an integer (unsigned or two's complement) or
// an IEEE float (length 4: float32, 8: float64) in the given byte order, then
// engineering value = raw * scale + offset.
struct SignalLayout {
  uint8_t byte = 0;
  uint8_t length = 1;
  Encoding encoding = Encoding::kUnsigned;
  ByteOrder order = ByteOrder::kLittle;
  double scale = 1.0;
  double offset = 0.0;
};

// The engineering value of a signal in `data` (8 bytes).
double unpack(const SignalLayout& s, const uint8_t* data) noexcept;

// Writes value's raw form into `data` (8 bytes), touching only the signal's
// bytes. Integers are rounded to nearest; false (and `data` unchanged) when
// the raw value does not fit the signal or is not finite.
bool pack(const SignalLayout& s, double value, uint8_t* data) noexcept;

// What a SocketCAN error frame reports (linux/can/error.h).
struct ErrorReport {
  bool bus_off = false;
  bool restarted = false;       // the controller left bus-off
  bool error_passive = false;   // rx or tx error counter >= 128
  bool warning = false;         // an error counter >= 96
  bool back_to_active = false;  // error counters fell below the warning level
  bool tx_timeout = false;
  bool lost_arbitration = false;
  bool protocol = false;        // a protocol violation (bit, form, stuff...)
  bool no_ack = false;          // nobody acknowledged our frame (alone on the bus)
  bool bus_error = false;
  bool transceiver = false;
};

ErrorReport decode_error(const Frame& f) noexcept;
// "bus-off", "error-passive, no-ack": the report for logs.
std::string error_text(const ErrorReport& e);

}  // namespace rtplc::can
