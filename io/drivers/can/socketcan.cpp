// The SocketCAN raw transport (transport.h): one PF_CAN/SOCK_RAW socket bound
// to an interface, with CAN_RAW_FILTER set to the mapped identifiers (so the
// kernel drops every other frame before it wakes us) and CAN_RAW_ERR_FILTER to
// the error classes the driver reports (bus-off, restart, controller states,
// protocol and acknowledgement errors).
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "io/drivers/can/transport.h"

namespace rtplc::can {
namespace {

struct RawPort {
  int fd = -1;
};

std::string no_can_text(int err) {
  return fmt::format("this kernel offers no SocketCAN raw sockets (socket(PF_CAN, SOCK_RAW): {}); "
                     "load the modules: modprobe can can-raw (and vcan for a virtual bus)",
                     std::strerror(err));
}

Result<void*> raw_open(void*, const std::string& iface, std::span<const IdFilter> filters, bool error_frames) {
  if (iface.empty() || iface.size() >= IFNAMSIZ) {
    return make_error(fmt::format("'{}' is not a network interface name (1..{} characters)", iface, IFNAMSIZ - 1));
  }
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return make_error(no_can_text(errno));
  auto fail = [fd](std::string msg) -> Result<void*> {
    ::close(fd);
    return make_error(std::move(msg));
  };
  ifreq ifr{};
  std::memcpy(ifr.ifr_name, iface.data(), iface.size());
  if (::ioctl(fd, SIOCGIFINDEX, &ifr) < 0) {
    const int e = errno;
    if (e == ENODEV) {
      return fail(fmt::format("CAN interface '{}' does not exist (see `ip link`; a virtual bus: "
                              "ip link add dev {} type vcan && ip link set up {})",
                              iface, iface, iface));
    }
    return fail(fmt::format("CAN interface '{}': {}", iface, std::strerror(e)));
  }
  std::vector<can_filter> f;
  for (const IdFilter& x : filters) {
    can_filter cf{};
    cf.can_id = x.extended ? (x.id | CAN_EFF_FLAG) : x.id;
    cf.can_mask = CAN_EFF_FLAG | CAN_RTR_FLAG | (x.mask & (x.extended ? CAN_EFF_MASK : CAN_SFF_MASK));
    f.push_back(cf);
  }
  // An empty filter list receives no data frames at all (what a port that only
  // transmits wants).
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, f.empty() ? nullptr : f.data(),
                   static_cast<socklen_t>(f.size() * sizeof(can_filter))) < 0) {
    return fail(fmt::format("CAN interface '{}': CAN_RAW_FILTER: {}", iface, std::strerror(errno)));
  }
  if (error_frames) {
    const can_err_mask_t mask = CAN_ERR_TX_TIMEOUT | CAN_ERR_LOSTARB | CAN_ERR_CRTL | CAN_ERR_PROT | CAN_ERR_TRX |
                                CAN_ERR_ACK | CAN_ERR_BUSOFF | CAN_ERR_BUSERROR | CAN_ERR_RESTARTED;
    if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &mask, sizeof mask) < 0) {
      return fail(fmt::format("CAN interface '{}': CAN_RAW_ERR_FILTER: {}", iface, std::strerror(errno)));
    }
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) < 0) {
    return fail(fmt::format("CAN interface '{}': bind: {}", iface, std::strerror(errno)));
  }
  return static_cast<void*>(new RawPort{fd});
}

int raw_send(void* p, const Frame& f) {
  can_frame cf{};
  cf.can_id = f.extended ? ((f.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (f.id & CAN_SFF_MASK);
  cf.len = f.len > 8 ? 8 : f.len;
  std::memcpy(cf.data, f.data, 8);
  const ssize_t n = ::send(static_cast<RawPort*>(p)->fd, &cf, sizeof cf, MSG_DONTWAIT);
  if (n == static_cast<ssize_t>(sizeof cf)) return 0;
  return n < 0 ? errno : EIO;
}

RecvResult raw_recv(void* p, Frame& f, int64_t timeout_ns, int* err) {
  const int fd = static_cast<RawPort*>(p)->fd;
  pollfd pfd{fd, POLLIN, 0};
  const int ms = timeout_ns <= 0 ? 0 : static_cast<int>((timeout_ns + 999999) / 1000000);
  const int r = ::poll(&pfd, 1, ms);
  if (r == 0) return RecvResult::kTimeout;
  if (r < 0) {
    if (errno == EINTR) return RecvResult::kTimeout;
    *err = errno;
    return RecvResult::kError;
  }
  can_frame cf{};
  const ssize_t n = ::recv(fd, &cf, sizeof cf, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EINTR) return RecvResult::kTimeout;
    *err = errno;
    return RecvResult::kError;
  }
  if (n != static_cast<ssize_t>(sizeof cf)) {
    *err = EPROTO;  // a CAN FD frame on a classic socket cannot happen; refuse what we do not know
    return RecvResult::kError;
  }
  f = Frame{};
  f.error = (cf.can_id & CAN_ERR_FLAG) != 0;
  f.extended = (cf.can_id & CAN_EFF_FLAG) != 0;
  f.id = f.error ? (cf.can_id & CAN_ERR_MASK) : f.extended ? (cf.can_id & CAN_EFF_MASK) : (cf.can_id & CAN_SFF_MASK);
  f.len = cf.len > 8 ? 8 : cf.len;
  std::memcpy(f.data, cf.data, 8);
  return RecvResult::kFrame;
}

void raw_close(void* p) {
  auto* port = static_cast<RawPort*>(p);
  ::close(port->fd);
  delete port;
}

const TransportOps kSocketCan{"socketcan", nullptr, &raw_open, &raw_send, &raw_recv, &raw_close};

}  // namespace

const TransportOps& socketcan_transport() {
  return kSocketCan;
}

Result<void> socketcan_available() {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return make_error(no_can_text(errno));
  ::close(fd);
  return {};
}

Result<Port> Port::open(const TransportOps& ops, const std::string& iface, std::span<const IdFilter> filters,
                        bool error_frames) {
  auto p = ops.open(ops.context, iface, filters, error_frames);
  if (!p) return make_error(p.error());
  Port port;
  port.ops_ = &ops;
  port.port_ = *p;
  return Result<Port>(std::move(port));
}

Port& Port::operator=(Port&& o) noexcept {
  if (this != &o) {
    close();
    ops_ = o.ops_;
    port_ = o.port_;
    o.port_ = nullptr;
  }
  return *this;
}

void Port::close() {
  if (port_ != nullptr) ops_->close(port_);
  port_ = nullptr;
}

}  // namespace rtplc::can
