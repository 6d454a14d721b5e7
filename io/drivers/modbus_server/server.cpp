// The modbus-server's TCP loop (see server.h).
#include "io/drivers/modbus_server/server.h"

#include <arpa/inet.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>

#include "io/drivers/modbus/pdu.h"
#include "kernel_rt/clock.h"

namespace rtplc::modbus_server {
namespace {

constexpr size_t kMaxUnsent = 64 * 1024;
constexpr int kPollMs = 50;  // how soon stop() and idle clients are noticed

std::string peer_text(const sockaddr_in& a) {
  char ip[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &a.sin_addr, ip, sizeof ip);
  return fmt::format("{}:{}", ip, ntohs(a.sin_port));
}

void add(std::atomic<uint64_t>& c, uint64_t n = 1) {
  c.store(c.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);  // one writer
}

}  // namespace

TcpServer::TcpServer(const ServerSettings& s, const RequestHandler& handler, Log log)
    : s_(s), handler_(handler), log_(std::move(log)) {}

TcpServer::~TcpServer() { stop(); }

Result<void> TcpServer::listen() {
  auto ep = link::parse_endpoint(s_.bind, s_.port);
  if (!ep) return make_error(ep.error());
  auto fd = link::listen_on(*ep, 64);
  if (!fd) {
    std::string hint;
    if (errno == EACCES && s_.port < 1024) {
      hint = "; ports below 1024 need root or CAP_NET_BIND_SERVICE (or set port: 1502)";
    } else if (errno == EADDRINUSE) {
      hint = "; another program listens there";
    }
    return make_error(fmt::format("modbus server cannot listen: {}{}", fd.error(), hint));
  }
  listen_fd_ = std::move(*fd);
  port_ = link::local_port(listen_fd_.get());
  // Every client is a descriptor: make room for max_clients of them.
  link::raise_fd_limit(s_.max_clients + 256);
  counters_.listening.store(true, std::memory_order_relaxed);
  return {};
}

Result<void> TcpServer::start(const std::string& thread_name, int priority, int cpu) {
  if (!listen_fd_.valid()) {
    if (auto r = listen(); !r) return r;
  }
  kernel_rt::ThreadSpec spec;
  spec.name = thread_name;
  spec.fifo_priority = priority;
  if (cpu >= 0) spec.cpu = static_cast<unsigned>(cpu);
  stop_.store(false, std::memory_order_relaxed);
  auto t = kernel_rt::start_thread(spec, [this] { run(); });
  if (!t) return make_error(t.error());
  thread_ = std::move(*t);
  return {};
}

void TcpServer::stop() {
  stop_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
  clients_.clear();
  listen_fd_.reset();
  counters_.listening.store(false, std::memory_order_relaxed);
  counters_.connected.store(0, std::memory_order_relaxed);
}

void TcpServer::run() {
  std::vector<pollfd> fds;
  while (!stop_.load(std::memory_order_relaxed)) {
    fds.clear();
    const bool accepting = kernel_rt::monotonic_now_ns() >= accept_paused_until_ns_;
    fds.push_back({listen_fd_.get(), static_cast<short>(accepting ? POLLIN : 0), 0});
    for (const Client& c : clients_) {
      fds.push_back({c.fd.get(), static_cast<short>(POLLIN | (c.out.empty() ? 0 : POLLOUT)), 0});
    }
    ::poll(fds.data(), static_cast<nfds_t>(fds.size()), kPollMs);
    const int64_t now = kernel_rt::monotonic_now_ns();
    const int64_t idle_ns = static_cast<int64_t>(s_.timeout_s * 1e9);
    // fds[i + 1] is clients_[i]: clients accepted below come after them.
    std::vector<bool> keep(clients_.size(), true);
    for (size_t i = 0; i < clients_.size(); ++i) {
      Client& c = clients_[i];
      const short ev = fds[i + 1].revents;
      if (ev & (POLLIN | POLLHUP | POLLERR)) keep[i] = serve(c, now);
      if (keep[i] && (ev & POLLOUT)) keep[i] = flush(c);
      if (keep[i] && now - c.last_heard_ns > idle_ns) {
        add(counters_.idle_closed);
        log_(false, fmt::format("client {} closed: silent for {} s", c.peer, s_.timeout_s));
        keep[i] = false;
      }
    }
    size_t w = 0;
    for (size_t i = 0; i < clients_.size(); ++i) {
      if (keep[i]) {
        if (w != i) clients_[w] = std::move(clients_[i]);
        ++w;
      }
    }
    clients_.resize(w);
    if (fds[0].revents & POLLIN) accept_clients(now);
    counters_.connected.store(clients_.size(), std::memory_order_relaxed);
  }
}

void TcpServer::accept_clients(int64_t now) {
  for (;;) {
    sockaddr_in a{};
    socklen_t len = sizeof a;
    link::UniqueFd fd(::accept4(listen_fd_.get(), reinterpret_cast<sockaddr*>(&a), &len,
                                SOCK_NONBLOCK | SOCK_CLOEXEC));
    if (!fd.valid()) {
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
        // Out of descriptors: the waiting client stays queued; try again in a
        // second rather than spin on a listening socket that stays readable.
        accept_paused_until_ns_ = now + 1000000000;
        log_(true, fmt::format("cannot accept a client: {}", link::errno_text(errno)));
      }
      return;  // EAGAIN: nobody else waits
    }
    const std::string peer = peer_text(a);
    const char* why = nullptr;
    if (!s_.allows(ntohl(a.sin_addr.s_addr))) why = "not in 'allow'";
    else if (clients_.size() >= s_.max_clients) why = "max_clients reached";
    if (why != nullptr) {
      add(counters_.refused);
      // Every refusal is counted; the first ones and then every thousandth are logged.
      if (refusals_logged_ < 10 || counters_.refused.load(std::memory_order_relaxed) % 1000 == 0) {
        ++refusals_logged_;
        log_(true, fmt::format("client {} refused: {} ({} refused so far)", peer, why,
                               counters_.refused.load(std::memory_order_relaxed)));
      }
      continue;  // fd closes here
    }
    const int one = 1;
    ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    add(counters_.accepted);
    Client c;
    c.fd = std::move(fd);
    c.peer = peer;
    c.last_heard_ns = now;
    clients_.push_back(std::move(c));
  }
}

bool TcpServer::serve(Client& c, int64_t now) {
  uint8_t buf[4096];
  for (;;) {
    const ssize_t n = ::recv(c.fd.get(), buf, sizeof buf, 0);
    if (n == 0) return false;  // the client closed
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) break;
      if (errno == EINTR) continue;
      return false;
    }
    c.in.insert(c.in.end(), buf, buf + n);
    c.last_heard_ns = now;
    if (static_cast<size_t>(n) < sizeof buf) break;
  }
  size_t used = 0;
  for (;;) {
    modbus::Frame f;
    const modbus::FrameStatus st = modbus::next_frame(c.in.data() + used, c.in.size() - used, f);
    if (st == modbus::FrameStatus::kBad) {
      add(counters_.bad_frames);
      log_(true, fmt::format("client {} closed: it does not speak Modbus TCP", c.peer));
      return false;
    }
    if (st == modbus::FrameStatus::kIncomplete) break;
    add(counters_.requests);
    Outcome out;
    std::vector<uint8_t> pdu;
    if (!s_.answers(f.unit)) {
      out.exception = modbus::kExceptionGatewayTarget;
      pdu = modbus::exception_reply(f.pdu[0], out.exception);
    } else {
      pdu = handler_.answer(f.pdu, f.pdu_len, out);
    }
    if (out.exception != 0) add(counters_.exceptions);
    if (out.written != 0) add(counters_.writes_accepted, out.written);
    if (out.write_refused || (out.exception != 0 && f.pdu[0] >= 5)) add(counters_.writes_refused);
    for (const std::string& line : out.log) log_(out.write_refused, fmt::format("client {}: {}", c.peer, line));
    modbus::append_frame(c.out, f.transaction, f.unit, pdu.data(), pdu.size());
    used += f.frame_len;
  }
  c.in.erase(c.in.begin(), c.in.begin() + static_cast<std::ptrdiff_t>(used));
  return flush(c);
}

bool TcpServer::flush(Client& c) {
  while (!c.out.empty()) {
    const ssize_t n = ::send(c.fd.get(), c.out.data(), c.out.size(), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) break;
      return false;
    }
    c.out.erase(c.out.begin(), c.out.begin() + n);
  }
  return c.out.size() <= kMaxUnsent;
}

}  // namespace rtplc::modbus_server
