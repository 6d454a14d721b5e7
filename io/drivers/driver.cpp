// The bridge thread every driver shares, the event queue and the kind registry
// (see driver.h).
#include "io/drivers/driver.h"

#include <algorithm>
#include <cstring>

#include <cmath>

#include <algorithm>
#include <vector>

#include "common/registry.h"
#include "common/text.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/cycle_scope.h"
#include "kernel_rt/periodic.h"

namespace rtplc::io {

void LinkEventQueue::push(LinkEvent::Level level, std::string_view driver, std::string_view text) noexcept {
  LinkEvent e;
  e.level = level;
  copy_text(e.driver, sizeof e.driver, driver);
  copy_text(e.text, sizeof e.text, text);
  if (!queue_.push(e)) dropped_.fetch_add(1, std::memory_order_relaxed);
}

Driver::Driver(DriverSetup setup, const char* thread_tag) : setup_(std::move(setup)), tag_(thread_tag) {}

Driver::~Driver() {
  request_stop();
  join();
}

Result<void> Driver::start(int64_t first_release_ns) {
  first_release_ = first_release_ns;
  if (auto r = on_start(); !r) return make_error("driver " + name() + ": " + r.error());
  started_ = true;
  // The channels exist before the first cycle (plants at rest, links not up yet).
  cycle(kernel_rt::monotonic_now_ns());
  auto t = kernel_rt::start_driver_thread(name(), tag_, setup_.priority, setup_.cpu, [this] { run(); });
  if (!t) {
    on_joined();
    started_ = false;
    return make_error(t.error());
  }
  thread_ = std::move(t).value();
  return {};
}

void Driver::join() {
  if (thread_.joinable()) thread_.join();
  if (started_) {
    started_ = false;
    on_joined();
  }
}

void Driver::run() noexcept {
  int64_t release = first_release_;
  while (!stop_.load(std::memory_order_relaxed)) {
    kernel_rt::sleep_until_ns(release);
    const int64_t now = kernel_rt::monotonic_now_ns();
    cycle_now(now);
    cycles_.fetch_add(1, std::memory_order_relaxed);
    release = kernel_rt::next_release(release, setup_.period_ns, now);
  }
  on_stop();
}

void Driver::cycle_now(int64_t now_ns) noexcept {
  const kernel_rt::CycleScope no_allocation;
  cycle(now_ns);
}

bool Driver::read_output(uint32_t j, double& value, Quality& quality, int64_t now_ns) const noexcept {
  const OutputSource& src = setup_.consumes[j];
  double v = 0;
  Quality q = Quality::kBad;
  int64_t t = 0;
  if (!setup_.image->read_values(src.region, &src.index, 1, &v, 8, nullptr, &q, &t)) return false;
  value = v;
  quality = judge_quality(q, v, t, now_ns, src.max_age_ns);
  return true;
}

SendDecision Driver::output_to_send(uint32_t j, double& value, int64_t now_ns) const noexcept {
  Quality q = Quality::kBad;
  if (!read_output(j, value, q, now_ns)) return SendDecision::kNoRead;
  if (q == Quality::kGood || q == Quality::kForced) return SendDecision::kSend;
  const OutputSource& src = setup_.consumes[j];
  switch (src.on_bad) {
    case config::OnBad::kSafe:
      value = src.safe_value;
      return SendDecision::kSend;
    case config::OnBad::kSend:  // the engineer chose the computed value whatever its status
      return std::isfinite(value) ? SendDecision::kSend : SendDecision::kHold;
    case config::OnBad::kHold:
      break;
  }
  return SendDecision::kHold;
}

void Driver::describe_link(uint32_t l, std::string_view link_name, std::string_view peer) const {
  LinkStatus& ls = link_row(l);
  copy_text(ls.name, sizeof ls.name, link_name);
  copy_text(ls.driver, sizeof ls.driver, name());
  copy_text(ls.kind, sizeof ls.kind, kind());
  copy_text(ls.peer, sizeof ls.peer, peer);
  ls.state.store(static_cast<uint8_t>(LinkState::kDown), std::memory_order_relaxed);
  ls.quality.store(static_cast<uint8_t>(Quality::kBad), std::memory_order_relaxed);
}

void Driver::name_gauge(uint32_t l, uint32_t g, std::string_view gauge_name) const {
  if (g < kLinkGauges) copy_text(link_row(l).gauge_names[g], sizeof link_row(l).gauge_names[g], gauge_name);
}

void Driver::set_link_error(uint32_t l, std::string_view text) const noexcept {
  LinkError e{};
  const size_t n = std::min(text.size(), sizeof e.text - 1);
  std::memcpy(e.text, text.data(), n);
  e.at_ns = kernel_rt::monotonic_now_ns();
  link_row(l).last_error.store(e);
}

void Driver::log(LinkEvent::Level level, std::string_view text) const noexcept {
  if (setup_.events != nullptr) setup_.events->push(level, name(), text);
}

namespace {
const char* kind_name(const DriverKind& k) { return k.config->kind; }
using KindTable = Registry<DriverKind>;
}  // namespace

void register_driver_kind(const DriverKind* kind) {
  KindTable::add(kind, kind_name);
  config::register_driver_kind(kind->config);
}

std::span<const DriverKind* const> driver_kinds() { return KindTable::all(); }

const DriverKind* find_driver_kind(std::string_view kind) { return KindTable::find(kind, kind_name); }

}  // namespace rtplc::io
