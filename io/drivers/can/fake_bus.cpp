// The in-process CAN bus of host tests (see fake_bus.h).
#include "io/drivers/can/fake_bus.h"

#include <algorithm>
#include <cerrno>
#include <chrono>

namespace rtplc::can {
namespace {

bool takes(const std::vector<IdFilter>& filters, const Frame& f) {
  return std::any_of(filters.begin(), filters.end(),
                     [&](const IdFilter& x) { return ((x.id ^ f.id) & x.mask) == 0 && x.extended == f.extended; });
}

}  // namespace

Result<void*> FakeBus::open_port(void* context, const std::string& iface, std::span<const IdFilter> filters,
                                 bool error_frames) {
  auto* bus = static_cast<FakeBus*>(context);
  if (iface == "missing") return make_error("CAN interface 'missing' does not exist");
  auto* p = new FakePort;
  p->bus = bus;
  p->filters.assign(filters.begin(), filters.end());
  p->error_frames = error_frames;
  std::lock_guard lock(bus->mu_);
  bus->ports_.push_back(p);
  bus->last_filters_ = p->filters;
  return static_cast<void*>(p);
}

int FakeBus::send_port(void* port, const Frame& f) {
  auto* p = static_cast<FakePort*>(port);
  FakeBus* bus = p->bus;
  {
    std::lock_guard lock(bus->mu_);
    if (bus->refuse_) return ENETDOWN;
    bus->sent_.push_back(f);
  }
  bus->deliver(f, p);
  return 0;
}

RecvResult FakeBus::recv_port(void* port, Frame& f, int64_t timeout_ns, int*) {
  auto* p = static_cast<FakePort*>(port);
  FakeBus* bus = p->bus;
  std::unique_lock lock(bus->mu_);
  if (!bus->cv_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [&] { return !p->rx.empty(); })) {
    return RecvResult::kTimeout;
  }
  f = p->rx.front();
  p->rx.pop_front();
  return RecvResult::kFrame;
}

void FakeBus::close_port(void* port) {
  auto* p = static_cast<FakePort*>(port);
  FakeBus* bus = p->bus;
  {
    std::lock_guard lock(bus->mu_);
    bus->ports_.erase(std::remove(bus->ports_.begin(), bus->ports_.end(), p), bus->ports_.end());
  }
  delete p;
}

void FakeBus::deliver(const Frame& f, const FakePort* from) {
  {
    std::lock_guard lock(mu_);
    for (FakePort* p : ports_) {
      if (p == from) continue;
      if (!(f.error ? p->error_frames : takes(p->filters, f))) continue;
      if (rx_limit_ != 0 && p->rx.size() >= rx_limit_) {
        ++rx_dropped_;
        continue;
      }
      p->rx.push_back(f);
    }
  }
  cv_.notify_all();
}

void FakeBus::inject(const Frame& f) {
  deliver(f, nullptr);
}

void FakeBus::inject_error(uint32_t error_class, uint8_t ctrl) {
  Frame f;
  f.error = true;
  f.id = error_class;
  f.len = 8;
  f.data[1] = ctrl;
  deliver(f, nullptr);
}

void FakeBus::refuse_sends(bool on) {
  std::lock_guard lock(mu_);
  refuse_ = on;
}

void FakeBus::limit_rx(size_t frames) {
  std::lock_guard lock(mu_);
  rx_limit_ = frames;
}

uint64_t FakeBus::rx_dropped() const {
  std::lock_guard lock(mu_);
  return rx_dropped_;
}

std::vector<Frame> FakeBus::sent() const {
  std::lock_guard lock(mu_);
  return sent_;
}

size_t FakeBus::sent_count() const {
  std::lock_guard lock(mu_);
  return sent_.size();
}

void FakeBus::clear_sent() {
  std::lock_guard lock(mu_);
  sent_.clear();
}

int FakeBus::ports_open() const {
  std::lock_guard lock(mu_);
  return static_cast<int>(ports_.size());
}

std::vector<IdFilter> FakeBus::last_filters() const {
  std::lock_guard lock(mu_);
  return last_filters_;
}

}  // namespace rtplc::can
