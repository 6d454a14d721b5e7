// How the CAN driver reaches a bus: a small table of operations over an
// opaque port (as libmodbus does for TCP and RTU), so the driver, the
// commissioning CLI and the tests share one core whatever carries the frames.
//   socketcan_transport()  raw SocketCAN (PF_CAN/SOCK_RAW) on a Linux
//                          interface: can0, vcan0 (socketcan.cpp);
//   fake_bus.h             an in-process bus for host tests (fake_bus.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "common/result.h"
#include "io/drivers/can/codec.h"

namespace rtplc::can {

// Receive frames whose identifier matches `id` in the bits of `mask` (all
// bits by default: exactly this id), standard or extended.
struct IdFilter {
  uint32_t id = 0;
  bool extended = false;
  uint32_t mask = kMaxExtendedId;
};

enum class RecvResult : uint8_t { kFrame, kTimeout, kError };

struct TransportOps {
  const char* name;
  void* context;  // what open() gets first (the fake's bus; null for SocketCAN)
  // Opens `iface`; the port wakes only for `filters` (none: no data frames at
  // all) and, when `error_frames`, for the controller's error frames. Fails
  // with a message saying why (no such interface, no SocketCAN in the kernel).
  Result<void*> (*open)(void* context, const std::string& iface, std::span<const IdFilter> filters, bool error_frames);
  // Queues one frame; 0 or an errno (ENOBUFS: the controller's queue is full,
  // ENETDOWN: the interface is down).
  int (*send)(void* port, const Frame& f);
  // Waits at most timeout_ns for one frame; *err gets the errno of kError.
  RecvResult (*recv)(void* port, Frame& f, int64_t timeout_ns, int* err);
  void (*close)(void* port);
};

const TransportOps& socketcan_transport();
// Whether this kernel offers PF_CAN raw sockets at all (and why not).
Result<void> socketcan_available();

// An open port; closes itself.
class Port {
 public:
  Port() = default;
  static Result<Port> open(const TransportOps& ops, const std::string& iface, std::span<const IdFilter> filters,
                           bool error_frames);
  Port(Port&& o) noexcept : ops_(o.ops_), port_(o.port_) { o.port_ = nullptr; }
  Port& operator=(Port&& o) noexcept;
  Port(const Port&) = delete;
  Port& operator=(const Port&) = delete;
  ~Port() { close(); }

  bool is_open() const { return port_ != nullptr; }
  int send(const Frame& f) const { return ops_->send(port_, f); }
  RecvResult recv(Frame& f, int64_t timeout_ns, int* err) const { return ops_->recv(port_, f, timeout_ns, err); }
  void close();

 private:
  const TransportOps* ops_ = nullptr;
  void* port_ = nullptr;
};

}  // namespace rtplc::can
