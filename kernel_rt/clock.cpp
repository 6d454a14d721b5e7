// CLOCK_MONOTONIC arithmetic and absolute sleeps (spec: runtime.md, "Tasks and the scheduler").
#include "kernel_rt/clock.h"

#include <cerrno>
#include <limits>

namespace rtplc::kernel_rt {
namespace {

constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
constexpr int64_t kMin = std::numeric_limits<int64_t>::min();

// Floor division and modulo: the C operators truncate towards zero, which would give a
// negative tv_nsec for times before the epoch.
constexpr int64_t floor_div(int64_t a, int64_t b) {
  int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}
constexpr int64_t floor_mod(int64_t a, int64_t b) {
  return a - floor_div(a, b) * b;
}

}  // namespace

int64_t saturating_add(int64_t a, int64_t b) noexcept {
  int64_t r = 0;
  if (__builtin_add_overflow(a, b, &r)) return b > 0 ? kMax : kMin;
  return r;
}

int64_t saturating_sub(int64_t a, int64_t b) noexcept {
  int64_t r = 0;
  if (__builtin_sub_overflow(a, b, &r)) return b < 0 ? kMax : kMin;
  return r;
}

int64_t saturating_mul(int64_t a, int64_t b) noexcept {
  int64_t r = 0;
  if (__builtin_mul_overflow(a, b, &r)) return ((a < 0) != (b < 0)) ? kMin : kMax;
  return r;
}

int64_t to_ns(const timespec& ts) noexcept {
  return saturating_add(saturating_mul(static_cast<int64_t>(ts.tv_sec), kNsPerSec),
                        static_cast<int64_t>(ts.tv_nsec));
}

timespec from_ns(int64_t ns) noexcept {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(floor_div(ns, kNsPerSec));
  ts.tv_nsec = static_cast<long>(floor_mod(ns, kNsPerSec));
  return ts;
}

timespec normalize(timespec ts) noexcept {
  const int64_t nsec = static_cast<int64_t>(ts.tv_nsec);
  const int64_t carry = floor_div(nsec, kNsPerSec);
  ts.tv_sec = static_cast<time_t>(saturating_add(static_cast<int64_t>(ts.tv_sec), carry));
  ts.tv_nsec = static_cast<long>(floor_mod(nsec, kNsPerSec));
  return ts;
}

timespec add_ns(const timespec& ts, int64_t ns) noexcept {
  // Split ns so that no intermediate exceeds the range: seconds and sub-second part are
  // added separately, then the sub-second carry is folded in.
  const timespec base = normalize(ts);
  const int64_t sec = saturating_add(static_cast<int64_t>(base.tv_sec), floor_div(ns, kNsPerSec));
  const int64_t nsec = static_cast<int64_t>(base.tv_nsec) + floor_mod(ns, kNsPerSec);  // < 2e9
  timespec out{};
  out.tv_sec = static_cast<time_t>(sec);
  out.tv_nsec = static_cast<long>(nsec);
  if (sec == kMax) {
    out.tv_nsec = static_cast<long>(kNsPerSec - 1);  // pinned at the far end
    return out;
  }
  return normalize(out);
}

int64_t diff_ns(const timespec& a, const timespec& b) noexcept {
  const timespec na = normalize(a);
  const timespec nb = normalize(b);
  const int64_t dsec =
      saturating_sub(static_cast<int64_t>(na.tv_sec), static_cast<int64_t>(nb.tv_sec));
  const int64_t dnsec = static_cast<int64_t>(na.tv_nsec) - static_cast<int64_t>(nb.tv_nsec);
  return saturating_add(saturating_mul(dsec, kNsPerSec), dnsec);
}

int compare(const timespec& a, const timespec& b) noexcept {
  const timespec na = normalize(a);
  const timespec nb = normalize(b);
  if (na.tv_sec != nb.tv_sec) return na.tv_sec < nb.tv_sec ? -1 : 1;
  if (na.tv_nsec != nb.tv_nsec) return na.tv_nsec < nb.tv_nsec ? -1 : 1;
  return 0;
}

timespec monotonic_now() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts;
}

int64_t monotonic_now_ns() noexcept {
  return to_ns(monotonic_now());
}

int64_t realtime_now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return to_ns(ts);
}

SleepStatus sleep_until(const timespec& deadline) noexcept {
  const timespec target = normalize(deadline);
  if (target.tv_sec < 0) return SleepStatus::kReached;  // before boot: nothing to wait for
  for (;;) {
    // clock_nanosleep returns the error number instead of setting errno.
    const int rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &target, nullptr);
    if (rc == 0) return SleepStatus::kReached;
    if (rc != EINTR) return SleepStatus::kInvalidDeadline;
  }
}

SleepStatus sleep_until_ns(int64_t deadline_ns) noexcept {
  return sleep_until(from_ns(deadline_ns));
}

}  // namespace rtplc::kernel_rt
