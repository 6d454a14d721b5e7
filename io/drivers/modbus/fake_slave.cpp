// The fault-injecting Modbus TCP/RTU slave (see fake_slave.h).
#include "io/drivers/modbus/fake_slave.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>
#include <utility>

#include "kernel_rt/clock.h"

namespace rtplc::modbus {
namespace {

uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }
void put16(std::vector<uint8_t>& v, uint32_t x) {
  v.push_back(static_cast<uint8_t>(x >> 8));
  v.push_back(static_cast<uint8_t>(x));
}

std::vector<uint8_t> exception(uint8_t fc, uint8_t code) { return {static_cast<uint8_t>(fc | 0x80), code}; }

size_t table_index(Table t) { return static_cast<size_t>(t); }

// RTU: a partial frame followed by this much quiet is discarded. The standard's
// 3.5 character times are ~2 ms at 19200 baud; a shared test machine needs
// more slack, and a master waits far longer for its answer anyway.
constexpr int64_t kRtuGapNs = 50'000'000;

bool speed_of(uint32_t baud, speed_t& out) {
  static constexpr std::pair<uint32_t, speed_t> kSpeeds[] = {
      {1200, B1200},   {2400, B2400},   {4800, B4800},     {9600, B9600},     {19200, B19200},
      {38400, B38400}, {57600, B57600}, {115200, B115200}, {230400, B230400},
  };
  for (const auto& [b, s] : kSpeeds) {
    if (b == baud) {
      out = s;
      return true;
    }
  }
  return false;
}

}  // namespace

FakeSlave::FakeSlave(FakeSlaveOptions opt) : opt_(std::move(opt)) {
  for (auto& t : tables_) t.assign(65536, 0);
}

FakeSlave::~FakeSlave() { stop(); }

Result<void> FakeSlave::listen() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) return make_error(fmt::format("socket: {}", std::strerror(errno)));
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port_ != 0 ? port_ : opt_.port);
  if (inet_pton(AF_INET, opt_.bind.c_str(), &a.sin_addr) != 1) {
    ::close(fd);
    return make_error(fmt::format("'{}' is not a numeric IPv4 address", opt_.bind));
  }
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd, 64) != 0) {
    const int e = errno;
    ::close(fd);
    return make_error(fmt::format("cannot listen on {}:{}: {}", opt_.bind, ntohs(a.sin_port), std::strerror(e)));
  }
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
  listen_fd_.store(fd);
  return {};
}

Result<void> FakeSlave::open_serial() {
  const SerialLine& l = opt_.serial;
  speed_t speed{};
  if (!speed_of(l.baud, speed)) return make_error(fmt::format("{} baud is not a serial speed this slave knows", l.baud));
  const int fd = ::open(l.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return make_error(fmt::format("cannot open {}: {}", l.device, std::strerror(errno)));
  termios t{};
  if (::tcgetattr(fd, &t) != 0) {
    const int e = errno;
    ::close(fd);
    return make_error(fmt::format("{} is not a serial device: {}", l.device, std::strerror(e)));
  }
  ::cfmakeraw(&t);
  ::cfsetispeed(&t, speed);
  ::cfsetospeed(&t, speed);
  t.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cflag |= l.data_bits == 5 ? CS5 : l.data_bits == 6 ? CS6 : l.data_bits == 7 ? CS7 : CS8;
  if (l.parity != 'N') t.c_cflag |= PARENB;
  if (l.parity == 'O') t.c_cflag |= PARODD;
  if (l.stop_bits == 2) t.c_cflag |= CSTOPB;
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  if (::tcsetattr(fd, TCSANOW, &t) != 0) {
    const int e = errno;
    ::close(fd);
    // Some serial devices (and ptys, for some callers) refuse parity bits with EINVAL.
    return make_error(fmt::format("cannot set {} to {} baud {}{}{}: {}{}", l.device, l.baud, int{l.data_bits}, l.parity,
                                  int{l.stop_bits}, std::strerror(e), l.parity != 'N' ? " (try parity N)" : ""));
  }
  ::tcflush(fd, TCIOFLUSH);
  listen_fd_.store(fd);
  return {};
}

Result<void> FakeSlave::start() {
  if (auto r = rtu() ? open_serial() : listen(); !r) return r;
  stop_.store(false);
  thread_ = std::thread([this] { run(); });
  return {};
}

void FakeSlave::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  const int fd = listen_fd_.exchange(-1);
  if (fd >= 0) ::close(fd);
}

void FakeSlave::kill() {
  kill_.store(true);
  // The serving thread closes everything and acknowledges by clearing the flag.
  while (kill_.load() && thread_.joinable()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

Result<void> FakeSlave::restart() { return rtu() ? open_serial() : listen(); }

void FakeSlave::set_units(std::vector<uint8_t> units) {
  std::lock_guard lock(mu_);
  opt_.units = std::move(units);
}

uint16_t FakeSlave::get(Table t, uint16_t address) const {
  std::lock_guard lock(mu_);
  return tables_[table_index(t)][address];
}

void FakeSlave::set(Table t, uint16_t address, uint16_t value) {
  std::lock_guard lock(mu_);
  tables_[table_index(t)][address] = value;
}

void FakeSlave::put(const Address& a, double value) {
  uint16_t w[2] = {};
  encode(a, value, w);
  for (uint16_t i = 0; i < width(a); ++i) set(a.table, static_cast<uint16_t>(a.address + i), w[i]);
}

double FakeSlave::value(const Address& a) const {
  uint16_t w[2] = {};
  for (uint16_t i = 0; i < width(a); ++i) w[i] = get(a.table, static_cast<uint16_t>(a.address + i));
  return decode(a, w);
}

void FakeSlave::run() {
  const FrameOps& ops = frames();
  std::vector<Client> clients;  // TCP: the accepted connections; RTU: the line
  std::vector<Pending> pending;
  std::vector<Response> responses;
  std::vector<pollfd> fds;
  auto close_client = [&](int fd) {
    if (ops.connections) ::close(fd);  // the serial line is closed with listen_fd_
    clients.erase(std::remove_if(clients.begin(), clients.end(), [&](const Client& c) { return c.fd == fd; }),
                  clients.end());
    pending.erase(std::remove_if(pending.begin(), pending.end(), [&](const Pending& p) { return p.fd == fd; }),
                  pending.end());
  };
  while (!stop_.load()) {
    if (kill_.load()) {
      if (ops.connections) {
        for (const Client& c : clients) ::close(c.fd);
      }
      clients.clear();
      pending.clear();
      const int fd = listen_fd_.exchange(-1);
      if (fd >= 0) ::close(fd);
      kill_.store(false);
    }
    const int lfd = listen_fd_.load();
    if (!ops.connections && clients.empty() && lfd >= 0) clients.push_back({lfd, {}, 0});
    int64_t now = kernel_rt::monotonic_now_ns();
    int timeout_ms = 20;
    for (const Pending& p : pending) {
      timeout_ms = std::min<int>(timeout_ms, static_cast<int>(std::max<int64_t>(0, (p.due_ns - now) / 1000000)));
    }
    fds.clear();
    if (lfd >= 0 && ops.connections) fds.push_back({lfd, POLLIN, 0});
    for (const Client& c : clients) fds.push_back({c.fd, POLLIN, 0});
    ::poll(fds.data(), fds.size(), timeout_ms);
    now = kernel_rt::monotonic_now_ns();
    // Replies whose time has come.
    for (size_t i = 0; i < pending.size();) {
      if (pending[i].due_ns <= now) {
        if (ops.connections) {
          (void)!::send(pending[i].fd, pending[i].bytes.data(), pending[i].bytes.size(), MSG_NOSIGNAL);
        } else {
          (void)!::write(pending[i].fd, pending[i].bytes.data(), pending[i].bytes.size());
        }
        pending.erase(pending.begin() + static_cast<std::ptrdiff_t>(i));
      } else {
        ++i;
      }
    }
    std::vector<int> to_close;
    for (const pollfd& p : fds) {
      if (ops.connections && p.fd == lfd) {
        if (!(p.revents & POLLIN)) continue;
        const int c = ::accept4(lfd, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
        if (c >= 0) {
          const int one = 1;
          ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
          clients.push_back({c, {}, 0});
        }
        continue;
      }
      auto it = std::find_if(clients.begin(), clients.end(), [&](const Client& c) { return c.fd == p.fd; });
      if (it == clients.end()) continue;
      if (!ops.connections && !it->in.empty() && now - it->last_rx_ns > kRtuGapNs) it->in.clear();
      if (!(p.revents & (POLLIN | POLLHUP | POLLERR))) continue;
      uint8_t buf[4096];
      const ssize_t n = ::read(p.fd, buf, sizeof buf);
      if (n <= 0) {
        if (ops.connections) {
          to_close.push_back(p.fd);
        } else {
          // Nobody holds the other end of the pty yet (or any more): wait for one.
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        continue;
      }
      it->in.insert(it->in.end(), buf, buf + n);
      it->last_rx_ns = now;
      responses.clear();
      const bool keep = serve(ops, it->in, responses);
      for (Response& r : responses) {
        if (r.action == Response::Action::kReply) pending.push_back({p.fd, now + r.delay_ns, std::move(r.bytes)});
      }
      if (!keep) to_close.push_back(p.fd);
    }
    for (int fd : to_close) close_client(fd);
  }
  if (ops.connections) {
    for (const Client& c : clients) ::close(c.fd);
  }
}

bool FakeSlave::serve(const FrameOps& ops, std::vector<uint8_t>& in, std::vector<Response>& out) {
  for (;;) {
    const ptrdiff_t n = ops.frame_length(in.data(), in.size());
    if (n == 0) return true;
    if (n == kNotAFrame) {
      in.clear();
      return !ops.connections;
    }
    const auto len = static_cast<size_t>(n);
    Request req;
    if (!ops.open(in.data(), len, req)) {
      // RTU: a bad CRC; what follows cannot be trusted to start a frame either.
      in.clear();
      return true;
    }
    Response r = respond(ops, in.data(), len);
    in.erase(in.begin(), in.begin() + n);
    if (r.action == Response::Action::kDrop) {
      if (ops.connections) return false;
      r.action = Response::Action::kSilent;
    }
    out.push_back(std::move(r));
  }
}

Response FakeSlave::respond(const FrameOps& ops, const uint8_t* frame, size_t len) {
  Response r;
  Request req;
  if (!ops.open(frame, len, req)) return r;
  requests_.fetch_add(1);
  if (silent_.load()) return r;
  {
    std::lock_guard lock(mu_);
    if (!opt_.units.empty() && std::find(opt_.units.begin(), opt_.units.end(), req.unit) == opt_.units.end()) return r;
  }
  uint16_t magic = 0;
  std::vector<uint8_t> pdu = answer(req.pdu, req.pdu_len, magic);
  if (!ops.connections && req.unit == 0) return r;  // a broadcast: done, never answered
  if (magic == kMagicSilent) return r;
  if (magic == kMagicDrop) {
    r.action = Response::Action::kDrop;
    return r;
  }
  if (magic == kMagicBadLength && pdu.size() >= 2 && !(pdu[0] & 0x80) && pdu[0] <= 4) {
    // A byte count that does not match the request: two bytes too many.
    pdu[1] = static_cast<uint8_t>(pdu[1] + 2);
    pdu.push_back(0);
    pdu.push_back(0);
  }
  const FrameFault fault = magic == kMagicBadId    ? FrameFault::kWrongId
                           : magic == kMagicBadCrc ? FrameFault::kBadCrc
                                                   : FrameFault::kNone;
  ops.seal(req, pdu.data(), pdu.size(), fault, r.bytes);
  r.action = Response::Action::kReply;
  r.delay_ns = opt_.reply_delay_ns + (magic == kMagicDelay ? opt_.delay_ns : 0);
  return r;
}

// The PDU of the answer to one request; `magic` says which fault, if any, the
// request's range covered.
std::vector<uint8_t> FakeSlave::answer(const uint8_t* pdu, size_t len, uint16_t& magic) {
  if (len < 1) return exception(0, 1);
  const uint8_t fc = pdu[0];
  if (len < 5) return exception(fc, 3);
  const uint16_t addr = be16(pdu + 1);
  const uint16_t qty = be16(pdu + 3);
  uint32_t span = 1;
  if (fc == 1 || fc == 2 || fc == 3 || fc == 4 || fc == 15 || fc == 16) span = qty;
  const uint32_t end = uint32_t{addr} + span;
  for (uint32_t m = kMagicExceptionBase + 1; m <= kMagicExceptionBase + 11u; ++m) {
    if (addr <= m && m < end) return exception(fc, static_cast<uint8_t>(m - kMagicExceptionBase));
  }
  for (uint16_t m : {kMagicDelay, kMagicDrop, kMagicBadLength, kMagicSilent, kMagicBadId, kMagicBadCrc}) {
    if (addr <= m && m < end) magic = m;
  }
  std::vector<uint8_t> r{fc};
  std::lock_guard lock(mu_);
  switch (fc) {
    case 1:
    case 2: {
      if (qty < 1 || qty > 2000) return exception(fc, 3);
      if (end > 65536) return exception(fc, 2);
      const auto& t = tables_[table_index(fc == 1 ? Table::kCoil : Table::kDiscreteInput)];
      const auto bytes = static_cast<uint8_t>((qty + 7) / 8);
      r.push_back(bytes);
      for (uint32_t b = 0; b < bytes; ++b) {
        uint8_t v = 0;
        for (uint32_t i = 0; i < 8 && b * 8 + i < qty; ++i) v = static_cast<uint8_t>(v | (t[addr + b * 8 + i] ? 1u << i : 0u));
        r.push_back(v);
      }
      return r;
    }
    case 3:
    case 4: {
      if (qty < 1 || qty > 125) return exception(fc, 3);
      if (end > 65536) return exception(fc, 2);
      const auto& t = tables_[table_index(fc == 3 ? Table::kHoldingRegister : Table::kInputRegister)];
      r.push_back(static_cast<uint8_t>(qty * 2));
      for (uint32_t i = 0; i < qty; ++i) put16(r, t[addr + i]);
      return r;
    }
    case 5:
      if (qty != 0xFF00 && qty != 0) return exception(fc, 3);
      tables_[table_index(Table::kCoil)][addr] = qty ? 1 : 0;
      writes_.fetch_add(1);
      r.assign(pdu, pdu + 5);
      return r;
    case 6:
      tables_[table_index(Table::kHoldingRegister)][addr] = qty;
      writes_.fetch_add(1);
      r.assign(pdu, pdu + 5);
      return r;
    case 15:
    case 16: {
      if (len < 6) return exception(fc, 3);
      const size_t bytes = pdu[5];
      const bool regs = fc == 16;
      if (qty < 1 || qty > (regs ? 123 : 1968) || bytes != (regs ? qty * 2u : (qty + 7u) / 8u) || len < 6 + bytes) {
        return exception(fc, 3);
      }
      if (end > 65536) return exception(fc, 2);
      auto& t = tables_[table_index(regs ? Table::kHoldingRegister : Table::kCoil)];
      for (uint32_t i = 0; i < qty; ++i) {
        t[addr + i] = regs ? be16(pdu + 6 + 2 * i) : static_cast<uint16_t>((pdu[6 + i / 8] >> (i % 8)) & 1);
      }
      writes_.fetch_add(1);
      r.assign(pdu, pdu + 5);
      return r;
    }
    default: return exception(fc, 1);
  }
}

}  // namespace rtplc::modbus
