// The trace ring's writer, reader and selection hand-over (protocol in
// trace_ring.h).
#include "io/trace_ring.h"

#include <algorithm>

namespace rtplc::io {

bool TraceWriter::pick_up() noexcept {
  if (block_ == nullptr) return false;
  TraceControl& c = block_->control;
  const uint64_t g = c.requested.load(std::memory_order_acquire);
  if (g == generation_) return false;
  generation_ = g;
  n_ = std::min(c.n, kTraceChannels);
  for (uint32_t i = 0; i < n_; ++i) src_[i] = c.src[i];
  // Only this thread writes head: a relaxed load is exact.
  c.first_record.store(block_->ring.head.load(std::memory_order_relaxed), std::memory_order_relaxed);
  c.applied.store(g, std::memory_order_release);  // hands src[] back, publishes first_record
  return true;
}

void TraceWriter::append(uint64_t cycle, int64_t release_ns, const double* values) noexcept {
  if (n_ == 0) return;
  TraceRecord& r = begin(cycle, release_ns);
  for (uint32_t k = 0; k < n_; ++k) put(r, k, values[k]);
  commit(r);
}

TraceRecord& TraceWriter::begin(uint64_t cycle, int64_t release_ns) noexcept {
  // Only this thread writes head: a relaxed load is exact.
  const uint64_t i = block_->ring.head.load(std::memory_order_relaxed);
  TraceRecord& r = block_->records[i % kTraceSlots];
  // Odd: being written. The acquire half keeps the stores below after it.
  r.seq.exchange(2 * i + 1, std::memory_order_acq_rel);
  r.cycle.store(cycle, std::memory_order_release);
  r.release_ns.store(release_ns, std::memory_order_release);
  return r;
}

void TraceWriter::commit(TraceRecord& r) noexcept {
  TraceRingHeader& ring = block_->ring;
  const uint64_t i = ring.head.load(std::memory_order_relaxed);
  r.seq.store(2 * i + 2, std::memory_order_release);
  ring.head.store(i + 1, std::memory_order_release);
}

size_t TraceReader::drain(std::vector<TraceSample>& out) {
  const uint64_t head = block_->ring.head.load(std::memory_order_acquire);
  if (head <= next_) return 0;
  // The writer may be filling record `head` right now, in the slot of record
  // head - kTraceSlots: only the kTraceSlots - 1 records below head are safe
  // to try; older ones are gone.
  const uint64_t oldest = head >= kTraceSlots - 1 ? head - (kTraceSlots - 1) : 0;
  if (next_ < oldest) {
    lost_ += oldest - next_;
    next_ = oldest;
  }
  size_t got = 0;
  for (; next_ < head; ++next_) {
    const TraceRecord& r = block_->records[next_ % kTraceSlots];
    const uint64_t want = 2 * next_ + 2;
    const uint64_t v1 = r.seq.load(std::memory_order_acquire);
    if (v1 != want) {
      ++lost_;  // overwritten by a later record since we read head
      continue;
    }
    TraceSample s;
    s.record = next_;
    s.cycle = r.cycle.load(std::memory_order_acquire);
    s.release_ns = r.release_ns.load(std::memory_order_acquire);
    for (uint32_t k = 0; k < n_ && k < kTraceChannels; ++k) s.values[k] = r.values[k].load(std::memory_order_acquire);
    // The acquire loads above keep this one after them (see the protocol).
    if (r.seq.load(std::memory_order_relaxed) != v1) {
      ++lost_;
      continue;
    }
    out.push_back(s);
    ++got;
  }
  return got;
}

uint64_t TraceReader::behind() const {
  const uint64_t head = block_->ring.head.load(std::memory_order_acquire);
  return head > next_ ? head - next_ : 0;
}

bool request_trace(TraceBlock& block, const TraceSource* src, uint32_t n) noexcept {
  TraceControl& c = block.control;
  const uint64_t g = c.requested.load(std::memory_order_relaxed);  // only this thread writes it
  if (c.applied.load(std::memory_order_acquire) != g) return false;  // the task may still read src[]
  c.n = std::min(n, kTraceChannels);
  for (uint32_t i = 0; i < c.n; ++i) c.src[i] = src[i];
  c.requested.store(g + 1, std::memory_order_release);
  return true;
}

bool trace_applied(const TraceBlock& block, uint64_t* first_record) noexcept {
  const TraceControl& c = block.control;
  if (c.applied.load(std::memory_order_acquire) != c.requested.load(std::memory_order_relaxed)) return false;
  if (first_record != nullptr) *first_record = c.first_record.load(std::memory_order_relaxed);
  return true;
}

void prefault(TraceBlock& block) noexcept {
  // A read-modify-write that changes nothing: it dirties the page (a read
  // could map the zero page and fault again on the task's first store), and
  // stays atomic if the task happens to write the same record.
  block.ring.head.fetch_add(0, std::memory_order_relaxed);
  for (TraceRecord& r : block.records) r.seq.fetch_add(0, std::memory_order_relaxed);
}

}  // namespace rtplc::io
