// One task thread records millions of cycles into CycleStats while reader threads take
// snapshots, as `rtplc stats` does from another process (spec: runtime.md, "Jitter
// monitor"; protocol in sched/jitter.h). Checks what the relaxed protocol promises: counts a
// reader sees never go backwards, every snapshot is internally sane (min <= avg <= max,
// ordered percentiles), and the final figures are exact. Run under ThreadSanitizer too
// (label concurrency): every shared access is atomic, so it must report nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "sched/jitter.h"

namespace rtplc::sched {
namespace {

#if defined(__SANITIZE_THREAD__)
constexpr uint64_t kCycles = 1'000'000;  // ThreadSanitizer runs every access through its runtime
#else
constexpr uint64_t kCycles = 4'000'000;
#endif
constexpr uint64_t kOverrunEvery = 1000;  // cycles k*1000, +1, +2 overrun: runs of three

int64_t wake_of(uint64_t i) { return 2000 + static_cast<int64_t>((i * 7919) % 50'000); }
int64_t exec_of(uint64_t i) { return 300 + static_cast<int64_t>((i * 104'729) % 9000); }
bool overruns(uint64_t i) { return i % kOverrunEvery < 3 && i >= kOverrunEvery; }

struct ReaderResult {
  uint64_t snapshots = 0;
  uint64_t during_writes = 0;  // snapshots taken while the writer was still recording
  uint64_t failures = 0;
  std::string first_failure;
};

void check_snapshot_sane(const StatsSnapshot& s, ReaderResult& r, const char* what) {
  auto fail = [&](const char* why) {
    if (r.failures++ == 0) r.first_failure = std::string(what) + ": " + why;
  };
  if (s.count == 0) return;
  if (!(s.min_ns <= s.avg_ns && s.avg_ns <= s.max_ns)) fail("min <= avg <= max broken");
  if (!(s.min_ns <= s.p50_ns && s.p50_ns <= s.p90_ns && s.p90_ns <= s.p99_ns &&
        s.p99_ns <= s.p999_ns && s.p999_ns <= s.max_ns)) {
    fail("percentiles out of order");
  }
}

// Each reader counts itself in here after kOverlap snapshots taken mid-write; the writer
// keeps going until all have, so the test never passes without real overlap.
constexpr uint64_t kOverlap = 50;

void reader(const CycleStats& stats, const std::atomic<bool>& done, std::atomic<int>& overlapped,
            ReaderResult& r) {
  StatsSnapshot prev_wake;
  StatsSnapshot prev_exec;
  auto went_back = [&](const StatsSnapshot& now, const StatsSnapshot& before, const char* what) {
    bool back = now.count < before.count || now.overruns < before.overruns ||
                now.skipped_releases < before.skipped_releases ||
                now.max_consecutive_overruns < before.max_consecutive_overruns;
    for (uint32_t b = 0; b < LatencyHistogram::kBuckets && !back; ++b) {
      back = now.buckets[b] < before.buckets[b];
    }
    if (back && r.failures++ == 0) r.first_failure = std::string(what) + ": a count went backwards";
  };
  // At least a few snapshots even if the writer finishes first.
  for (int extra = 0; !done.load(std::memory_order_acquire) || extra < 3;) {
    const bool writing = !done.load(std::memory_order_acquire);
    if (!writing) ++extra;
    const StatsSnapshot w = snapshot(stats, Series::kWake);
    const StatsSnapshot e = snapshot(stats, Series::kExec);
    check_snapshot_sane(w, r, "wake");
    check_snapshot_sane(e, r, "exec");
    went_back(w, prev_wake, "wake");
    went_back(e, prev_exec, "exec");
    prev_wake = w;
    prev_exec = e;
    ++r.snapshots;
    if (writing && w.count > 0 && ++r.during_writes == kOverlap) {
      overlapped.fetch_add(1, std::memory_order_relaxed);
    }
  }
}

TEST(CycleStatsConcurrency, readers_see_monotonic_sane_snapshots_while_the_writer_records) {
  auto stats = std::make_unique<CycleStats>();
  std::atomic<bool> done{false};
  std::atomic<int> overlapped{0};
  constexpr int kReaders = 2;
  std::vector<ReaderResult> results(kReaders);
  std::vector<std::thread> readers;
  for (int i = 0; i < kReaders; ++i) {
    readers.emplace_back(reader, std::cref(*stats), std::cref(done), std::ref(overlapped),
                         std::ref(results[static_cast<size_t>(i)]));
  }

  uint64_t expect_overruns = 0;
  uint64_t longest_seen_by_writer = 0;
  uint64_t cycles = 0;
  std::thread writer([&] {
    // At least kCycles, and on until every reader has overlapped the writing.
    for (; cycles < kCycles || overlapped.load(std::memory_order_relaxed) < kReaders; ++cycles) {
      stats->record(wake_of(cycles), exec_of(cycles));
      if (overruns(cycles)) {
        ++expect_overruns;
        longest_seen_by_writer = std::max(longest_seen_by_writer, stats->record_overrun(2));
      }
    }
    done.store(true, std::memory_order_release);
  });
  writer.join();
  for (auto& t : readers) t.join();

  for (const auto& r : results) {
    EXPECT_EQ(r.failures, 0u) << r.first_failure;
    EXPECT_GE(r.during_writes, kOverlap);
  }

  // After the writer stopped, the figures are exact.
  const StatsSnapshot w = snapshot(*stats, Series::kWake);
  const StatsSnapshot e = snapshot(*stats, Series::kExec);
  EXPECT_EQ(w.count, cycles);
  EXPECT_EQ(w.overruns, expect_overruns);
  EXPECT_EQ(w.skipped_releases, 2 * expect_overruns);
  EXPECT_EQ(w.max_consecutive_overruns, 3u);
  EXPECT_EQ(longest_seen_by_writer, 3u);
  uint64_t total = 0;
  int64_t min = INT64_MAX;
  int64_t max = 0;
  uint64_t sum = 0;
  for (uint64_t i = 0; i < cycles; ++i) {
    min = std::min(min, exec_of(i));
    max = std::max(max, exec_of(i));
    sum += static_cast<uint64_t>(exec_of(i));
  }
  for (uint64_t c : e.buckets) total += c;
  EXPECT_EQ(total, cycles);
  EXPECT_EQ(e.min_ns, min);
  EXPECT_EQ(e.max_ns, max);
  EXPECT_EQ(e.avg_ns, static_cast<int64_t>(sum / cycles));
  EXPECT_EQ(w.last_ns, wake_of(cycles - 1));
}

}  // namespace
}  // namespace rtplc::sched
