// The jitter monitor's writer path and its reader-side snapshot (spec: runtime.md,
// "Jitter monitor"). The protocol between the two is documented above CycleStats in
// sched/jitter.h; this file keeps to it: the writer does relaxed loads and stores of its
// own fields only, readers do relaxed loads and repair what adjacent cycles can make
// disagree.
#include "sched/jitter.h"

#include <algorithm>

namespace rtplc::sched {

void LatencyHistogram::reset() noexcept {
  for (auto& c : counts_) c.store(0, std::memory_order_relaxed);
}

void CycleStats::add_to(Series& s, int64_t v, uint64_t n_before) noexcept {
  // The first sample sets min and max: that way all-zero memory is a valid empty state and
  // the shared-memory segment needs no sentinel values written at creation.
  if (n_before == 0 || v < load(s.min_ns)) store(s.min_ns, v);
  if (n_before == 0 || v > load(s.max_ns)) store(s.max_ns, v);
  store(s.last_ns, v);
  store(s.sum_ns, load(s.sum_ns) + static_cast<uint64_t>(v));
  s.hist.add(v);
}

void CycleStats::record(int64_t wake_latency_ns, int64_t exec_ns) noexcept {
  const int64_t wake = std::max<int64_t>(wake_latency_ns, 0);
  const int64_t exec = std::max<int64_t>(exec_ns, 0);
  const uint64_t n = load(count_);

  RingSlot& slot = ring_[n % kRingSize];
  store(slot.wake_latency_ns, wake);
  store(slot.exec_ns, exec);
  add_to(wake_, wake, n);
  add_to(exec_, exec, n);

  // A cycle starts out as on time; record_overrun() for this same cycle extends the run
  // saved here. Readers may see 0 in the instant between the two calls of an overrunning
  // cycle — a display flicker, never a wrong watchdog decision (the watchdog uses the
  // value record_overrun() returns).
  store(run_before_, load(consecutive_));
  store(consecutive_, uint64_t{0});

  // Stored last only by habit: with relaxed order a reader may still see it before the
  // fields above, which snapshot() tolerates.
  store(count_, n + 1);
}

uint64_t CycleStats::record_overrun(uint64_t skipped_releases) noexcept {
  store(overruns_, load(overruns_) + 1);
  store(skipped_, load(skipped_) + skipped_releases);
  const uint64_t run = load(run_before_) + 1;
  store(consecutive_, run);
  if (run > load(max_consecutive_)) store(max_consecutive_, run);
  return run;
}

void CycleStats::reset() noexcept {
  for (auto* a : {&count_, &overruns_, &skipped_, &consecutive_, &max_consecutive_, &run_before_}) {
    store(*a, uint64_t{0});
  }
  for (Series* s : {&wake_, &exec_}) {
    store(s->min_ns, int64_t{0});
    store(s->max_ns, int64_t{0});
    store(s->last_ns, int64_t{0});
    store(s->sum_ns, uint64_t{0});
    s->hist.reset();
  }
  for (auto& slot : ring_) {
    store(slot.wake_latency_ns, int64_t{0});
    store(slot.exec_ns, int64_t{0});
  }
}

size_t CycleStats::recent(std::span<CycleSample> out) const noexcept {
  const uint64_t n = load(count_);
  const size_t k = static_cast<size_t>(std::min<uint64_t>({n, kRingSize, out.size()}));
  for (size_t i = 0; i < k; ++i) {
    const RingSlot& slot = ring_[(n - k + i) % kRingSize];
    out[i] = CycleSample{load(slot.wake_latency_ns), load(slot.exec_ns)};
  }
  return k;
}

int64_t percentile_ns(std::span<const uint64_t, LatencyHistogram::kBuckets> buckets, double q,
                      int64_t cap_ns) noexcept {
  uint64_t total = 0;
  for (uint64_t c : buckets) total += c;
  if (total == 0) return 0;
  // The rank in integers (q in parts per million): q * total in floating point can land a
  // hair above an integer (0.999 * 1000 = 999.0000000000001) and skip to the next rank.
  const auto ppm = static_cast<unsigned __int128>(std::clamp(q, 0.0, 1.0) * 1e6 + 0.5);
  auto rank = static_cast<uint64_t>((ppm * total + 999'999) / 1'000'000);
  rank = std::max<uint64_t>(rank, 1);
  uint64_t seen = 0;
  for (uint32_t b = 0; b < LatencyHistogram::kBuckets; ++b) {
    seen += buckets[b];
    if (seen >= rank) return std::min(LatencyHistogram::bucket_upper(b), cap_ns);
  }
  return cap_ns;  // unreachable: seen ends at total >= rank
}

void fill_percentiles(StatsSnapshot& s) noexcept {
  // Clamped into [min, max]: a snapshot taken while the writer runs can hold a bucket
  // count from a cycle newer than the min it read; raising a percentile keeps it an
  // upper bound.
  auto pct = [&s](double q) {
    return std::clamp(percentile_ns(s.buckets, q, s.max_ns), s.min_ns, s.max_ns);
  };
  s.p50_ns = pct(0.50);
  s.p90_ns = pct(0.90);
  s.p99_ns = pct(0.99);
  s.p999_ns = pct(0.999);
}

StatsSnapshot snapshot(const CycleStats& stats, Series series) noexcept {
  const CycleStats::Series& src = series == Series::kWake ? stats.wake() : stats.exec();
  auto rd = [](const auto& a) { return a.load(std::memory_order_relaxed); };

  StatsSnapshot s;
  s.count = stats.cycles();
  s.overruns = stats.overruns();
  s.skipped_releases = stats.skipped_releases();
  s.consecutive_overruns = stats.consecutive_overruns();
  s.max_consecutive_overruns = stats.max_consecutive_overruns();
  for (uint32_t b = 0; b < LatencyHistogram::kBuckets; ++b) s.buckets[b] = src.hist.count(b);
  if (s.count == 0) return s;  // fields may hold a first cycle the count does not show yet

  s.min_ns = rd(src.min_ns);
  s.max_ns = std::max(rd(src.max_ns), s.min_ns);
  s.last_ns = rd(src.last_ns);
  // sum and count can come from adjacent cycles, so the quotient can stray just outside
  // [min, max] (all samples 100 ns, sum of k+1 over count k): clamp it back.
  s.avg_ns = std::clamp(static_cast<int64_t>(rd(src.sum_ns) / s.count), s.min_ns, s.max_ns);
  fill_percentiles(s);
  return s;
}

}  // namespace rtplc::sched
