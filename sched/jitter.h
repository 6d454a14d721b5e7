// The jitter monitor's data: a log-linear latency histogram and the per-task cycle
// statistics a task thread records every cycle (spec: runtime.md, "Jitter monitor";
// "Tasks and the scheduler" for what wake latency, exec time and overruns mean).
//
// CycleStats is built to live in the POSIX shared-memory process image: fixed size, no
// pointers, trivially destructible, std::atomic members only (all 64-bit and lock-free, so
// a reader that maps the segment read-only in another process — `rtplc stats`,
// `rtplc monitor` — can load them). One writer, the task thread; any number of readers.
// The writer side (record, record_overrun) is RT-safe: no allocation, no lock, no system
// call, no read-modify-write instruction — relaxed loads and stores only. The protocol and
// why relaxed order is enough are written down above CycleStats.
#pragma once

#include <array>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

namespace rtplc::sched {

// Histogram of non-negative nanosecond values with 16 linear sub-buckets per power of two.
//
// Values 0..15 ns each have their own bucket (so 0..31 are exact); from 16 ns on, the
// octave [2^m, 2^(m+1)) is split into 16 equal buckets of width 2^(m-4). A bucket's width
// is therefore at most 1/16 of its lower bound: reporting the bucket's upper bound instead
// of the true value over-states by at most 1/16 (6.25 %), and never under-states. The
// buckets cover every non-negative int64 (up to ~292 years), so there is no overflow
// bucket and no value is ever clamped except negatives, which count as 0.
//
// The counts are atomics so the histogram can sit in shared memory; add() is meant for a
// single writer (it is a relaxed load + store, not an atomic increment).
class LatencyHistogram {
 public:
  static constexpr uint32_t kSubBucketBits = 4;
  static constexpr uint32_t kSubBuckets = 1u << kSubBucketBits;  // 16 per power of two
  // Group 0 holds 0..15; groups 1..59 hold the octaves 2^4 .. 2^62 (the top of int64).
  static constexpr uint32_t kGroups = 64 - kSubBucketBits;
  static constexpr uint32_t kBuckets = kGroups * kSubBuckets;  // 960

  // The bucket holding `ns`; negative values go to bucket 0. O(1): one count-leading-zeros.
  static constexpr uint32_t bucket_of(int64_t ns) noexcept {
    if (ns <= 0) return 0;
    const auto v = static_cast<uint64_t>(ns);
    // group = 0 for v < 16, else (index of the top bit) - 3. Or-ing in 15 makes every
    // value below 16 look like 15, whose bit width is 4.
    const auto group = static_cast<uint32_t>(std::bit_width(v | (kSubBuckets - 1))) - kSubBucketBits;
    const uint32_t shift = group == 0 ? 0 : group - 1;
    const auto sub = static_cast<uint32_t>((v >> shift) & (kSubBuckets - 1));
    return group * kSubBuckets + sub;
  }
  // Smallest value in bucket `b` (b < kBuckets).
  static constexpr int64_t bucket_lower(uint32_t b) noexcept {
    const uint32_t group = b / kSubBuckets;
    const uint64_t sub = b % kSubBuckets;
    if (group == 0) return static_cast<int64_t>(sub);
    return static_cast<int64_t>((kSubBuckets + sub) << (group - 1));
  }
  // Largest value in bucket `b`, inclusive. The last bucket ends at INT64_MAX.
  static constexpr int64_t bucket_upper(uint32_t b) noexcept {
    const uint32_t group = b / kSubBuckets;
    const uint64_t width = group == 0 ? 1 : uint64_t{1} << (group - 1);
    return static_cast<int64_t>(static_cast<uint64_t>(bucket_lower(b)) + width - 1);
  }

  // Single writer only. Relaxed: see CycleStats for why that is enough.
  void add(int64_t ns) noexcept {
    auto& c = counts_[bucket_of(ns)];
    c.store(c.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
  uint64_t count(uint32_t b) const noexcept { return counts_[b].load(std::memory_order_relaxed); }
  // Not safe against a concurrent add(): tests and (re)initialisation only.
  void reset() noexcept;

 private:
  std::array<std::atomic<uint64_t>, kBuckets> counts_{};
};

// One entry of the ring of recent cycles.
struct CycleSample {
  int64_t wake_latency_ns = 0;
  int64_t exec_ns = 0;
};

// What a task thread records per cycle.
//
// Protocol. Writer: the task thread, alone; every member is written by it only. Readers:
// any thread or process, at any time, without telling the writer. All accesses are relaxed
// atomic loads/stores, which is enough because
//  - there is one writer, so "load, compute, store" cannot lose an update and needs no
//    read-modify-write (which would cost a locked instruction per field per cycle);
//  - a reader needs no field to agree exactly with another: a snapshot may combine, say,
//    the count of cycle k with the sum of cycle k+1. snapshot() therefore clamps what could
//    disagree (avg into [min, max]; percentiles against the histogram's own total), and
//    every reported figure is off by at most one or two adjacent cycles;
//  - each counter only grows, and coherence of a single atomic object guarantees that a
//    reader which loads it twice never sees the second load older than the first: counts
//    a reader observes never go backwards;
//  - 64-bit atomic loads and stores are single instructions, so no value is ever torn.
// No release/acquire pairing is needed because no reader follows a pointer or relies on
// one field to publish another.
//
// Call order per cycle: record(wake latency, exec time) once; then, if the cycle ended
// after the next release, record_overrun(releases skipped). Lifetime in shared memory: the
// segment's creator constructs it with placement new (all zeros is the empty state).
class CycleStats {
 public:
  static constexpr size_t kRingSize = 256;

  // One finished cycle. Negative durations (a clock glitch, a caller bug) count as 0.
  void record(int64_t wake_latency_ns, int64_t exec_ns) noexcept;
  // The cycle just passed to record() ended after its next release; `skipped_releases` is
  // how many releases the scheduler dropped to get back on its time grid. Returns the
  // number of consecutive overrunning cycles including this one — what the watchdog
  // compares with its limit. (Readers may see the current run as 0 in the instant between
  // record() and this call; the return value is always exact.)
  uint64_t record_overrun(uint64_t skipped_releases) noexcept;
  // Back to the empty state. Not safe against a concurrent writer: tests and restarts only.
  void reset() noexcept;

  // Reader side: each call is one relaxed load (see the protocol above).
  uint64_t cycles() const noexcept { return load(count_); }
  uint64_t overruns() const noexcept { return load(overruns_); }
  uint64_t skipped_releases() const noexcept { return load(skipped_); }
  uint64_t consecutive_overruns() const noexcept { return load(consecutive_); }
  uint64_t max_consecutive_overruns() const noexcept { return load(max_consecutive_); }
  // Copies up to out.size() of the most recent samples (at most kRingSize), oldest first,
  // and returns how many. A sample the writer overwrites during the copy may come out as
  // a newer cycle's value: readers get recent samples, not a frozen window.
  size_t recent(std::span<CycleSample> out) const noexcept;

  // Per measured quantity; public so snapshot() can read it, written only via record().
  struct Series {
    std::atomic<int64_t> min_ns{0};
    std::atomic<int64_t> max_ns{0};
    std::atomic<int64_t> last_ns{0};
    std::atomic<uint64_t> sum_ns{0};  // of clamped values; 2^64 ns is ~584 years
    LatencyHistogram hist;
  };
  const Series& wake() const noexcept { return wake_; }
  const Series& exec() const noexcept { return exec_; }

 private:
  template <typename T>
  static T load(const std::atomic<T>& a) noexcept {
    return a.load(std::memory_order_relaxed);
  }
  template <typename T>
  static void store(std::atomic<T>& a, T v) noexcept {
    a.store(v, std::memory_order_relaxed);
  }
  static void add_to(Series& s, int64_t v, uint64_t n_before) noexcept;

  // Hot scalars first, so a cycle touches few cache lines.
  std::atomic<uint64_t> count_{0};  // cycles recorded; also the ring's write index
  std::atomic<uint64_t> overruns_{0};
  std::atomic<uint64_t> skipped_{0};
  std::atomic<uint64_t> consecutive_{0};      // current run of overrunning cycles
  std::atomic<uint64_t> max_consecutive_{0};  // longest run so far
  // Writer's own bookkeeping: the run that ended with the previous cycle, saved by
  // record() so record_overrun() can extend it while record() already shows 0.
  std::atomic<uint64_t> run_before_{0};
  Series wake_;
  Series exec_;
  struct RingSlot {
    std::atomic<int64_t> wake_latency_ns{0};
    std::atomic<int64_t> exec_ns{0};
  };
  std::array<RingSlot, kRingSize> ring_{};  // slot (count - 1) % kRingSize is the newest
};

static_assert(std::atomic<uint64_t>::is_always_lock_free && std::atomic<int64_t>::is_always_lock_free,
              "CycleStats needs lock-free 64-bit atomics to be shared between processes");
static_assert(std::is_trivially_destructible_v<CycleStats>, "lives in shared memory");
static_assert(std::is_standard_layout_v<CycleStats>, "lives in shared memory");

// Which quantity of a CycleStats to summarise.
enum class Series : uint8_t { kWake, kExec };

// Plain numbers for readers: one quantity (wake latency or exec time) of one task plus the
// task's overrun counters (the same in both snapshots of a task).
struct StatsSnapshot {
  uint64_t count = 0;  // cycles recorded
  int64_t min_ns = 0;
  int64_t avg_ns = 0;   // rounded down, clamped into [min, max]
  int64_t max_ns = 0;
  int64_t last_ns = 0;  // the most recent cycle ("Act" in cyclictest)
  // Percentiles from the histogram, each the upper bound of the bucket holding the rank
  // (nearest-rank method), capped at max_ns: never below the true value, at most 1/16 above.
  int64_t p50_ns = 0;
  int64_t p90_ns = 0;
  int64_t p99_ns = 0;
  int64_t p999_ns = 0;
  uint64_t overruns = 0;
  uint64_t skipped_releases = 0;
  uint64_t consecutive_overruns = 0;
  uint64_t max_consecutive_overruns = 0;
  std::array<uint64_t, LatencyHistogram::kBuckets> buckets{};  // a copy of the histogram
};

// Reads one quantity of `stats` while its writer may be running (see CycleStats).
StatsSnapshot snapshot(const CycleStats& stats, Series series) noexcept;

// The q-quantile (0 < q <= 1) of a copied histogram by the nearest-rank method: the upper
// bound of the bucket holding the ceil(q * total)-th smallest value, capped at `cap_ns`.
// 0 when the histogram is empty.
int64_t percentile_ns(std::span<const uint64_t, LatencyHistogram::kBuckets> buckets, double q,
                      int64_t cap_ns) noexcept;

// Recomputes the percentiles of `s` from s.buckets (capped at s.max_ns); for callers that
// build a snapshot by hand, e.g. from a histogram file.
void fill_percentiles(StatsSnapshot& s) noexcept;

}  // namespace rtplc::sched
