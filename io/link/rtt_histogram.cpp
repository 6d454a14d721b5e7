// Log-linear RTT histogram (see rtt_histogram.h).
#include "io/link/rtt_histogram.h"

#include <bit>
#include <cmath>

namespace rtplc::link {

size_t RttHistogram::bucket_of(uint64_t v) {
  if (v < kLinear) return static_cast<size_t>(v);
  const int e = 63 - std::countl_zero(v);  // v in [2^e, 2^(e+1)), e >= 5
  const auto sub = static_cast<size_t>((v >> (e - 4)) & (kSub - 1));
  const size_t b = kLinear + static_cast<size_t>(e - 5) * kSub + sub;
  return b < kBuckets ? b : kBuckets - 1;
}

uint64_t RttHistogram::bucket_upper(size_t b) {
  if (b < kLinear) return b;
  const size_t e = (b - kLinear) / kSub + 5;
  const size_t sub = (b - kLinear) % kSub;
  return ((uint64_t{16} + sub + 1) << (e - 4)) - 1;
}

void RttHistogram::record(uint64_t micros) {
  ++counts_[bucket_of(micros)];
  ++count_;
  if (micros > max_) max_ = micros;
}

uint64_t RttHistogram::quantile(double q) const {
  if (count_ == 0) return 0;
  const auto rank = static_cast<uint64_t>(std::ceil(q * static_cast<double>(count_)));
  uint64_t seen = 0;
  for (size_t b = 0; b < kBuckets; ++b) {
    seen += counts_[b];
    if (seen >= rank && seen > 0) {
      const uint64_t up = bucket_upper(b);
      return up < max_ ? up : max_;
    }
  }
  return max_;
}

void RttHistogram::clear() {
  counts_.fill(0);
  count_ = 0;
  max_ = 0;
}

}  // namespace rtplc::link
