// Small POSIX socket helpers shared by the engine, the session and the fake PLC:
// IPv4 endpoints, non-blocking connect and listen, and a file descriptor owner.
// (spec: s7-client.md, "The engine we want": non-blocking sockets, no select()).
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <string>
#include <string_view>

#include "common/result.h"

namespace rtplc::link {

// Owns one file descriptor; closes it when destroyed.
class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  UniqueFd(UniqueFd&& o) noexcept : fd_(o.release()) {}
  UniqueFd& operator=(UniqueFd&& o) noexcept {
    if (this != &o) reset(o.release());
    return *this;
  }
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;
  ~UniqueFd() { reset(); }

  int get() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  int release() {
    const int f = fd_;
    fd_ = -1;
    return f;
  }
  void reset(int fd = -1);

 private:
  int fd_ = -1;
};

struct Endpoint {
  sockaddr_in addr{};
  std::string text() const;  // "127.0.0.1:102"
};

// "10.0.0.5", "plc7.local" (resolved, IPv4) with the port.
Result<Endpoint> resolve_endpoint(std::string_view host, uint16_t port);
// Numeric IPv4 only (no resolver: safe to call from the engine thread).
Result<Endpoint> parse_endpoint(std::string_view ipv4, uint16_t port);

// Starts a non-blocking TCP connect; the socket is ready (or failed) when writable.
// Sets TCP_NODELAY: S7 jobs are small and latency is the point.
Result<UniqueFd> start_connect(const Endpoint& ep);
// The outcome of a non-blocking connect once the socket became writable (SO_ERROR).
int connect_error(int fd);
// A non-blocking listening socket bound to `ep` (port 0 picks one).
Result<UniqueFd> listen_on(const Endpoint& ep, int backlog);
// The port a socket is bound to.
uint16_t local_port(int fd);

// Raises RLIMIT_NOFILE towards `want` (up to the hard limit); returns the new soft limit.
size_t raise_fd_limit(size_t want);

std::string errno_text(int err);

}  // namespace rtplc::link
