// Reconnect backoff shared by every link that dials a peer (S7 today, Modbus
// TCP next): exponential from `min_ns`, doubling per consecutive failure up to
// `max_ns`, with "equal jitter" (half fixed, half random) so peers that failed
// together do not all come back at the same instant.
#pragma once

#include <algorithm>
#include <cstdint>

namespace rtplc::link {

// `random` is any uniformly distributed number (the caller's generator).
inline int64_t backoff_delay_ns(uint32_t failures, int64_t min_ns, int64_t max_ns, uint64_t random) {
  const uint32_t shift = std::min<uint32_t>(failures > 0 ? failures - 1 : 0, 20);
  const int64_t exp = std::min(max_ns, min_ns << shift);
  const int64_t half = std::max<int64_t>(exp / 2, 1);
  return half + static_cast<int64_t>(random % static_cast<uint64_t>(half));
}

}  // namespace rtplc::link
