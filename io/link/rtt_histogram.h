// Round-trip-time statistics per PLC (issue 4, item 3: "RTT p50/p99"): a fixed
// log-linear histogram of microseconds, 16 buckets per octave (quantiles within
// about 6 %), no allocation after construction and O(1) per sample, so the engine
// can record every reply of a thousand PLCs.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace rtplc::link {

class RttHistogram {
 public:
  void record(uint64_t micros);
  // The q-quantile (0..1) in microseconds, the upper edge of its bucket; 0 if empty.
  uint64_t quantile(double q) const;
  uint64_t count() const { return count_; }
  uint64_t max() const { return max_; }
  void clear();

  static size_t bucket_of(uint64_t micros);
  static uint64_t bucket_upper(size_t bucket);

 private:
  static constexpr size_t kLinear = 32;  // 0..31 us exact
  static constexpr size_t kSub = 16;     // per octave above
  static constexpr size_t kBuckets = kLinear + kSub * 40;
  std::array<uint32_t, kBuckets> counts_{};
  uint64_t count_ = 0;
  uint64_t max_ = 0;
};

}  // namespace rtplc::link
