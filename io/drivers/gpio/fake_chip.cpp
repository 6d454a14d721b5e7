// The in-process GPIO chips of the host tests (fake_chip.h).
#include "io/drivers/gpio/fake_chip.h"

#include <fmt/format.h>

#include <cerrno>
#include <chrono>
#include <stdexcept>

namespace rtplc::gpio {

struct FakeChips::Line {
  Chip* chip = nullptr;
  unsigned offset = 0;
  std::string name;
  int physical = 0;
  bool requested = false;
  LineRequest req;
  std::string consumer;
  std::deque<EdgeEvent> events;
};

struct FakeChips::Chip {
  std::string name, label;
  std::vector<Line> lines;
  FakeChips* owner = nullptr;
};

struct FakeOps {
  static FakeChips* of(void* chip) { return static_cast<FakeChips::Chip*>(chip)->owner; }
  static FakeChips::Line* line(void* l) { return static_cast<FakeChips::Line*>(l); }

  static Result<void*> open(void* context, const std::string& name) {
    auto* self = static_cast<FakeChips*>(context);
    std::lock_guard lock(self->mu_);
    for (auto& [n, c] : self->chips_) {
      if (name == n || name == "/dev/" + n || name == c->label) return static_cast<void*>(c.get());
    }
    return make_error(fmt::format("GPIO chip '{}' cannot be opened: no such chip", name));
  }
  static void close(void*) {}
  static ChipInfo chip_info(void* chip) {
    auto* c = static_cast<FakeChips::Chip*>(chip);
    return {c->name, c->label, static_cast<unsigned>(c->lines.size())};
  }
  static LineInfo line_info(void* chip, unsigned offset) {
    auto* c = static_cast<FakeChips::Chip*>(chip);
    std::lock_guard lock(of(chip)->mu_);
    LineInfo i;
    i.offset = offset;
    if (offset >= c->lines.size()) return i;
    const FakeChips::Line& l = c->lines[offset];
    i.name = l.name;
    i.used = l.requested;
    i.consumer = l.consumer;
    i.output = l.requested && l.req.output;
    i.active_low = l.requested && l.req.active_low;
    return i;
  }
  static int find(void* chip, const std::string& name) {
    auto* c = static_cast<FakeChips::Chip*>(chip);
    for (const FakeChips::Line& l : c->lines) {
      if (!name.empty() && l.name == name) return static_cast<int>(l.offset);
    }
    return -1;
  }
  static Result<void*> request(void* chip, const LineRequest& req, const char* consumer) {
    auto* c = static_cast<FakeChips::Chip*>(chip);
    std::lock_guard lock(of(chip)->mu_);
    if (req.offset >= c->lines.size()) {
      return make_error(fmt::format("line {} does not exist on {} ({} lines)", req.offset, c->name, c->lines.size()));
    }
    FakeChips::Line& l = c->lines[req.offset];
    if (l.requested) {
      return make_error(fmt::format("line {} of {} cannot be requested: Device or resource busy (used by '{}')",
                                    req.offset, c->name, l.consumer));
    }
    l.requested = true;
    l.req = req;
    l.consumer = consumer;
    l.events.clear();
    if (req.output) l.physical = req.active_low ? !req.initial : req.initial != 0;
    return static_cast<void*>(&l);
  }
  static void release(void* p) {
    FakeChips::Line* l = line(p);
    std::lock_guard lock(l->chip->owner->mu_);
    l->requested = false;
    l->consumer.clear();
    l->events.clear();
  }
  static int get(void* p) {
    FakeChips::Line* l = line(p);
    std::lock_guard lock(l->chip->owner->mu_);
    if (l->chip->owner->fail_ != 0) return -l->chip->owner->fail_;
    return l->req.active_low ? !l->physical : l->physical;
  }
  static int set(void* p, int v) {
    FakeChips::Line* l = line(p);
    std::lock_guard lock(l->chip->owner->mu_);
    FakeChips* self = l->chip->owner;
    if (self->fail_ != 0) return self->fail_;
    if (!l->req.output) return EPERM;
    ++self->sets_;
    l->physical = l->req.active_low ? v == 0 : v != 0;
    return 0;
  }
  static int wait(std::span<void* const> lines, int64_t timeout_ns, bool* ready) {
    if (lines.empty()) return 0;
    FakeChips* self = line(lines[0])->chip->owner;
    std::unique_lock lock(self->mu_);
    auto count = [&] {
      int n = 0;
      for (size_t i = 0; i < lines.size(); ++i) {
        ready[i] = !line(lines[i])->events.empty();
        n += ready[i];
      }
      return n;
    };
    self->cv_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [&] { return count() > 0; });
    return count();
  }
  static int read_events(void* p, EdgeEvent* out, unsigned max) {
    FakeChips::Line* l = line(p);
    std::lock_guard lock(l->chip->owner->mu_);
    if (l->events.empty()) return -EAGAIN;
    int n = 0;
    for (; static_cast<unsigned>(n) < max && !l->events.empty(); ++n) {
      out[n] = l->events.front();
      l->events.pop_front();
    }
    return n;
  }
};

FakeChips::FakeChips()
    : ops_{"fake", this, &FakeOps::open, &FakeOps::close, &FakeOps::chip_info, &FakeOps::line_info,
           &FakeOps::find, &FakeOps::request, &FakeOps::release, &FakeOps::get, &FakeOps::set,
           &FakeOps::wait, &FakeOps::read_events} {}

FakeChips::~FakeChips() = default;

void FakeChips::add_chip(const std::string& name, const std::string& label, unsigned lines,
                         std::vector<std::string> names) {
  std::lock_guard lock(mu_);
  auto c = std::make_unique<Chip>();
  c->name = name;
  c->label = label;
  c->owner = this;
  c->lines.resize(lines);
  for (unsigned i = 0; i < lines; ++i) {
    c->lines[i].chip = c.get();
    c->lines[i].offset = i;
    if (i < names.size()) c->lines[i].name = names[i];
  }
  chips_[name] = std::move(c);
}

FakeChips::Line& FakeChips::line(const std::string& chip, unsigned offset) const {
  auto it = chips_.find(chip);
  if (it == chips_.end() || offset >= it->second->lines.size()) throw std::out_of_range("no such fake line");
  return it->second->lines[offset];
}

void FakeChips::pull(const std::string& chip, unsigned offset, int level, int64_t ts_ns) {
  {
    std::lock_guard lock(mu_);
    Line& l = line(chip, offset);
    if (l.requested && l.req.output) return;  // an output drives itself
    const int before = l.physical;
    l.physical = level != 0;
    if (!l.requested || before == l.physical) return;
    const bool rising = (l.physical != 0) != l.req.active_low;  // logical edge
    const Edge e = l.req.edge;
    if (e == Edge::kBoth || (e == Edge::kRising && rising) || (e == Edge::kFalling && !rising)) {
      if (event_limit_ != 0 && l.events.size() >= event_limit_) {
        ++events_dropped_;
        return;
      }
      l.events.push_back({rising, ts_ns});
    }
  }
  cv_.notify_all();
}

int FakeChips::level(const std::string& chip, unsigned offset) const {
  std::lock_guard lock(mu_);
  return line(chip, offset).physical;
}

bool FakeChips::requested(const std::string& chip, unsigned offset) const {
  std::lock_guard lock(mu_);
  return line(chip, offset).requested;
}

uint64_t FakeChips::sets() const {
  std::lock_guard lock(mu_);
  return sets_;
}

void FakeChips::fail_io(int err) {
  std::lock_guard lock(mu_);
  fail_ = err;
}

void FakeChips::limit_events(size_t events) {
  std::lock_guard lock(mu_);
  event_limit_ = events;
}

uint64_t FakeChips::events_dropped() const {
  std::lock_guard lock(mu_);
  return events_dropped_;
}

}  // namespace rtplc::gpio
