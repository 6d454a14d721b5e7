// Bucket names of the link latency histogram (see latency_buckets.h).
#include "io/link/latency_buckets.h"

namespace rtplc::link {

const char* latency_bucket_name(size_t k) {
  static const char* const kNames[kLatencyBuckets] = {
      "<100us",     "100-200us", "200-500us", "0.5-1ms",    "1-2ms",      "2-5ms",
      "5-10ms",     "10-20ms",   "20-50ms",   "50-100ms",   "100-200ms",  ">=200ms"};
  return k < kLatencyBuckets ? kNames[k] : "?";
}

}  // namespace rtplc::link
