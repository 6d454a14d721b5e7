// Tests of CLOCK_MONOTONIC arithmetic and the absolute sleep (kernel_rt/clock.h).
#include "kernel_rt/clock.h"

#include <gtest/gtest.h>
#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <limits>
#include <thread>

namespace rtplc::kernel_rt {
namespace {

constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
constexpr int64_t kMin = std::numeric_limits<int64_t>::min();

timespec ts(time_t s, long ns) {
  timespec t{};
  t.tv_sec = s;
  t.tv_nsec = ns;
  return t;
}

TEST(Clock, saturating_ops_clamp_instead_of_wrapping) {
  EXPECT_EQ(saturating_add(kMax, 1), kMax);
  EXPECT_EQ(saturating_add(kMin, -1), kMin);
  EXPECT_EQ(saturating_add(40, 2), 42);
  EXPECT_EQ(saturating_sub(kMin, 1), kMin);
  EXPECT_EQ(saturating_sub(kMax, -1), kMax);
  EXPECT_EQ(saturating_sub(0, kMin), kMax);
  EXPECT_EQ(saturating_mul(kMax / 2, 3), kMax);
  EXPECT_EQ(saturating_mul(kMax / 2, -3), kMin);
  EXPECT_EQ(saturating_mul(-7, 6), -42);
}

TEST(Clock, ns_round_trip_keeps_nsec_in_range_for_negative_values) {
  for (int64_t v : {int64_t{0}, int64_t{1}, int64_t{-1}, kNsPerSec, -kNsPerSec,
                    int64_t{-1'500'000'001}, int64_t{123'456'789'012}}) {
    const timespec t = from_ns(v);
    EXPECT_GE(t.tv_nsec, 0) << v;
    EXPECT_LT(t.tv_nsec, kNsPerSec) << v;
    EXPECT_EQ(to_ns(t), v);
  }
  const timespec minus_one = from_ns(-1);
  EXPECT_EQ(minus_one.tv_sec, -1);
  EXPECT_EQ(minus_one.tv_nsec, 999'999'999);
}

TEST(Clock, to_ns_saturates_far_future) {
  EXPECT_EQ(to_ns(ts(std::numeric_limits<time_t>::max(), 0)), kMax);
  EXPECT_EQ(to_ns(ts(std::numeric_limits<time_t>::min(), 0)), kMin);
}

TEST(Clock, normalize_carries_both_ways) {
  const timespec a = normalize(ts(1, 2'500'000'000));
  EXPECT_EQ(a.tv_sec, 3);
  EXPECT_EQ(a.tv_nsec, 500'000'000);
  const timespec b = normalize(ts(5, -1));
  EXPECT_EQ(b.tv_sec, 4);
  EXPECT_EQ(b.tv_nsec, 999'999'999);
}

TEST(Clock, add_ns_carries_into_seconds) {
  const timespec a = add_ns(ts(10, 999'999'999), 1);
  EXPECT_EQ(a.tv_sec, 11);
  EXPECT_EQ(a.tv_nsec, 0);
  const timespec b = add_ns(ts(10, 0), -1);
  EXPECT_EQ(b.tv_sec, 9);
  EXPECT_EQ(b.tv_nsec, 999'999'999);
  const timespec c = add_ns(ts(0, 0), 3 * kNsPerSec + 7);
  EXPECT_EQ(c.tv_sec, 3);
  EXPECT_EQ(c.tv_nsec, 7);
}

TEST(Clock, add_ns_one_period_at_a_time_equals_one_big_add) {
  // release += period, a million times, must not drift from release + n * period.
  const int64_t period = 333'333;  // does not divide a second
  timespec release = ts(100, 123);
  for (int i = 0; i < 1'000'000; ++i) release = add_ns(release, period);
  const timespec direct = add_ns(ts(100, 123), saturating_mul(period, 1'000'000));
  EXPECT_EQ(compare(release, direct), 0);
}

TEST(Clock, add_ns_saturates_at_the_far_end) {
  const timespec far = add_ns(ts(std::numeric_limits<time_t>::max() - 1, 0), kMax);
  EXPECT_EQ(far.tv_sec, std::numeric_limits<time_t>::max());
  EXPECT_LT(far.tv_nsec, kNsPerSec);
  EXPECT_GE(compare(far, ts(1'000'000, 0)), 1);
}

TEST(Clock, diff_ns_is_signed_and_saturates) {
  EXPECT_EQ(diff_ns(ts(2, 0), ts(1, 999'999'999)), 1);
  EXPECT_EQ(diff_ns(ts(1, 999'999'999), ts(2, 0)), -1);
  EXPECT_EQ(diff_ns(ts(std::numeric_limits<time_t>::max(), 0), ts(0, 0)), kMax);
  EXPECT_EQ(diff_ns(ts(std::numeric_limits<time_t>::min(), 0), ts(1, 0)), kMin);
}

TEST(Clock, compare_orders_non_normalised_input) {
  EXPECT_EQ(compare(ts(1, 1'000'000'000), ts(2, 0)), 0);
  EXPECT_EQ(compare(ts(1, 0), ts(1, 1)), -1);
  EXPECT_EQ(compare(ts(3, 0), ts(2, 999'999'999)), 1);
}

TEST(Clock, monotonic_now_never_goes_back) {
  int64_t prev = monotonic_now_ns();
  for (int i = 0; i < 10'000; ++i) {
    const int64_t now = monotonic_now_ns();
    ASSERT_GE(now, prev);
    prev = now;
  }
}

TEST(Clock, sleep_until_returns_at_or_after_the_deadline) {
  for (int i = 0; i < 50; ++i) {
    const timespec deadline = add_ns(monotonic_now(), 200 * kNsPerUs);
    ASSERT_EQ(sleep_until(deadline), SleepStatus::kReached);
    EXPECT_GE(compare(monotonic_now(), deadline), 0);
  }
}

TEST(Clock, sleep_until_ns_in_the_past_returns_at_once) {
  EXPECT_EQ(sleep_until_ns(monotonic_now_ns() - kNsPerSec), SleepStatus::kReached);
  EXPECT_EQ(sleep_until(ts(-5, 0)), SleepStatus::kReached);
}

std::atomic<int> g_signals{0};
void count_signal(int) {
  g_signals.fetch_add(1);
}

TEST(Clock, sleep_until_survives_signals_without_waking_early) {
  struct sigaction sa {};
  sa.sa_handler = count_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: clock_nanosleep really sees EINTR
  struct sigaction old {};
  ASSERT_EQ(sigaction(SIGUSR1, &sa, &old), 0);
  g_signals = 0;

  const pthread_t sleeper = pthread_self();
  std::atomic<bool> done{false};
  std::thread pester([&] {
    while (!done.load()) {
      pthread_kill(sleeper, SIGUSR1);
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  });
  const timespec deadline = add_ns(monotonic_now(), 100 * kNsPerMs);
  const SleepStatus st = sleep_until(deadline);
  const timespec woke = monotonic_now();
  done = true;
  pester.join();
  sigaction(SIGUSR1, &old, nullptr);

  EXPECT_EQ(st, SleepStatus::kReached);
  EXPECT_GE(compare(woke, deadline), 0);
  EXPECT_GT(g_signals.load(), 0) << "the test never interrupted the sleep";
}

}  // namespace
}  // namespace rtplc::kernel_rt
