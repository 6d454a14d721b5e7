// Frame packing and unpacking, and error-frame decoding (see codec.h).
#include "io/drivers/can/codec.h"

#include <linux/can/error.h>

#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace rtplc::can {
namespace {

uint64_t read_raw(const SignalLayout& s, const uint8_t* data) noexcept {
  uint64_t raw = 0;
  for (unsigned i = 0; i < s.length; ++i) {
    const unsigned shift = s.order == ByteOrder::kLittle ? 8 * i : 8 * (s.length - 1u - i);
    raw |= uint64_t{data[s.byte + i]} << shift;
  }
  return raw;
}

void write_raw(const SignalLayout& s, uint64_t raw, uint8_t* data) noexcept {
  for (unsigned i = 0; i < s.length; ++i) {
    const unsigned shift = s.order == ByteOrder::kLittle ? 8 * i : 8 * (s.length - 1u - i);
    data[s.byte + i] = static_cast<uint8_t>(raw >> shift);
  }
}

}  // namespace

std::string id_text(uint32_t id, bool extended) { return id_chars(id, extended).s; }

std::string frame_text(const Frame& f) { return frame_chars(f).s; }

IdChars id_chars(uint32_t id, bool extended) noexcept {
  IdChars t{};
  const auto r = extended ? fmt::format_to_n(t.s, sizeof t.s - 1, "{:08X}x", id)
                          : fmt::format_to_n(t.s, sizeof t.s - 1, "{:03X}", id);
  *r.out = '\0';
  return t;
}

FrameChars frame_chars(const Frame& f) noexcept {
  FrameChars t{};
  char* out = f.extended ? fmt::format_to_n(t.s, 10, "{:08X}#", f.id).out : fmt::format_to_n(t.s, 10, "{:03X}#", f.id).out;
  for (unsigned i = 0; i < f.len && i < 8; ++i) out = fmt::format_to_n(out, 2, "{:02X}", f.data[i]).out;
  *out = '\0';
  return t;
}

double unpack(const SignalLayout& s, const uint8_t* data) noexcept {
  const uint64_t raw = read_raw(s, data);
  double v = 0;
  if (s.encoding == Encoding::kFloat) {
    if (s.length == 4) {
      float f = 0;
      const auto bits = static_cast<uint32_t>(raw);
      std::memcpy(&f, &bits, sizeof f);
      v = static_cast<double>(f);
    } else {
      std::memcpy(&v, &raw, sizeof v);
    }
  } else if (s.encoding == Encoding::kSigned) {
    const unsigned bits = 8u * s.length;
    int64_t x = 0;
    if (bits == 64) {
      std::memcpy(&x, &raw, sizeof x);
    } else {
      const uint64_t sign = uint64_t{1} << (bits - 1);
      x = static_cast<int64_t>(raw ^ sign) - static_cast<int64_t>(sign);  // sign-extend
    }
    v = static_cast<double>(x);
  } else {
    v = static_cast<double>(raw);
  }
  return v * s.scale + s.offset;
}

bool pack(const SignalLayout& s, double value, uint8_t* data) noexcept {
  const double x = (value - s.offset) / s.scale;
  if (!std::isfinite(x)) return false;
  uint64_t raw = 0;
  if (s.encoding == Encoding::kFloat) {
    if (s.length == 4) {
      if (std::fabs(x) > static_cast<double>(std::numeric_limits<float>::max())) return false;
      const auto f = static_cast<float>(x);
      uint32_t bits = 0;
      std::memcpy(&bits, &f, sizeof bits);
      raw = bits;
    } else {
      std::memcpy(&raw, &x, sizeof raw);
    }
  } else {
    const double r = std::nearbyint(x);
    const int bits = 8 * s.length;
    if (s.encoding == Encoding::kUnsigned) {
      // 2^bits exactly as a double (bits <= 64): the first value that no longer fits.
      if (r < 0 || r >= std::ldexp(1.0, bits)) return false;
      raw = static_cast<uint64_t>(r);
    } else {
      const double half = std::ldexp(1.0, bits - 1);
      if (r < -half || r >= half) return false;
      const auto i = static_cast<int64_t>(r);
      std::memcpy(&raw, &i, sizeof raw);  // two's complement; write_raw keeps the low bytes
    }
  }
  write_raw(s, raw, data);
  return true;
}

ErrorReport decode_error(const Frame& f) noexcept {
  ErrorReport e;
  if (!f.error) return e;
  const uint32_t c = f.id;
  e.bus_off = (c & CAN_ERR_BUSOFF) != 0;
  e.restarted = (c & CAN_ERR_RESTARTED) != 0;
  e.tx_timeout = (c & CAN_ERR_TX_TIMEOUT) != 0;
  e.lost_arbitration = (c & CAN_ERR_LOSTARB) != 0;
  e.protocol = (c & CAN_ERR_PROT) != 0;
  e.no_ack = (c & CAN_ERR_ACK) != 0;
  e.bus_error = (c & CAN_ERR_BUSERROR) != 0;
  e.transceiver = (c & CAN_ERR_TRX) != 0;
  if ((c & CAN_ERR_CRTL) != 0 && f.len > 1) {
    const uint8_t ctrl = f.data[1];
    e.error_passive = (ctrl & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    e.warning = (ctrl & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
    e.back_to_active = (ctrl & CAN_ERR_CRTL_ACTIVE) != 0;
  }
  return e;
}

std::string error_text(const ErrorReport& e) {
  std::string s;
  auto add = [&](bool on, const char* what) {
    if (!on) return;
    if (!s.empty()) s += ", ";
    s += what;
  };
  add(e.bus_off, "bus-off");
  add(e.restarted, "restarted");
  add(e.error_passive, "error-passive");
  add(e.warning, "error-warning");
  add(e.back_to_active, "error-active again");
  add(e.tx_timeout, "tx-timeout");
  add(e.lost_arbitration, "lost-arbitration");
  add(e.protocol, "protocol-violation");
  add(e.no_ack, "no-ack");
  add(e.bus_error, "bus-error");
  add(e.transceiver, "transceiver");
  return s.empty() ? "error frame" : s;
}

}  // namespace rtplc::can
