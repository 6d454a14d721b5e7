// POSIX socket helpers (see socket_util.h).
#include "io/link/socket_util.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/tcp.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>

namespace rtplc::link {

void UniqueFd::reset(int fd) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = fd;
}

std::string Endpoint::text() const {
  char buf[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &addr.sin_addr, buf, sizeof buf);
  return fmt::format("{}:{}", buf, ntohs(addr.sin_port));
}

std::string errno_text(int err) { return std::strerror(err); }

Result<Endpoint> parse_endpoint(std::string_view ipv4, uint16_t port) {
  Endpoint ep;
  ep.addr.sin_family = AF_INET;
  ep.addr.sin_port = htons(port);
  const std::string s(ipv4);
  if (::inet_pton(AF_INET, s.c_str(), &ep.addr.sin_addr) != 1) {
    return make_error(fmt::format("'{}' is not an IPv4 address", s));
  }
  return ep;
}

Result<Endpoint> resolve_endpoint(std::string_view host, uint16_t port) {
  if (auto ep = parse_endpoint(host, port)) return ep;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  const std::string h(host);
  const int rc = ::getaddrinfo(h.c_str(), nullptr, &hints, &res);
  if (rc != 0 || res == nullptr) {
    return make_error(fmt::format("cannot resolve host '{}': {}", h, ::gai_strerror(rc)));
  }
  Endpoint ep;
  std::memcpy(&ep.addr, res->ai_addr, sizeof(sockaddr_in));
  ep.addr.sin_port = htons(port);
  ::freeaddrinfo(res);
  return ep;
}

Result<UniqueFd> start_connect(const Endpoint& ep) {
  UniqueFd fd(::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!fd.valid()) return make_error(fmt::format("socket: {}", errno_text(errno)));
  int one = 1;
  ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  const int rc = ::connect(fd.get(), reinterpret_cast<const sockaddr*>(&ep.addr), sizeof ep.addr);
  if (rc != 0 && errno != EINPROGRESS) {
    return make_error(fmt::format("connect to {}: {}", ep.text(), errno_text(errno)));
  }
  return fd;
}

int connect_error(int fd) {
  int err = 0;
  socklen_t len = sizeof err;
  if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0) return errno;
  return err;
}

Result<UniqueFd> listen_on(const Endpoint& ep, int backlog) {
  UniqueFd fd(::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!fd.valid()) return make_error(fmt::format("socket: {}", errno_text(errno)));
  int one = 1;
  ::setsockopt(fd.get(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(fd.get(), reinterpret_cast<const sockaddr*>(&ep.addr), sizeof ep.addr) != 0) {
    return make_error(fmt::format("bind {}: {}", ep.text(), errno_text(errno)));
  }
  if (::listen(fd.get(), backlog) != 0) return make_error(fmt::format("listen {}: {}", ep.text(), errno_text(errno)));
  return fd;
}

uint16_t local_port(int fd) {
  sockaddr_in a{};
  socklen_t len = sizeof a;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) return 0;
  return ntohs(a.sin_port);
}

size_t raise_fd_limit(size_t want) {
  rlimit rl{};
  if (::getrlimit(RLIMIT_NOFILE, &rl) != 0) return 0;
  if (rl.rlim_cur < want) {
    rl.rlim_cur = std::min<rlim_t>(want, rl.rlim_max);
    ::setrlimit(RLIMIT_NOFILE, &rl);
    ::getrlimit(RLIMIT_NOFILE, &rl);
  }
  return static_cast<size_t>(rl.rlim_cur);
}

}  // namespace rtplc::link
