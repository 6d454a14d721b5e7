// CLOCK_MONOTONIC arithmetic and the absolute-deadline sleep every RT task cycle ends with
// (spec: runtime.md, "Tasks and the scheduler": clock_nanosleep TIMER_ABSTIME, release += period).
//
// Everything here is safe on the RT path: no allocation, no exception, no lock, and the only
// system calls are clock_gettime (vDSO, usually no kernel entry) and clock_nanosleep.
// Nanosecond arithmetic saturates instead of wrapping, so a corrupt or extreme period can
// make a deadline "far away" but never negative or in the past by accident.
#pragma once

#include <cstdint>
#include <ctime>

namespace rtplc::kernel_rt {

inline constexpr int64_t kNsPerUs = 1'000;
inline constexpr int64_t kNsPerMs = 1'000'000;
inline constexpr int64_t kNsPerSec = 1'000'000'000;

// a + b, clamped to [INT64_MIN, INT64_MAX] instead of wrapping.
int64_t saturating_add(int64_t a, int64_t b) noexcept;
// a - b, clamped likewise.
int64_t saturating_sub(int64_t a, int64_t b) noexcept;
// a * b, clamped likewise (period * skipped releases, for example).
int64_t saturating_mul(int64_t a, int64_t b) noexcept;

// A timespec as nanoseconds since the clock's epoch. Saturates: a timespec beyond ~292 years
// maps to INT64_MAX. Accepts non-normalised input (tv_nsec outside [0, 1e9)).
int64_t to_ns(const timespec& ts) noexcept;
// Nanoseconds to a normalised timespec (0 <= tv_nsec < 1e9, also for negative values).
timespec from_ns(int64_t ns) noexcept;
// Brings tv_nsec into [0, 1e9), carrying into tv_sec.
timespec normalize(timespec ts) noexcept;
// ts + ns, normalised, saturating at the representable range.
timespec add_ns(const timespec& ts, int64_t ns) noexcept;
// a - b in nanoseconds, saturating.
int64_t diff_ns(const timespec& a, const timespec& b) noexcept;
// -1, 0, 1 like strcmp, on normalised values.
int compare(const timespec& a, const timespec& b) noexcept;

// CLOCK_MONOTONIC now.
timespec monotonic_now() noexcept;
int64_t monotonic_now_ns() noexcept;
// CLOCK_REALTIME now, in ns since 1970: wall-clock instants for people (logs,
// records, "died at"); never for timing, which is CLOCK_MONOTONIC.
int64_t realtime_now_ns() noexcept;

enum class SleepStatus : uint8_t {
  kReached,          // the clock has passed the deadline (or it was already in the past)
  kInvalidDeadline,  // the kernel refused the timespec (EINVAL): a bug in the caller
};

// Sleeps until CLOCK_MONOTONIC >= deadline. A signal does not shorten the sleep: with an
// absolute deadline, restarting after EINTR simply resumes waiting for the same instant,
// which a relative sleep could not do without drift.
SleepStatus sleep_until(const timespec& deadline) noexcept;
SleepStatus sleep_until_ns(int64_t deadline_ns) noexcept;

}  // namespace rtplc::kernel_rt
