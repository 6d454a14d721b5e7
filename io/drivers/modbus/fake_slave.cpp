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

#include "io/drivers/modbus/pdu.h"
#include "kernel_rt/clock.h"

namespace rtplc::modbus {
namespace {

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
    Frame req;
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
  Frame req;
  if (!ops.open(frame, len, req)) return r;
  requests_.fetch_add(1);
  if (req.pdu_len >= 5) {
    std::lock_guard lock(mu_);
    const uint8_t fc = req.pdu[0];
    const bool spans = fc == 1 || fc == 2 || fc == 3 || fc == 4 || fc == 15 || fc == 16;
    if (log_.size() < 100000) {
      log_.push_back({fc, be16(req.pdu + 1), static_cast<uint16_t>(spans ? be16(req.pdu + 3) : 1),
                      kernel_rt::monotonic_now_ns()});
    }
  }
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

std::vector<FakeSlave::LoggedRequest> FakeSlave::request_log() const {
  std::lock_guard lock(mu_);
  return log_;
}

// The PDU of the answer to one request; `magic` says which fault, if any, the
// request's range covered.
std::vector<uint8_t> FakeSlave::answer(const uint8_t* pdu, size_t len, uint16_t& magic) {
  if (len < 1) return exception_reply(0, kExceptionIllegalFunction);
  const uint8_t fc = pdu[0];
  if (len < 5) return exception_reply(fc, kExceptionIllegalValue);
  // The faults come first, whatever else is wrong with the request.
  const uint16_t addr = be16(pdu + 1);
  const uint32_t span = fc == 1 || fc == 2 || fc == 3 || fc == 4 || fc == 15 || fc == 16 ? be16(pdu + 3) : 1;
  const uint32_t end = uint32_t{addr} + span;
  for (uint32_t m = kMagicExceptionBase + 1; m <= kMagicExceptionBase + 11u; ++m) {
    if (addr <= m && m < end) return exception_reply(fc, static_cast<uint8_t>(m - kMagicExceptionBase));
  }
  for (uint16_t m : {kMagicDelay, kMagicDrop, kMagicBadLength, kMagicSilent, kMagicBadId, kMagicBadCrc}) {
    if (addr <= m && m < end) magic = m;
  }
  Request rq;
  if (const uint8_t e = parse_request(pdu, len, rq); e != 0) return exception_reply(fc, e);
  std::lock_guard lock(mu_);
  switch (fc) {
    case 1:
    case 2: {
      const auto& t = tables_[table_index(fc == 1 ? Table::kCoil : Table::kDiscreteInput)];
      std::vector<uint8_t> bits(rq.count);
      for (uint32_t i = 0; i < rq.count; ++i) bits[i] = t[rq.address + i] != 0;
      return bits_reply(fc, bits.data(), rq.count);
    }
    case 3:
    case 4: {
      const auto& t = tables_[table_index(fc == 3 ? Table::kHoldingRegister : Table::kInputRegister)];
      return registers_reply(fc, t.data() + rq.address, rq.count);
    }
    case 5:
    case 6:
      tables_[table_index(fc == 5 ? Table::kCoil : Table::kHoldingRegister)][rq.address] = rq.value;
      writes_.fetch_add(1);
      return write_reply(pdu);
    default: {  // 15, 16
      const bool regs = fc == 16;
      auto& t = tables_[table_index(regs ? Table::kHoldingRegister : Table::kCoil)];
      for (uint16_t i = 0; i < rq.count; ++i) {
        t[rq.address + i] = regs ? rq.register_at(i) : static_cast<uint16_t>(rq.bit_at(i));
      }
      writes_.fetch_add(1);
      return write_reply(pdu);
    }
  }
}

}  // namespace rtplc::modbus
