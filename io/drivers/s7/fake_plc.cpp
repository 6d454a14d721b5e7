// The fake S7 PLC (see fake_plc.h): an epoll server answering COTP, setup
// communication, read var and write var from per-endpoint memory, with injected
// delays and faults (issue 4, item 6b).
#include "io/drivers/s7/fake_plc.h"

#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <mutex>
#include <queue>
#include <thread>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "io/drivers/s7/link.h"
#include "kernel_rt/clock.h"

namespace rtplc::s7 {
namespace {

constexpr uint64_t kListenerBit = uint64_t{1} << 63;

int64_t mono_ns() { return kernel_rt::monotonic_now_ns(); }

}  // namespace

// The fake's connections, endpoints and delayed replies: FakePlc::Impl's
// members, so named (a member of an external class may not have a type from an
// anonymous namespace once this file is compiled inside a unity batch).
namespace fake_plc_detail {

enum class Fault : uint8_t { kNone, kDisconnect, kWrongRef, kMalformed };

struct Conn {
  UniqueFd fd;
  uint32_t gen = 0;
  size_t ep = 0;
  bool silent = false;
  bool want_out = false;
  uint16_t pdu = 240;
  Bytes in;
  Bytes out;
};

struct Ep {
  FakeEndpointSpec spec;
  UniqueFd listener;
  UniqueFd filler;  // kNeverAccept: the connection that keeps the accept queue full
  FakeStats st;
  std::unordered_map<uint32_t, Bytes> mem;
  std::vector<uint32_t> conns;
};

struct Delayed {
  int64_t due;
  uint64_t seq;  // keeps replies of one connection in order when due times tie
  uint32_t conn;
  uint32_t gen;
  Fault fault;
  Bytes frame;
  bool operator>(const Delayed& o) const { return due != o.due ? due > o.due : seq > o.seq; }
};

}  // namespace fake_plc_detail

using fake_plc_detail::Conn;
using fake_plc_detail::Delayed;
using fake_plc_detail::Ep;
using fake_plc_detail::Fault;

struct FakePlc::Impl {
  mutable std::mutex mu;
  UniqueFd epfd;
  UniqueFd wakefd;
  std::vector<Ep> eps;
  std::vector<Conn> conns;
  std::vector<uint32_t> free_conns;
  std::priority_queue<Delayed, std::vector<Delayed>, std::greater<>> delayed;
  uint64_t seq = 0;
  uint64_t rng;
  std::thread thread;
  std::atomic<bool> stop_flag{false};

  explicit Impl(uint64_t seed) : rng(seed | 1) {
    epfd.reset(::epoll_create1(EPOLL_CLOEXEC));
    wakefd.reset(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = kListenerBit - 1;
    ::epoll_ctl(epfd.get(), EPOLL_CTL_ADD, wakefd.get(), &ev);
  }

  double uniform() {
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return static_cast<double>(rng >> 11) / 9007199254740992.0;
  }

  Result<void> listen(size_t i) {
    Ep& e = eps[i];
    auto ep = parse_endpoint(e.spec.address, e.spec.port);
    if (!ep) return make_error(ep.error());
    const bool never = e.spec.behavior.blackhole == FakeBehavior::Blackhole::kNeverAccept;
    auto fd = listen_on(*ep, never ? 0 : 4096);
    if (!fd) return make_error(fd.error());
    e.listener = std::move(*fd);
    e.spec.port = local_port(e.listener.get());
    if (never) {
      // One connection we never accept fills the zero-length accept queue; from then
      // on the kernel drops every SYN, exactly like a host that is gone.
      auto self = parse_endpoint(e.spec.address, e.spec.port);
      auto c = start_connect(*self);
      if (c) e.filler = std::move(*c);
      return {};
    }
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = kListenerBit | i;
    ::epoll_ctl(epfd.get(), EPOLL_CTL_ADD, e.listener.get(), &ev);
    return {};
  }

  void close_conn(uint32_t c) {
    Conn& k = conns[c];
    if (!k.fd.valid()) return;
    k.fd.reset();
    ++k.gen;
    k.in.clear();
    k.out.clear();
    auto& list = eps[k.ep].conns;
    list.erase(std::remove(list.begin(), list.end(), c), list.end());
    free_conns.push_back(c);
  }

  void close_all(size_t ep) {
    const std::vector<uint32_t> list = eps[ep].conns;
    for (uint32_t c : list) close_conn(c);
  }

  void accept_all(size_t i) {
    Ep& e = eps[i];
    while (e.listener.valid()) {
      const int fd = ::accept4(e.listener.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) return;
      ++e.st.accepted;
      uint32_t c = 0;
      if (!free_conns.empty()) {
        c = free_conns.back();
        free_conns.pop_back();
      } else {
        c = static_cast<uint32_t>(conns.size());
        conns.emplace_back();
      }
      Conn& k = conns[c];
      k.fd.reset(fd);
      k.ep = i;
      k.silent = e.spec.behavior.blackhole == FakeBehavior::Blackhole::kAcceptSilent;
      k.want_out = false;
      k.pdu = 240;
      e.conns.push_back(c);
      epoll_event ev{};
      ev.events = EPOLLIN;
      ev.data.u64 = static_cast<uint64_t>(k.gen) << 32 | c;
      ::epoll_ctl(epfd.get(), EPOLL_CTL_ADD, fd, &ev);
    }
  }

  void flush(uint32_t c) {
    Conn& k = conns[c];
    while (!k.out.empty()) {
      const ssize_t n = ::send(k.fd.get(), k.out.data(), k.out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        k.out.erase(k.out.begin(), k.out.begin() + n);
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
      close_conn(c);
      return;
    }
    const bool want = !k.out.empty();
    if (want != k.want_out) {
      epoll_event ev{};
      ev.events = EPOLLIN | (want ? EPOLLOUT : 0u);
      ev.data.u64 = static_cast<uint64_t>(k.gen) << 32 | c;
      ::epoll_ctl(epfd.get(), EPOLL_CTL_MOD, k.fd.get(), &ev);
      k.want_out = want;
    }
  }

  void schedule(uint32_t c, Bytes frame, bool data_reply, int64_t now) {
    Conn& k = conns[c];
    Ep& e = eps[k.ep];
    const FakeBehavior& b = e.spec.behavior;
    Fault f = Fault::kNone;
    if (data_reply) {
      const double u = uniform();
      if (u < b.p_disconnect_mid_reply) {
        f = Fault::kDisconnect;
      } else if (u < b.p_disconnect_mid_reply + b.p_wrong_ref) {
        f = Fault::kWrongRef;
      } else if (u < b.p_disconnect_mid_reply + b.p_wrong_ref + b.p_malformed) {
        f = Fault::kMalformed;
      }
    }
    const int64_t delay = static_cast<int64_t>(b.delay_us) * 1000 +
                          static_cast<int64_t>(uniform() * static_cast<double>(b.jitter_us)) * 1000;
    delayed.push(Delayed{now + delay, ++seq, c, k.gen, f, std::move(frame)});
  }

  void deliver(Delayed& d) {
    Conn& k = conns[d.conn];
    if (!k.fd.valid() || k.gen != d.gen) return;
    Ep& e = eps[k.ep];
    switch (d.fault) {
      case Fault::kNone:
        break;
      case Fault::kDisconnect: {
        ++e.st.faults;
        const size_t half = d.frame.size() / 2;
        [[maybe_unused]] const ssize_t n = ::send(k.fd.get(), d.frame.data(), half, MSG_NOSIGNAL | MSG_DONTWAIT);
        close_conn(d.conn);
        return;
      }
      case Fault::kWrongRef:
        ++e.st.faults;
        d.frame[kFramePduRefOffset] ^= 0x40;
        break;
      case Fault::kMalformed:
        ++e.st.faults;
        // The S7 data length claims more than the frame holds.
        if (d.frame.size() > kFramePduRefOffset + 6) d.frame[kFramePduRefOffset + 4] ^= 0x7F;
        break;
    }
    if (d.fault == Fault::kNone) ++e.st.replies;
    k.out.insert(k.out.end(), d.frame.begin(), d.frame.end());
    flush(d.conn);
  }

  // --- memory ---
  static uint32_t area_key(Area a, uint16_t db) {
    return static_cast<uint32_t>(a) << 16 | (a == Area::kDB ? db : 0u);
  }
  Bytes* region(size_t ep, Area a, uint16_t db, bool create) {
    Ep& e = eps[ep];
    if (a == Area::kDB && (db == 0 || db > e.spec.behavior.db_count)) return nullptr;
    auto it = e.mem.find(area_key(a, db));
    if (it != e.mem.end()) return &it->second;
    if (!create) return nullptr;
    const bool elements = a == Area::kCounters || a == Area::kTimers;
    auto& r = e.mem[area_key(a, db)];
    r.assign(static_cast<size_t>(e.spec.behavior.area_size) * (elements ? 2 : 1), 0);
    return &r;
  }

  // Locates the bytes a var addresses: offset and length, or an item return code.
  uint8_t locate(size_t ep, const VarSpec& v, Bytes*& mem, size_t& off, size_t& len, uint8_t& bit) {
    const bool ct = v.area == Area::kCounters || v.area == Area::kTimers;
    const bool ct_ts = v.ts == TransportSize::kCounter || v.ts == TransportSize::kTimer;
    if (v.area != Area::kInputs && v.area != Area::kOutputs && v.area != Area::kFlags && v.area != Area::kDB && !ct) {
      return 0x0A;
    }
    if (ct != ct_ts) return 0x06;
    mem = region(ep, v.area, v.db, true);
    if (mem == nullptr) return 0x0A;
    bit = 0;
    if (ct) {
      off = static_cast<size_t>(v.address) * 2;
      len = static_cast<size_t>(v.count) * 2;
    } else if (v.ts == TransportSize::kBit) {
      if (v.count != 1) return 0x07;
      off = v.address / 8;
      bit = static_cast<uint8_t>(v.address % 8);
      len = 1;
    } else {
      if (v.address % 8 != 0) return 0x05;
      off = v.address / 8;
      len = var_data_bytes(v);
    }
    if (len == 0 || off + len > mem->size()) return 0x05;
    return kItemOk;
  }

  void handle_job(uint32_t c, const S7Header& h, int64_t now) {
    Conn& k = conns[c];
    Ep& e = eps[k.ep];
    ++e.st.requests;
    Bytes reply;
    if (h.params.empty()) {
      encode_error_reply(reply, h.pdu_ref, 0x8104);
      schedule(c, std::move(reply), true, now);
      return;
    }
    const uint8_t fn = h.params[0];
    if (fn == kFuncSetup) {
      auto p = parse_setup(h);
      if (!p) {
        encode_error_reply(reply, h.pdu_ref, 0x8404);
      } else {
        SetupParams g;
        g.amq_calling = std::min(p->amq_calling, e.spec.behavior.max_amq);
        g.amq_called = std::min(p->amq_called, e.spec.behavior.max_amq);
        g.pdu_size = std::min(p->pdu_size, e.spec.behavior.max_pdu);
        k.pdu = g.pdu_size;
        encode_ack_header(reply, kRosctrAckData, h.pdu_ref, 8, 0, 0);
        reply.insert(reply.end(), {kFuncSetup, 0, static_cast<uint8_t>(g.amq_calling >> 8),
                                   static_cast<uint8_t>(g.amq_calling & 0xFF), static_cast<uint8_t>(g.amq_called >> 8),
                                   static_cast<uint8_t>(g.amq_called & 0xFF), static_cast<uint8_t>(g.pdu_size >> 8),
                                   static_cast<uint8_t>(g.pdu_size & 0xFF)});
        patch_tpkt_length(reply, 0);
      }
      schedule(c, std::move(reply), false, now);
      return;
    }
    if (fn != kFuncRead && fn != kFuncWrite) {
      encode_error_reply(reply, h.pdu_ref, 0x8104);
      schedule(c, std::move(reply), true, now);
      return;
    }
    auto vars = parse_var_params(h, fn);
    if (!vars || vars->size() > kMaxItemsPerPdu || kS7JobHeader + h.params.size() + h.data.size() > k.pdu) {
      encode_error_reply(reply, h.pdu_ref, vars ? 0x8500 : 0x8404);
      schedule(c, std::move(reply), true, now);
      return;
    }
    if (fn == kFuncRead) {
      std::vector<DataItem> items(vars->size());
      std::vector<Bytes> bufs(vars->size());
      size_t reply_size = read_reply_base();
      for (size_t i = 0; i < vars->size(); ++i) {
        const VarSpec& v = (*vars)[i];
        Bytes* mem = nullptr;
        size_t off = 0, len = 0;
        uint8_t bit = 0;
        DataItem& d = items[i];
        d.return_code = locate(k.ep, v, mem, off, len, bit);
        if (d.return_code == kItemOk) {
          if (v.ts == TransportSize::kBit) {
            bufs[i].push_back(static_cast<uint8_t>(((*mem)[off] >> bit) & 1));
          } else {
            bufs[i].assign(mem->begin() + static_cast<std::ptrdiff_t>(off),
                           mem->begin() + static_cast<std::ptrdiff_t>(off + len));
          }
          d.size = data_size_for(v.ts);
          d.data = bufs[i];
        }
        reply_size += reply_item_size(d.data.size());
      }
      if (reply_size > k.pdu) {
        encode_error_reply(reply, h.pdu_ref, 0x8500);
      } else {
        encode_read_reply(reply, h.pdu_ref, items);
      }
      schedule(c, std::move(reply), true, now);
      return;
    }
    std::vector<DataItem> data;
    std::vector<uint8_t> codes(vars->size(), kItemOk);
    if (!parse_data_items(h.data, vars->size(), false, data)) {
      encode_error_reply(reply, h.pdu_ref, 0x8404);
      schedule(c, std::move(reply), true, now);
      return;
    }
    for (size_t i = 0; i < vars->size(); ++i) {
      const VarSpec& v = (*vars)[i];
      Bytes* mem = nullptr;
      size_t off = 0, len = 0;
      uint8_t bit = 0;
      codes[i] = locate(k.ep, v, mem, off, len, bit);
      if (codes[i] != kItemOk) continue;
      if (data[i].data.size() != len) {
        codes[i] = 0x07;
        continue;
      }
      if (v.ts == TransportSize::kBit) {
        const auto mask = static_cast<uint8_t>(1u << bit);
        (*mem)[off] = static_cast<uint8_t>((data[i].data[0] & 1) ? ((*mem)[off] | mask) : ((*mem)[off] & ~mask));
      } else {
        std::copy(data[i].data.begin(), data[i].data.end(), mem->begin() + static_cast<std::ptrdiff_t>(off));
      }
    }
    encode_write_reply(reply, h.pdu_ref, codes);
    schedule(c, std::move(reply), true, now);
  }

  void handle_frame(uint32_t c, ByteSpan frame, int64_t now) {
    auto t = parse_frame(frame);
    if (!t) {
      close_conn(c);
      return;
    }
    if (t->type == CotpType::kConnectionRequest) {
      Bytes cc{3, 0, 0, 0, 17, 0xD0, static_cast<uint8_t>(t->src_ref >> 8), static_cast<uint8_t>(t->src_ref & 0xFF),
               0x00, 0x01, 0x00, 0xC0, 1, 0x0A, 0xC1, 2,
               static_cast<uint8_t>(t->calling_tsap >> 8), static_cast<uint8_t>(t->calling_tsap & 0xFF), 0xC2, 2,
               static_cast<uint8_t>(t->called_tsap >> 8), static_cast<uint8_t>(t->called_tsap & 0xFF)};
      patch_tpkt_length(cc, 0);
      schedule(c, std::move(cc), false, now);
      return;
    }
    if (t->type != CotpType::kData) {
      close_conn(c);
      return;
    }
    auto h = parse_s7(t->payload);
    if (!h || h->rosctr != kRosctrJob) {
      close_conn(c);
      return;
    }
    handle_job(c, *h, now);
  }

  void readable(uint32_t c, int64_t now) {
    std::array<uint8_t, 8192> buf;
    const ssize_t n = ::recv(conns[c].fd.get(), buf.data(), buf.size(), 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
      close_conn(c);
      return;
    }
    if (n < 0) return;
    Conn& k = conns[c];
    if (k.silent) return;
    k.in.insert(k.in.end(), buf.data(), buf.data() + n);
    size_t pos = 0;
    const uint32_t gen = k.gen;
    while (conns[c].fd.valid() && conns[c].gen == gen) {
      auto len = tpkt_frame_length(ByteSpan(conns[c].in).subspan(pos));
      if (!len) {
        close_conn(c);
        return;
      }
      if (*len == 0) break;
      const Bytes frame(conns[c].in.begin() + static_cast<std::ptrdiff_t>(pos),
                        conns[c].in.begin() + static_cast<std::ptrdiff_t>(pos + *len));
      pos += *len;
      handle_frame(c, frame, now);
    }
    if (conns[c].fd.valid() && conns[c].gen == gen) {
      conns[c].in.erase(conns[c].in.begin(), conns[c].in.begin() + static_cast<std::ptrdiff_t>(pos));
    }
  }

  void run_once(int max_wait_ms) {
    int64_t now = mono_ns();
    int64_t wait_ns = static_cast<int64_t>(max_wait_ms) * 1'000'000;
    {
      std::lock_guard lock(mu);
      if (!delayed.empty()) wait_ns = std::clamp<int64_t>(delayed.top().due - now, 0, wait_ns);
    }
    timespec ts{static_cast<time_t>(wait_ns / 1'000'000'000), static_cast<long>(wait_ns % 1'000'000'000)};
    std::array<epoll_event, 256> events;
    const int n = ::epoll_pwait2(epfd.get(), events.data(), static_cast<int>(events.size()), &ts, nullptr);
    std::lock_guard lock(mu);
    now = mono_ns();
    for (int i = 0; i < n; ++i) {
      const epoll_event& ev = events[static_cast<size_t>(i)];
      const uint64_t key = ev.data.u64;
      if (key == kListenerBit - 1) {
        uint64_t v = 0;
        [[maybe_unused]] const ssize_t r = ::read(wakefd.get(), &v, sizeof v);
        continue;
      }
      if ((key & kListenerBit) != 0) {
        const size_t ep = static_cast<size_t>(key & ~kListenerBit);
        if (ep < eps.size()) accept_all(ep);
        continue;
      }
      const auto c = static_cast<uint32_t>(key & 0xFFFFFFFF);
      if (c >= conns.size() || conns[c].gen != static_cast<uint32_t>(key >> 32) || !conns[c].fd.valid()) continue;
      if ((ev.events & EPOLLOUT) != 0) flush(c);
      if (conns[c].fd.valid() && (ev.events & (EPOLLIN | EPOLLERR | EPOLLHUP)) != 0) readable(c, now);
    }
    now = mono_ns();
    while (!delayed.empty() && delayed.top().due <= now) {
      Delayed d = std::move(const_cast<Delayed&>(delayed.top()));
      delayed.pop();
      deliver(d);
    }
  }

  void wake() {
    const uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(wakefd.get(), &one, sizeof one);
  }
};

FakePlc::FakePlc(uint64_t seed) : impl_(std::make_unique<Impl>(seed)) {}

FakePlc::~FakePlc() { stop(); }

Result<size_t> FakePlc::add_endpoint(const FakeEndpointSpec& spec) {
  std::lock_guard lock(impl_->mu);
  Ep e;
  e.spec = spec;
  impl_->eps.push_back(std::move(e));
  const size_t i = impl_->eps.size() - 1;
  if (auto r = impl_->listen(i); !r) {
    impl_->eps.pop_back();
    return make_error(r.error());
  }
  return i;
}

size_t FakePlc::endpoint_count() const {
  std::lock_guard lock(impl_->mu);
  return impl_->eps.size();
}

uint16_t FakePlc::port(size_t ep) const {
  std::lock_guard lock(impl_->mu);
  return impl_->eps.at(ep).spec.port;
}

std::string FakePlc::address(size_t ep) const {
  std::lock_guard lock(impl_->mu);
  return impl_->eps.at(ep).spec.address;
}

Result<void> FakePlc::start() {
  if (impl_->thread.joinable()) return make_error("fake PLC already running");
  impl_->stop_flag = false;
  impl_->thread = std::thread([this] { run(impl_->stop_flag); });
  return {};
}

void FakePlc::stop() {
  impl_->stop_flag = true;
  impl_->wake();
  if (impl_->thread.joinable()) impl_->thread.join();
}

void FakePlc::run(const std::atomic<bool>& stop_flag) {
  while (!stop_flag.load(std::memory_order_relaxed)) impl_->run_once(50);
}

void FakePlc::set_behavior(size_t ep, const FakeBehavior& b) {
  std::lock_guard lock(impl_->mu);
  Ep& e = impl_->eps.at(ep);
  const bool relisten = (e.spec.behavior.blackhole == FakeBehavior::Blackhole::kNeverAccept) !=
                        (b.blackhole == FakeBehavior::Blackhole::kNeverAccept);
  e.spec.behavior = b;
  for (uint32_t c : e.conns) impl_->conns[c].silent = b.blackhole == FakeBehavior::Blackhole::kAcceptSilent;
  if (relisten && e.listener.valid()) {
    e.listener.reset();
    e.filler.reset();
    impl_->close_all(ep);
    (void)impl_->listen(ep);
  }
}

void FakePlc::kill(size_t ep) {
  std::lock_guard lock(impl_->mu);
  Ep& e = impl_->eps.at(ep);
  e.listener.reset();
  e.filler.reset();
  impl_->close_all(ep);
}

void FakePlc::restart(size_t ep) {
  std::lock_guard lock(impl_->mu);
  Ep& e = impl_->eps.at(ep);
  if (e.listener.valid()) return;
  (void)impl_->listen(ep);
}

void FakePlc::drop_connections(size_t ep) {
  std::lock_guard lock(impl_->mu);
  impl_->close_all(ep);
}

FakeStats FakePlc::stats(size_t ep) const {
  std::lock_guard lock(impl_->mu);
  return impl_->eps.at(ep).st;
}

size_t FakePlc::connections(size_t ep) const {
  std::lock_guard lock(impl_->mu);
  return impl_->eps.at(ep).conns.size();
}

void FakePlc::write_memory(size_t ep, Area area, uint16_t db, uint32_t offset, ByteSpan bytes) {
  std::lock_guard lock(impl_->mu);
  Bytes* r = impl_->region(ep, area, db, true);
  const size_t at = (area == Area::kCounters || area == Area::kTimers) ? size_t{offset} * 2 : offset;
  if (r == nullptr || at + bytes.size() > r->size()) return;
  std::copy(bytes.begin(), bytes.end(), r->begin() + static_cast<std::ptrdiff_t>(at));
}

Bytes FakePlc::read_memory(size_t ep, Area area, uint16_t db, uint32_t offset, size_t len) const {
  std::lock_guard lock(impl_->mu);
  Bytes* r = impl_->region(ep, area, db, true);
  const size_t at = (area == Area::kCounters || area == Area::kTimers) ? size_t{offset} * 2 : offset;
  if (r == nullptr || at + len > r->size()) return {};
  return Bytes(r->begin() + static_cast<std::ptrdiff_t>(at), r->begin() + static_cast<std::ptrdiff_t>(at + len));
}

}  // namespace rtplc::s7
