// An in-process CAN bus for host tests (transport.h): ports opened on one
// FakeBus see each other's frames as nodes on one wire do (a sender never
// receives its own frame), each through its own filters, so the driver's whole
// logic runs without SocketCAN. Faults are injected deterministically:
// error frames (bus-off, restart...) to every port that asked for them, a
// bus that refuses sends (as a controller in bus-off does), and a bounded
// receive queue per port that drops what does not fit (as a SocketCAN
// socket whose receive buffer is full drops frames).
// Not for the RT path: ports wait on a mutex and a condition variable.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "io/drivers/can/transport.h"

namespace rtplc::can {

class FakeBus {
 public:
  FakeBus() = default;
  FakeBus(const FakeBus&) = delete;
  FakeBus& operator=(const FakeBus&) = delete;

  // The transport whose open() attaches to this bus (`iface` is ignored but
  // recorded; an iface of "missing" fails as a missing interface does).
  const TransportOps& transport() const { return ops_; }

  // What a peer node does: put a frame on the bus (every port whose filters
  // take it receives it), or report a controller error to the ports.
  void inject(const Frame& f);
  void inject_error(uint32_t error_class, uint8_t ctrl = 0);
  // Sends fail with ENETDOWN while set (a controller in bus-off).
  void refuse_sends(bool on);
  // Each port queues at most `frames` received frames (0: no limit, the
  // default); a frame that finds its port's queue full is dropped and counted.
  void limit_rx(size_t frames);
  // Frames dropped so far because a port's queue was full (all ports).
  uint64_t rx_dropped() const;

  // Every frame a port sent, in order (the peer's candump).
  std::vector<Frame> sent() const;
  size_t sent_count() const;
  void clear_sent();
  int ports_open() const;
  // The filters of the last port opened.
  std::vector<IdFilter> last_filters() const;

 private:
  struct FakePort {
    FakeBus* bus = nullptr;
    std::vector<IdFilter> filters;
    bool error_frames = false;
    std::deque<Frame> rx;
  };
  static Result<void*> open_port(void* bus, const std::string& iface, std::span<const IdFilter> filters, bool error_frames);
  static int send_port(void* p, const Frame& f);
  static RecvResult recv_port(void* p, Frame& f, int64_t timeout_ns, int* err);
  static void close_port(void* p);
  void deliver(const Frame& f, const FakePort* from);

  TransportOps ops_{"fake", this, &FakeBus::open_port, &FakeBus::send_port, &FakeBus::recv_port, &FakeBus::close_port};

  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::vector<FakePort*> ports_;
  std::vector<Frame> sent_;
  std::vector<IdFilter> last_filters_;
  bool refuse_ = false;
  size_t rx_limit_ = 0;
  uint64_t rx_dropped_ = 0;
};

}  // namespace rtplc::can
