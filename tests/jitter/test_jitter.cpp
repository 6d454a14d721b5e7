// Tests of the jitter monitor's data structures (spec: runtime.md, "Jitter monitor"): the
// log-linear bucket math at its edges, CycleStats bookkeeping (min/avg/max, overrun runs,
// the ring), and percentiles against a sorted reference within the documented 1/16.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <random>
#include <vector>

#include "sched/jitter.h"

namespace rtplc::sched {
namespace {

using H = LatencyHistogram;

// --- bucket math --------------------------------------------------------------------------

static_assert(H::bucket_of(0) == 0 && H::bucket_of(31) == 31, "usable in constant expressions");
static_assert(H::kBuckets == 960);

TEST(LatencyHistogram, small_values_have_exact_buckets) {
  for (int64_t v = 0; v < 32; ++v) {
    EXPECT_EQ(H::bucket_of(v), static_cast<uint32_t>(v)) << v;
    EXPECT_EQ(H::bucket_lower(static_cast<uint32_t>(v)), v);
    EXPECT_EQ(H::bucket_upper(static_cast<uint32_t>(v)), v);
  }
  // 32..63 have width 2.
  EXPECT_EQ(H::bucket_of(32), 32u);
  EXPECT_EQ(H::bucket_of(33), 32u);
  EXPECT_EQ(H::bucket_of(34), 33u);
  EXPECT_EQ(H::bucket_upper(32), 33);
}

TEST(LatencyHistogram, negative_values_clamp_to_bucket_zero) {
  EXPECT_EQ(H::bucket_of(-1), 0u);
  EXPECT_EQ(H::bucket_of(-1'000'000), 0u);
  EXPECT_EQ(H::bucket_of(std::numeric_limits<int64_t>::min()), 0u);
}

TEST(LatencyHistogram, powers_of_two_start_a_group) {
  for (int k = 4; k < 63; ++k) {
    const int64_t p = int64_t{1} << k;
    const uint32_t b = H::bucket_of(p);
    EXPECT_EQ(b, static_cast<uint32_t>(16 * (k - 3))) << "2^" << k;
    EXPECT_EQ(H::bucket_lower(b), p) << "2^" << k;
    EXPECT_EQ(H::bucket_of(p - 1), b - 1) << "2^" << k << " - 1";
    EXPECT_EQ(H::bucket_upper(b - 1), p - 1) << "2^" << k;
  }
}

TEST(LatencyHistogram, huge_values_land_in_the_last_bucket_which_ends_at_int64_max) {
  constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
  EXPECT_EQ(H::bucket_of(kMax), H::kBuckets - 1);
  EXPECT_EQ(H::bucket_upper(H::kBuckets - 1), kMax);
  // 100 s and an hour are still inside the range, in their own buckets.
  const int64_t hundred_s = 100'000'000'000;
  EXPECT_LT(H::bucket_of(hundred_s), H::kBuckets - 1);
  EXPECT_LE(H::bucket_lower(H::bucket_of(hundred_s)), hundred_s);
  EXPECT_GE(H::bucket_upper(H::bucket_of(hundred_s)), hundred_s);
}

TEST(LatencyHistogram, buckets_tile_the_range_and_are_at_most_a_sixteenth_wide) {
  for (uint32_t b = 0; b < H::kBuckets; ++b) {
    const int64_t lo = H::bucket_lower(b);
    const int64_t hi = H::bucket_upper(b);
    ASSERT_LE(lo, hi) << b;
    EXPECT_EQ(H::bucket_of(lo), b);
    EXPECT_EQ(H::bucket_of(hi), b);
    if (b + 1 < H::kBuckets) {
      EXPECT_EQ(H::bucket_lower(b + 1), hi + 1) << b;
    }
    // The documented resolution: width <= lower / 16 (buckets below 32 are exact).
    const auto width = static_cast<uint64_t>(hi - lo) + 1;
    if (lo >= 16) {
      EXPECT_LE(width * 16, static_cast<uint64_t>(lo)) << b;
    }
  }
}

TEST(LatencyHistogram, random_values_fall_inside_their_bucket) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 200'000; ++i) {
    const int shift = static_cast<int>(rng() % 63);
    const auto v = static_cast<int64_t>(rng() >> (1 + shift));
    const uint32_t b = H::bucket_of(v);
    ASSERT_LT(b, H::kBuckets);
    ASSERT_LE(H::bucket_lower(b), v);
    ASSERT_GE(H::bucket_upper(b), v);
  }
}

TEST(LatencyHistogram, add_counts_and_reset_clears) {
  auto h = std::make_unique<H>();
  h->add(5);
  h->add(5);
  h->add(-3);
  h->add(1'000'000);
  EXPECT_EQ(h->count(5), 2u);
  EXPECT_EQ(h->count(0), 1u);
  EXPECT_EQ(h->count(H::bucket_of(1'000'000)), 1u);
  h->reset();
  for (uint32_t b = 0; b < H::kBuckets; ++b) ASSERT_EQ(h->count(b), 0u);
}

// --- CycleStats ---------------------------------------------------------------------------

TEST(CycleStats, default_construction_is_all_zero_bytes_so_zeroed_shared_memory_is_empty) {
  auto raw = std::make_unique<unsigned char[]>(sizeof(CycleStats));
  std::memset(raw.get(), 0xA5, sizeof(CycleStats));
  auto* s = new (raw.get()) CycleStats();
  const std::vector<unsigned char> zeros(sizeof(CycleStats), 0);
  EXPECT_EQ(std::memcmp(raw.get(), zeros.data(), sizeof(CycleStats)), 0);
  const StatsSnapshot w = snapshot(*s, Series::kWake);
  EXPECT_EQ(w.count, 0u);
  EXPECT_EQ(w.max_ns, 0);
  EXPECT_EQ(w.p99_ns, 0);
}

TEST(CycleStats, records_min_avg_max_last_of_both_series) {
  auto s = std::make_unique<CycleStats>();
  s->record(3000, 100);
  s->record(5000, 300);
  s->record(4000, 200);
  const StatsSnapshot w = snapshot(*s, Series::kWake);
  const StatsSnapshot e = snapshot(*s, Series::kExec);
  EXPECT_EQ(w.count, 3u);
  EXPECT_EQ(w.min_ns, 3000);
  EXPECT_EQ(w.max_ns, 5000);
  EXPECT_EQ(w.avg_ns, 4000);
  EXPECT_EQ(w.last_ns, 4000);
  EXPECT_EQ(e.min_ns, 100);
  EXPECT_EQ(e.max_ns, 300);
  EXPECT_EQ(e.avg_ns, 200);
  EXPECT_EQ(e.last_ns, 200);
  EXPECT_EQ(e.count, 3u);
}

TEST(CycleStats, first_sample_sets_min_even_when_large) {
  auto s = std::make_unique<CycleStats>();
  s->record(900'000, 5);
  EXPECT_EQ(snapshot(*s, Series::kWake).min_ns, 900'000);
  EXPECT_EQ(snapshot(*s, Series::kWake).p50_ns, 900'000);  // capped at max, a single sample
}

TEST(CycleStats, negative_durations_count_as_zero) {
  auto s = std::make_unique<CycleStats>();
  s->record(-50, -7);
  s->record(10, 20);
  const StatsSnapshot w = snapshot(*s, Series::kWake);
  EXPECT_EQ(w.min_ns, 0);
  EXPECT_EQ(w.avg_ns, 5);
  EXPECT_EQ(w.buckets[0], 1u);
  EXPECT_EQ(snapshot(*s, Series::kExec).min_ns, 0);
}

TEST(CycleStats, counts_runs_of_consecutive_overruns_and_skipped_releases) {
  auto s = std::make_unique<CycleStats>();
  s->record(1, 1);  // on time
  s->record(1, 1);
  EXPECT_EQ(s->record_overrun(0), 1u);
  s->record(1, 1);
  EXPECT_EQ(s->record_overrun(2), 2u);
  s->record(1, 1);
  EXPECT_EQ(s->record_overrun(1), 3u);
  EXPECT_EQ(s->consecutive_overruns(), 3u);
  s->record(1, 1);  // on time again: the run is over at once
  EXPECT_EQ(s->consecutive_overruns(), 0u);
  s->record(1, 1);
  EXPECT_EQ(s->record_overrun(0), 1u);
  const StatsSnapshot w = snapshot(*s, Series::kWake);
  EXPECT_EQ(w.overruns, 4u);
  EXPECT_EQ(w.skipped_releases, 3u);
  EXPECT_EQ(w.max_consecutive_overruns, 3u);
  EXPECT_EQ(w.consecutive_overruns, 1u);
  EXPECT_EQ(w.count, 6u);
}

TEST(CycleStats, ring_returns_the_most_recent_samples_oldest_first) {
  auto s = std::make_unique<CycleStats>();
  std::vector<CycleSample> out(CycleStats::kRingSize + 10);
  EXPECT_EQ(s->recent(out), 0u);
  for (int64_t i = 0; i < 5; ++i) s->record(i, 10 * i);
  ASSERT_EQ(s->recent(out), 5u);
  EXPECT_EQ(out[0].wake_latency_ns, 0);
  EXPECT_EQ(out[4].wake_latency_ns, 4);
  EXPECT_EQ(out[4].exec_ns, 40);

  for (int64_t i = 5; i < 1000; ++i) s->record(i, 10 * i);
  ASSERT_EQ(s->recent(out), CycleStats::kRingSize);
  for (size_t k = 0; k < CycleStats::kRingSize; ++k) {
    ASSERT_EQ(out[k].wake_latency_ns, static_cast<int64_t>(1000 - CycleStats::kRingSize + k));
  }
  // A smaller buffer gets the newest samples.
  std::vector<CycleSample> three(3);
  ASSERT_EQ(s->recent(three), 3u);
  EXPECT_EQ(three[0].wake_latency_ns, 997);
  EXPECT_EQ(three[2].wake_latency_ns, 999);
}

TEST(CycleStats, reset_returns_to_the_empty_state) {
  auto s = std::make_unique<CycleStats>();
  for (int i = 0; i < 100; ++i) s->record(i * 1000, i);
  s->record_overrun(4);
  s->reset();
  const StatsSnapshot w = snapshot(*s, Series::kWake);
  EXPECT_EQ(w.count, 0u);
  EXPECT_EQ(w.overruns, 0u);
  EXPECT_EQ(w.skipped_releases, 0u);
  EXPECT_EQ(w.max_consecutive_overruns, 0u);
  for (uint64_t c : w.buckets) ASSERT_EQ(c, 0u);
  s->record(7, 7);
  EXPECT_EQ(snapshot(*s, Series::kWake).min_ns, 7);
}

// --- percentiles --------------------------------------------------------------------------

// Nearest rank of q (given in parts per million) among n values, 1-based.
uint64_t nearest_rank(uint64_t ppm, uint64_t n) {
  return std::max<uint64_t>(1, (ppm * n + 999'999) / 1'000'000);
}

void expect_percentiles_within_resolution(const std::vector<int64_t>& values) {
  auto s = std::make_unique<CycleStats>();
  for (int64_t v : values) s->record(v, v / 2);
  std::vector<int64_t> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  const StatsSnapshot w = snapshot(*s, Series::kWake);
  ASSERT_EQ(w.count, values.size());
  EXPECT_EQ(w.min_ns, sorted.front());
  EXPECT_EQ(w.max_ns, sorted.back());

  const std::pair<uint64_t, int64_t> cases[] = {
      {500'000, w.p50_ns}, {900'000, w.p90_ns}, {990'000, w.p99_ns}, {999'000, w.p999_ns}};
  for (const auto& [ppm, got] : cases) {
    const int64_t ref = sorted[nearest_rank(ppm, sorted.size()) - 1];
    EXPECT_GE(got, ref) << "ppm " << ppm << ": a percentile must never under-state";
    EXPECT_LE(got, ref + ref / 16) << "ppm " << ppm << ": beyond the 1/16 resolution";
  }
  // Any quantile, straight from the histogram copy.
  std::mt19937 rng(3);
  for (int i = 0; i < 200; ++i) {
    const uint64_t ppm = 1 + rng() % 1'000'000;
    const int64_t got = percentile_ns(w.buckets, static_cast<double>(ppm) / 1e6, w.max_ns);
    const int64_t ref = sorted[nearest_rank(ppm, sorted.size()) - 1];
    ASSERT_GE(got, ref) << ppm;
    ASSERT_LE(got, ref + ref / 16) << ppm;
  }
}

TEST(Percentiles, match_a_sorted_reference_within_a_sixteenth_on_log_uniform_data) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> exponent(2.0, 7.0);  // 100 ns .. 10 ms
  std::vector<int64_t> values(100'000);
  for (auto& v : values) v = static_cast<int64_t>(std::pow(10.0, exponent(rng)));
  expect_percentiles_within_resolution(values);
}

TEST(Percentiles, match_a_sorted_reference_on_a_long_tailed_latency_shape) {
  // Mostly 3..8 us with a rare tail up to a few ms, like a real wake latency.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> body(5000.0, 800.0);
  std::exponential_distribution<double> tail(1.0 / 200'000.0);
  std::vector<int64_t> values(50'000);
  for (auto& v : values) {
    v = static_cast<int64_t>(rng() % 500 == 0 ? 10'000.0 + tail(rng) : std::max(body(rng), 0.0));
  }
  expect_percentiles_within_resolution(values);
}

TEST(Percentiles, small_exact_values_are_reported_exactly) {
  std::vector<int64_t> values;
  for (int64_t v = 1; v <= 20; ++v) values.push_back(v);
  auto s = std::make_unique<CycleStats>();
  for (int64_t v : values) s->record(v, 0);
  const StatsSnapshot w = snapshot(*s, Series::kWake);
  EXPECT_EQ(w.p50_ns, 10);
  EXPECT_EQ(w.p90_ns, 18);
  EXPECT_EQ(w.p99_ns, 20);
  EXPECT_EQ(w.p999_ns, 20);
}

TEST(Percentiles, rank_is_not_pushed_up_by_floating_point) {
  // 0.999 * 1000 is 999.0000000000001 in doubles; the rank must still be 999.
  std::array<uint64_t, H::kBuckets> b{};
  b[10] = 999;
  b[20] = 1;
  EXPECT_EQ(percentile_ns(b, 0.999, 1000), 10);
  EXPECT_EQ(percentile_ns(b, 1.0, 1000), 20);
}

TEST(Percentiles, are_capped_at_max_and_zero_when_empty) {
  std::array<uint64_t, H::kBuckets> b{};
  EXPECT_EQ(percentile_ns(b, 0.5, 100), 0);
  b[H::bucket_of(1'000'000)] = 1;  // bucket upper bound is above 1 ms
  EXPECT_EQ(percentile_ns(b, 0.99, 1'000'000), 1'000'000);
  EXPECT_GT(H::bucket_upper(H::bucket_of(1'000'000)), 1'000'000);
}

TEST(Snapshot, percentiles_stay_within_min_and_max_of_a_torn_read) {
  // What a reader can see while the writer runs: bucket counts from a cycle newer than the
  // min and max it read. The percentiles are raised or lowered into [min, max].
  StatsSnapshot s;
  s.count = 4;
  s.min_ns = 100;
  s.max_ns = 100;
  s.buckets[H::bucket_of(100)] = 5;  // bucket 100..103
  fill_percentiles(s);
  EXPECT_EQ(s.p50_ns, 100);
  EXPECT_EQ(s.p999_ns, 100);

  s.min_ns = 200;
  s.max_ns = 300;
  fill_percentiles(s);
  EXPECT_EQ(s.p50_ns, 200);
}

}  // namespace
}  // namespace rtplc::sched
