// The TCP slaves' event loop (see tcp_master.h). Everything below runs on the
// loop's thread, except push() (the bridge) and start/join (the driver).
#include "io/drivers/modbus/tcp_master.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <fmt/format.h>
#include <modbus/modbus.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

#include "kernel_rt/clock.h"

namespace rtplc::modbus {
namespace {

constexpr int64_t kDrainSlackNs = 100'000'000;
// How many slaves the loop serves (sends to) before it looks for answers.
constexpr size_t kSendsPerLook = 16;
// The largest answer frame: MBAP (7) + a 253-byte PDU; the buffer holds two,
// so a late answer and the awaited one can both be in it.
constexpr size_t kRxBytes = 2 * (7 + 253);

uint64_t key_of(uint32_t idx, uint32_t gen) { return static_cast<uint64_t>(gen) << 32 | idx; }

// A slave's write queue holds at least one job per write item of the slave:
// the bridge queues an item only when its value changed, so a whole cycle of
// changes always fits (BoundedQueue rounds up to a power of two).
size_t queue_size(const ModbusSettings& s, uint32_t slave) {
  size_t items = 0;
  for (const auto& w : s.writes) items += w.slave == s.slaves[slave].name ? 1u : 0u;
  return std::max<size_t>(64, items);
}

}  // namespace

struct TcpMaster::Peer {
  Peer(const ModbusSettings& s, uint32_t slave, Exchange& x, const LineOptions& opt)
      : book(s, std::vector<uint32_t>{slave}, x, opt), queue(queue_size(s, slave)) {}
  UnitBook book;  // one unit: the slave
  UnitBook::Unit& unit() { return book.units.front(); }
  link::Endpoint ep;
  link::UniqueFd fd;
  uint32_t gen = 0;  // of the socket: an event for an older one is dropped
  enum class State : uint8_t { kDown, kConnecting, kUp } state = State::kDown;
  // The request in flight (one at a time).
  Job job = Job::kNone;
  uint32_t block = 0;     // kRead: which of the unit's blocks
  int64_t due = 0;        // kRead: its slot on the grid
  WriteJob write;         // kWrite
  Asked asked;
  uint32_t attempt = 0;
  bool wrote_last = false;  // the last request was a write: a block due goes next
  uint16_t tid = 0;
  int64_t sent_ns = 0;
  int64_t deadline = 0;   // connecting or a request in flight: when it fails
  uint8_t rx[kRxBytes] = {};
  size_t rx_len = 0;
  link::BoundedQueue<WriteJob> queue;
  bool dirty = true;      // counters to publish
};

TcpMaster::TcpMaster(const ModbusSettings& s, const std::vector<uint32_t>& slaves, Exchange& x, LineOptions opt)
    : s_(s), opt_(std::move(opt)), timers_(slaves.size()) {
  peer_of_write_.assign(s.writes.size(), -1);
  for (uint32_t slave : slaves) {
    const auto i = static_cast<int32_t>(peers_.size());
    peers_.push_back(std::make_unique<Peer>(s, slave, x, opt_));
    for (uint32_t j = 0; j < s.writes.size(); ++j) {
      if (s.writes[j].slave == s.slaves[slave].name) peer_of_write_[j] = i;
    }
  }
}

TcpMaster::~TcpMaster() { join(); }

bool TcpMaster::push(const WriteJob& job) {
  const int32_t i = job.write < peer_of_write_.size() ? peer_of_write_[job.write] : -1;
  return i >= 0 && peers_[static_cast<size_t>(i)]->queue.push(job);
}

Result<void> TcpMaster::start() {
  for (auto& p : peers_) {
    const SlaveConfig& c = p->book.first();
    auto ep = link::parse_endpoint(c.address, c.port);
    if (!ep) return make_error(fmt::format("modbus slave {}: {}", c.name, ep.error()));
    p->ep = *ep;
  }
  epoll_ = link::UniqueFd(::epoll_create1(EPOLL_CLOEXEC));
  if (!epoll_.valid()) return make_error(fmt::format("modbus: epoll: {}", link::errno_text(errno)));
  const int64_t now = kernel_rt::monotonic_now_ns();
  for (uint32_t i = 0; i < peers_.size(); ++i) {
    peers_[i]->book.publish_all(now);
    timers_.schedule(i, now);  // connect at once
  }
  kernel_rt::ThreadSpec spec;
  spec.name = "mb-tcp";
  spec.fifo_priority = opt_.priority;
  if (opt_.cpu >= 0) spec.cpu = static_cast<unsigned>(opt_.cpu);
  auto t = kernel_rt::start_thread(spec, [this] { run(); });
  if (!t) return make_error(fmt::format("modbus TCP loop: {}", t.error()));
  thread_ = std::move(*t);
  started_ = true;
  return {};
}

void TcpMaster::join() {
  if (!started_) return;
  request_stop();
  thread_.join();
  started_ = false;
}

// ---- the loop ------------------------------------------------------------------

// Waits up to `wait_ns` (0: only looks) and handles what the sockets have.
// Each event gets its own time: handling a hundred answers takes a while, and
// an answer's values are available when they are stored, not when epoll woke.
void TcpMaster::pump(int64_t wait_ns) noexcept {
  std::array<epoll_event, 256> events;
  const timespec ts{static_cast<time_t>(wait_ns / 1'000'000'000), static_cast<long>(wait_ns % 1'000'000'000)};
  int n = ::epoll_pwait2(epoll_.get(), events.data(), static_cast<int>(events.size()), &ts, nullptr);
  if (n < 0 && errno == ENOSYS) {
    n = ::epoll_wait(epoll_.get(), events.data(), static_cast<int>(events.size()),
                     static_cast<int>((wait_ns + 999'999) / 1'000'000));
  }
  if (wait_ns > 0) wakeups_.fetch_add(1, std::memory_order_relaxed);
  for (int k = 0; k < n; ++k) {
    const uint64_t key = events[static_cast<size_t>(k)].data.u64;
    const auto i = static_cast<uint32_t>(key & 0xFFFFFFFF);
    if (i >= peers_.size() || peers_[i]->gen != static_cast<uint32_t>(key >> 32)) continue;
    on_io(i, events[static_cast<size_t>(k)].events, kernel_rt::monotonic_now_ns());
  }
}

void TcpMaster::run() noexcept {
  int64_t next_pickup = 0;
  int64_t drain_until = 0;
  while (true) {
    int64_t now = kernel_rt::monotonic_now_ns();
    if (!stopping_ && stop_.load(std::memory_order_acquire)) {
      // From here: no new polls or connects; queued writes still go out.
      stopping_ = true;
      int64_t longest = 0;
      for (auto& p : peers_) {
        const UnitBook::Unit& u = p->unit();
        longest = std::max(longest, (int64_t{u.cfg->retries} + 1) * u.timeout_ns);
      }
      drain_until = now + 2 * longest + kDrainSlackNs;
      for (uint32_t i = 0; i < peers_.size(); ++i) {
        Peer& p = *peers_[i];
        // A connect under way goes on when it has writes to deliver (within
        // drain_until); one without is abandoned.
        if (p.state == Peer::State::kConnecting && p.queue.empty()) {
          ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, p.fd.get(), nullptr);
          p.fd.reset();
          p.state = Peer::State::kDown;
        }
        reschedule(i);
      }
    }
    if (stopping_ && (drained() || now >= drain_until)) break;
    if (stopping_ || now >= next_pickup) {
      // The bridge's writes: an idle slave that is up takes its queue now.
      for (uint32_t i = 0; i < peers_.size(); ++i) {
        Peer& p = *peers_[i];
        if (p.state == Peer::State::kUp && p.job == Job::kNone) {
          if (start_next(p, now)) reschedule(i);
        }
      }
      next_pickup = now + opt_.wake_ns;
    }
    // Every service() moves its slave's deadline past `now` (a request sent,
    // a slot taken, a connect begun) or removes it; the bound only guards
    // against a bug turning that into a livelock. Every kSendsPerLook slaves
    // served, the answers already there are taken (the first slaves of a
    // period answer while the last ones are still being asked).
    for (size_t n = 0; n < 4 * peers_.size() + 16; ++n) {
      if (timers_.empty() || timers_.next_deadline() > now) break;
      service(timers_.top(), now);
      if (n % kSendsPerLook == kSendsPerLook - 1) pump(0);
    }
    for (auto& p : peers_) {
      if (p->dirty) {
        p->dirty = false;
        p->book.publish_all(now);
      }
    }
    const int64_t until = std::min(timers_.next_deadline(), stopping_ ? now + 1'000'000 : next_pickup);
    pump(std::max<int64_t>(1, until - kernel_rt::monotonic_now_ns()));
  }
  const int64_t now = kernel_rt::monotonic_now_ns();
  for (auto& p : peers_) {
    if (p->state != Peer::State::kDown) {
      if (p->job == Job::kWrite) p->book.write_done(p->write, nullptr);
      ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, p->fd.get(), nullptr);
      p->fd.reset();
      p->state = Peer::State::kDown;
      p->job = Job::kNone;
    }
    p->book.publish_all(now);
  }
}

bool TcpMaster::drained() const noexcept {
  for (const auto& p : peers_) {
    if (p->state == Peer::State::kDown) continue;
    if (p->job != Job::kNone || !p->queue.empty()) return false;
  }
  return true;
}

void TcpMaster::reschedule(uint32_t i) noexcept {
  Peer& p = *peers_[i];
  int64_t t = link::TimerHeap::kNever;
  switch (p.state) {
    case Peer::State::kConnecting: t = p.deadline; break;
    case Peer::State::kUp: t = p.job != Job::kNone ? p.deadline : stopping_ ? t : UnitBook::next_due(p.unit()); break;
    case Peer::State::kDown:
      if (!stopping_) t = std::min(p.book.next_connect(), UnitBook::next_due(p.unit()));
      break;
  }
  timers_.schedule(i, t);
}

// A slave's deadline came: a timeout, a reconnect, a poll due.
void TcpMaster::service(uint32_t i, int64_t now) noexcept {
  Peer& p = *peers_[i];
  UnitBook::Unit& u = p.unit();
  switch (p.state) {
    case Peer::State::kDown:
      if (!stopping_ && p.book.connect_due(now)) begin_connect(p, i, now);
      if (p.state != Peer::State::kDown) break;  // connecting: the polls due go out once it is up
      for (UnitBook::UnitBlock& b : u.blocks) {
        if (now >= b.next_due) {
          UnitBook::skip_slot(u, b, now);
          p.dirty = true;
        }
      }
      break;
    case Peer::State::kConnecting:
      if (now < p.deadline) break;
      // The loop may come to the deadline late, after the connect completed:
      // look at the socket before calling it a timeout.
      if (pollfd pf{p.fd.get(), POLLOUT, 0}; ::poll(&pf, 1, 0) == 1) {
        on_io(i, static_cast<uint32_t>(pf.revents & POLLOUT ? EPOLLOUT : EPOLLERR), now);
        return;  // on_io rescheduled
      }
      connect_done(p, ETIMEDOUT, now);
      break;
    case Peer::State::kUp:
      if (p.job != Job::kNone) {
        if (now < p.deadline) break;
        // An answer that arrived in time may still sit in the socket (the loop
        // reaches deadlines before it reads): read first.
        const uint16_t tid = p.tid;
        receive(i, now);
        if (p.state != Peer::State::kUp || p.job == Job::kNone || p.tid != tid || now < p.deadline) break;
        finish(p, Outcome{Outcome::Kind::kTimeout, ETIMEDOUT}, nullptr, now);
      } else {
        start_next(p, now);
      }
      break;
  }
  reschedule(i);
}

void TcpMaster::begin_connect(Peer& p, uint32_t i, int64_t now) noexcept {
  p.book.connecting();
  p.dirty = true;
  link::UniqueFd fd(::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  int err = fd.valid() ? 0 : errno;
  if (fd.valid()) {
    int one = 1;
    ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&p.ep.addr), sizeof p.ep.addr) != 0 &&
        errno != EINPROGRESS) {
      err = errno;
    }
  }
  ++p.gen;
  epoll_event ev{};
  ev.events = EPOLLOUT | EPOLLIN;
  ev.data.u64 = key_of(i, p.gen);
  if (err == 0 && ::epoll_ctl(epoll_.get(), EPOLL_CTL_ADD, fd.get(), &ev) != 0) err = errno;
  if (err != 0) {
    p.book.connect_failed(Outcome{Outcome::Kind::kLink, err}, now);
    return;
  }
  p.fd = std::move(fd);
  p.state = Peer::State::kConnecting;
  p.deadline = now + p.unit().timeout_ns;
}

void TcpMaster::connect_done(Peer& p, int err, int64_t now) noexcept {
  p.dirty = true;
  if (err != 0) {
    ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, p.fd.get(), nullptr);
    p.fd.reset();
    p.state = Peer::State::kDown;
    p.book.connect_failed(Outcome{Outcome::Kind::kLink, err}, now);
    return;
  }
  p.state = Peer::State::kUp;
  p.job = Job::kNone;
  p.rx_len = 0;
  p.book.connected();
  start_next(p, now);
}

// An idle slave that is up: its next write, else its next block due. True
// when a request went out (or the attempt ended the connection).
bool TcpMaster::start_next(Peer& p, int64_t now) noexcept {
  UnitBook::Unit& u = p.unit();
  // Writes and due polls alternate when both wait, so a task that changes its
  // outputs every cycle cannot starve the slave's reads.
  UnitBook::UnitBlock* due = nullptr;
  if (!stopping_) {
    for (UnitBook::UnitBlock& b : u.blocks) {
      if (now >= b.next_due && (!due || b.next_due < due->next_due)) due = &b;
    }
  }
  if (!(due && p.wrote_last) && p.queue.pop(p.write)) {
    p.job = Job::kWrite;
    p.wrote_last = true;
    const Address& a = s_.writes[p.write.write].item;
    if (!is_writable(a.table)) {  // the config refuses these; never sent
      p.job = Job::kNone;
      const Outcome o{Outcome::Kind::kException, kExceptionIllegalFunction};
      p.book.write_done(p.write, &o);
      return start_next(p, now);
    }
    p.asked = write_request(u.cfg->unit, a, p.write.words);
  } else {
    if (!due) return false;
    p.job = Job::kRead;
    p.wrote_last = false;
    p.block = static_cast<uint32_t>(due - u.blocks.data());
    p.due = UnitBook::take_slot(u, *due, now);
    p.asked = read_request(u.cfg->unit, due->block.table, due->block.start, due->block.count);
  }
  p.attempt = 0;
  send_job(p, now);
  return true;
}

void TcpMaster::send_job(Peer& p, int64_t now) noexcept {
  uint8_t frame[kMaxRequestFrame];
  ++p.tid;
  const size_t len = frame_request(p.asked, p.tid, frame);
  p.sent_ns = now;
  p.deadline = now + p.unit().timeout_ns;
  // One request of at most 17 bytes in flight on a connected socket: the send
  // buffer always takes it whole. A short or refused send means the
  // connection is broken (reset, or a peer that stopped reading entirely).
  const ssize_t n = ::send(p.fd.get(), frame, len, MSG_NOSIGNAL | MSG_DONTWAIT);
  if (n != static_cast<ssize_t>(len)) {
    finish(p, Outcome{Outcome::Kind::kLink, n < 0 ? errno : EPIPE}, nullptr, now);
  }
}

// The request in flight ended with `o` (an answer, a timeout, a lost link;
// `why_lost` says how a link was lost, for the log).
void TcpMaster::finish(Peer& p, const Outcome& o, const uint16_t* words, int64_t now, const char* why_lost) noexcept {
  UnitBook::Unit& u = p.unit();
  p.book.record(u, o, p.sent_ns, now);
  p.dirty = true;
  const bool again = p.state == Peer::State::kUp && p.attempt < u.cfg->retries &&
                     (o.kind == Outcome::Kind::kTimeout ||
                      (p.job == Job::kRead && o.kind == Outcome::Kind::kProtocol));
  if (again) {
    ++p.attempt;
    send_job(p, now);  // a new transaction id: the late answer to this attempt is dropped
    return;
  }
  const Job job = p.job;
  p.job = Job::kNone;
  if (job == Job::kWrite) {
    p.book.write_done(p.write, &o);
    if (o.kind == Outcome::Kind::kLink) drop(p, now, why_lost ? why_lost : "connection lost on a write");
    return;
  }
  const char* why = p.book.poll_done(u, u.blocks[p.block], o, words, p.due, now);
  if (why) drop(p, now, o.kind == Outcome::Kind::kLink && why_lost ? why_lost : why);
}

// The connection is broken (`err`, `why` for the log): the request in flight
// fails as a link loss, then the connection is dropped if finishing it did not.
void TcpMaster::lose_link(Peer& p, int err, const char* why, int64_t now) noexcept {
  if (p.job != Job::kNone) finish(p, Outcome{Outcome::Kind::kLink, err}, nullptr, now, why);
  if (p.state == Peer::State::kUp) drop(p, now, why);
}

void TcpMaster::drop(Peer& p, int64_t now, const char* why) noexcept {
  if (p.job == Job::kWrite) {
    const Outcome lost{Outcome::Kind::kLink, ECONNRESET};
    p.book.write_done(p.write, &lost);
  }
  p.job = Job::kNone;
  ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, p.fd.get(), nullptr);
  p.fd.reset();
  p.rx_len = 0;
  p.state = Peer::State::kDown;
  p.dirty = true;
  p.book.dropped(now, why);
}

void TcpMaster::on_io(uint32_t i, uint32_t events, int64_t now) noexcept {
  Peer& p = *peers_[i];
  if (p.state == Peer::State::kConnecting) {
    if (events & (EPOLLOUT | EPOLLERR | EPOLLHUP)) {
      const int err = link::connect_error(p.fd.get());
      connect_done(p, err != 0 ? err : (events & (EPOLLERR | EPOLLHUP)) ? ECONNREFUSED : 0, now);
      if (p.state == Peer::State::kUp) {
        epoll_event ev{};
        ev.events = EPOLLIN;
        ev.data.u64 = key_of(i, p.gen);
        ::epoll_ctl(epoll_.get(), EPOLL_CTL_MOD, p.fd.get(), &ev);
      }
    }
    reschedule(i);
    return;
  }
  if (p.state != Peer::State::kUp) return;
  receive(i, now);
  if (p.state == Peer::State::kUp && p.job == Job::kNone) start_next(p, now);
  reschedule(i);
}

// Everything that arrived on a slave's socket: each whole frame as soon as it
// is in the buffer (so the buffer, room for two of the largest frames, always
// has room for the rest of a partial one), then a close or error.
void TcpMaster::receive(uint32_t i, int64_t now) noexcept {
  Peer& p = *peers_[i];
  int lost = 0;
  const char* why = "connection closed by the slave";
  while (p.state == Peer::State::kUp) {
    const ssize_t n = ::recv(p.fd.get(), p.rx + p.rx_len, sizeof p.rx - p.rx_len, MSG_DONTWAIT);
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) lost = ECONNRESET;  // closed by the slave
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
      lost = errno;
      why = "connection lost";
    }
    if (n <= 0) break;
    const bool emptied = static_cast<size_t>(n) < sizeof p.rx - p.rx_len;
    p.rx_len += static_cast<size_t>(n);
    size_t used = 0;
    while (true) {
      Frame f;
      const FrameStatus st = next_frame(p.rx + used, p.rx_len - used, f);
      if (st == FrameStatus::kIncomplete) break;
      if (st == FrameStatus::kBad) {
        // Not Modbus TCP: the stream cannot be resynchronised. The request
        // in flight fails as a link loss (no retry on this connection).
        lose_link(p, EMBBADDATA, "an answer that is not Modbus TCP", now);
        return;
      }
      used += f.frame_len;
      if (p.job == Job::kNone || f.transaction != p.tid) continue;  // late, or not asked for
      uint16_t words[2000];  // the most bits one read asks for
      const Outcome o = check_answer(p.asked, f, words);
      finish(p, o, words, now);
      if (p.state != Peer::State::kUp) return;
    }
    std::memmove(p.rx, p.rx + used, p.rx_len - used);
    p.rx_len -= used;
    // A partial frame is shorter than the largest frame, so the buffer has
    // room; a full one would mean next_frame accepted a frame past its bound.
    if (p.rx_len == sizeof p.rx) {
      lost = EMSGSIZE;
      why = "an answer longer than Modbus TCP allows";
      break;
    }
    // A short read took all the socket held: what comes later wakes epoll
    // again (level-triggered), so no second recv to hear EAGAIN. On a
    // virtual machine a system call costs microseconds; a poll is one send
    // and one recv.
    if (emptied) break;
  }
  if (lost != 0 && p.state == Peer::State::kUp) lose_link(p, lost, why, now);
}

}  // namespace rtplc::modbus
