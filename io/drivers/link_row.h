// How a driver that talks to peers (an S7 PLC, a Modbus slave) fills a peer's
// link row (io/process_image.h, LinkStatus) from that peer's status, the same
// for every such kind. The writer is the driver's bridge thread, the only one
// (publish_status() in its cycle); the readers are `rtplc stats`, `monitor`
// and `status` through the shared image. Every store is relaxed, as each kind
// did before: the row is a set of independent gauges and counters, each read
// on its own, and no reader takes one field as a sign that another is fresh.
// No allocation, lock or syscall: fit for the RT cycle.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "common/quality.h"
#include "io/link/latency_buckets.h"
#include "io/process_image.h"

namespace rtplc::io {

// A peer's write outcomes as its driver counts them.
struct WriteCounts {
  uint64_t acked = 0;
  uint64_t failed = 0;
  uint64_t pending = 0;
  uint64_t rejected = 0;
};

// `st` has the peer figures every kind's status shares: rtt_p50_us,
// rtt_p99_us, rtt_max_us, connects, reconnects, timeouts, errors,
// polls_completed, polls_missed, polls_offline. `rtt` counts its round trips.
template <class PeerStatus>
void publish_link_row(LinkStatus& ls, uint8_t state, Quality quality, const PeerStatus& st,
                      const link::LatencyBuckets& rtt, const WriteCounts& w) noexcept {
  const auto r = std::memory_order_relaxed;
  ls.state.store(state, r);
  ls.quality.store(static_cast<uint8_t>(quality), r);
  ls.rtt_p50_us.store(st.rtt_p50_us, r);
  ls.rtt_p99_us.store(st.rtt_p99_us, r);
  ls.rtt_max_us.store(st.rtt_max_us, r);
  ls.connects.store(st.connects, r);
  ls.reconnects.store(st.reconnects, r);
  ls.timeouts.store(st.timeouts, r);
  ls.errors.store(st.errors, r);
  ls.polls_completed.store(st.polls_completed, r);
  ls.polls_missed.store(st.polls_missed, r);
  ls.polls_offline.store(st.polls_offline, r);
  ls.writes_acked.store(w.acked, r);
  ls.writes_failed.store(w.failed, r);
  ls.writes_pending.store(w.pending, r);
  ls.writes_rejected.store(w.rejected, r);
  for (size_t b = 0; b < kLinkLatencyBuckets; ++b) ls.latency[b].store(rtt.counts[b], r);
}

}  // namespace rtplc::io
