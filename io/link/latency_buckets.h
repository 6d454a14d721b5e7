// A coarse, fixed latency histogram every link reports the same way (the
// generic link rows of the process image, `rtplc stats`, `monitor`): counts
// of round trips per bucket, bucket k holding [edge(k-1), edge(k)) us. Plain
// data, trivially copyable, so it travels inside a SnapshotSlot and into the
// image unchanged.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace rtplc::link {

inline constexpr size_t kLatencyBuckets = 12;
// Upper edges in microseconds; the last bucket is open.
inline constexpr std::array<uint32_t, kLatencyBuckets - 1> kLatencyEdgesUs = {
    100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000, 100000, 200000};

struct LatencyBuckets {
  std::array<uint32_t, kLatencyBuckets> counts{};

  static size_t bucket_of(uint64_t micros) {
    size_t k = 0;
    while (k < kLatencyEdgesUs.size() && micros >= kLatencyEdgesUs[k]) ++k;
    return k;
  }
  void record(uint64_t micros) { ++counts[bucket_of(micros)]; }
};

// "<100us", "100us-200us", ..., ">=200ms": a bucket's range for tables.
const char* latency_bucket_name(size_t k);

}  // namespace rtplc::link
