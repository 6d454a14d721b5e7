// The fault-injecting Modbus TCP slave (see fake_slave.h).
#include "io/drivers/modbus/fake_slave.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "io/drivers/modbus/pdu.h"
#include "kernel_rt/clock.h"

namespace rtplc::modbus {
namespace {

uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }
size_t table_index(Table t) { return static_cast<size_t>(t); }

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

Result<void> FakeSlave::start() {
  if (auto r = listen(); !r) return r;
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

Result<void> FakeSlave::restart() { return listen(); }

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
  std::vector<Client> clients;
  std::vector<Pending> pending;
  std::vector<pollfd> fds;
  auto close_client = [&](int fd) {
    ::close(fd);
    clients.erase(std::remove_if(clients.begin(), clients.end(), [&](const Client& c) { return c.fd == fd; }),
                  clients.end());
    pending.erase(std::remove_if(pending.begin(), pending.end(), [&](const Pending& p) { return p.fd == fd; }),
                  pending.end());
  };
  while (!stop_.load()) {
    if (kill_.load()) {
      for (const Client& c : clients) ::close(c.fd);
      clients.clear();
      pending.clear();
      const int fd = listen_fd_.exchange(-1);
      if (fd >= 0) ::close(fd);
      kill_.store(false);
    }
    int64_t now = kernel_rt::monotonic_now_ns();
    int timeout_ms = 20;
    for (const Pending& p : pending) {
      timeout_ms = std::min<int>(timeout_ms, static_cast<int>(std::max<int64_t>(0, (p.due_ns - now) / 1000000)));
    }
    fds.clear();
    const int lfd = listen_fd_.load();
    if (lfd >= 0) fds.push_back({lfd, POLLIN, 0});
    for (const Client& c : clients) fds.push_back({c.fd, POLLIN, 0});
    ::poll(fds.data(), fds.size(), timeout_ms);
    now = kernel_rt::monotonic_now_ns();
    // Replies whose time has come.
    for (size_t i = 0; i < pending.size();) {
      if (pending[i].due_ns <= now) {
        (void)!::send(pending[i].fd, pending[i].bytes.data(), pending[i].bytes.size(), MSG_NOSIGNAL);
        pending.erase(pending.begin() + static_cast<std::ptrdiff_t>(i));
      } else {
        ++i;
      }
    }
    std::vector<int> to_close;
    for (const pollfd& p : fds) {
      if (!(p.revents & (POLLIN | POLLHUP | POLLERR))) continue;
      if (p.fd == lfd) {
        const int c = ::accept4(lfd, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
        if (c >= 0) {
          const int one = 1;
          ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
          clients.push_back({c, {}});
        }
        continue;
      }
      auto it = std::find_if(clients.begin(), clients.end(), [&](const Client& c) { return c.fd == p.fd; });
      if (it == clients.end()) continue;
      uint8_t buf[4096];
      const ssize_t n = ::recv(p.fd, buf, sizeof buf, 0);
      if (n <= 0) {
        to_close.push_back(p.fd);
        continue;
      }
      it->in.insert(it->in.end(), buf, buf + n);
      bool drop = false;
      size_t used = 0;
      while (!drop) {
        MbapFrame f;
        const FrameStatus st = next_frame(it->in.data() + used, it->in.size() - used, f);
        if (st == FrameStatus::kBad) drop = true;  // not Modbus TCP: hang up
        if (st != FrameStatus::kComplete) break;
        handle(*it, f, pending, drop);
        used += f.frame_len;
      }
      it->in.erase(it->in.begin(), it->in.begin() + static_cast<std::ptrdiff_t>(used));
      if (drop) to_close.push_back(p.fd);
    }
    for (int fd : to_close) close_client(fd);
  }
  for (const Client& c : clients) ::close(c.fd);
}

void FakeSlave::handle(Client& c, const MbapFrame& f, std::vector<Pending>& out, bool& drop) {
  requests_.fetch_add(1);
  if (silent_.load()) return;
  if (!opt_.units.empty() && std::find(opt_.units.begin(), opt_.units.end(), f.unit) == opt_.units.end()) return;
  uint16_t magic = 0;
  std::vector<uint8_t> pdu = answer(f.pdu, f.pdu_len, magic);
  if (magic == kMagicSilent) return;
  if (magic == kMagicDrop) {
    drop = true;
    return;
  }
  if (magic == kMagicBadLength && pdu.size() >= 2 && !(pdu[0] & 0x80) && pdu[0] <= 4) {
    // A byte count that does not match the request: two bytes too many.
    pdu[1] = static_cast<uint8_t>(pdu[1] + 2);
    pdu.push_back(0);
    pdu.push_back(0);
  }
  const uint16_t tid = magic == kMagicBadId ? static_cast<uint16_t>(f.transaction + 1) : f.transaction;
  std::vector<uint8_t> reply;
  append_frame(reply, tid, f.unit, pdu.data(), pdu.size());
  int64_t due = kernel_rt::monotonic_now_ns() + opt_.reply_delay_ns;
  if (magic == kMagicDelay) due += opt_.delay_ns;
  out.push_back({c.fd, due, std::move(reply)});
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
  for (uint16_t m : {kMagicDelay, kMagicDrop, kMagicBadLength, kMagicSilent, kMagicBadId}) {
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
