// The per-task trace ring in the process image (spec runtime.md, "The process
// image"; docs/runtime.md, "Tracing a running runtime"): what `rtplc trace`
// records. While a trace is selected, the task appends one record per cycle it
// runs (cycle number, release time, the values of the traced channels) and a
// tool in another process drains the ring; a record the tool did not read in
// time is overwritten and *counted*, never silently skipped.
//
// Each task has one TraceBlock: TraceControl (the selection), TraceRingHeader,
// then kTraceSlots TraceRecords. Capacity is fixed when the image is created
// (kTraceSlots records of at most kTraceChannels values), so the task never
// allocates; the pages are touched by the control thread when a trace starts
// (prefault()), not at load, so a runtime nobody traces does not pay for them
// (unless mlockall makes every mapped page resident anyway).
//
// Selection protocol (writer: the runtime's control thread; reader: the task):
//   control  waits until applied == requested (acquire), so the task reads no
//            field below any more; writes n and src[] (plain); then
//            requested = g + 1 (release)
//   task     at a cycle boundary: g = requested (acquire); g != its own
//            generation -> reads n and src[] (plain: the release/acquire pair
//            orders them after the control thread's writes), stores
//            first_record = head (relaxed), then applied = g (release)
//   control  sees applied == g + 1 (acquire): first_record is the number of
//            the first record of this selection, src[] is free to rewrite
// The control thread never writes n or src[] between a request and its
// acknowledgement, so neither side ever reads a field the other is writing.
//
// Ring protocol (writer: the task thread, the only one; reader: one tool):
//   writer  record i goes to slot i % kTraceSlots:
//           slot.seq = 2i+1 (exchange, acq_rel: no store below moves above it)
//           cycle, release_ns, values (release stores)
//           slot.seq = 2i+2 (release); head = i+1 (release)
//   reader  h = head (acquire); records below h - kTraceSlots + 1 may already
//           be overwritten (the writer may be filling record h in the slot of
//           h - kTraceSlots): they are counted lost without being read. For
//           each record i in range: v1 = seq (acquire); v1 != 2i+2 -> lost
//           (overwritten since); copy (acquire loads); v2 = seq; v2 != v1 ->
//           lost (the writer reused the slot while we copied)
// A load that saw any store of a later record in that slot happens after that
// record's odd seq (the acq_rel exchange keeps its stores below it), so v2
// differs and the torn copy is counted lost, never accepted. The writer never
// waits and makes no system call; a reader preempting it on the same CPU reads
// only completed records (those below head), which the writer is not touching
// unless it has lapped the whole ring. So every record number is either
// delivered exactly once or counted in lost(): none is hidden.
//
// All shared fields are std::atomic (plain moves on x86-64, ldar/stlr on
// AArch64); there are no standalone fences, so ThreadSanitizer checks this code.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace rtplc::io {

inline constexpr uint32_t kTraceChannels = 8;  // values per record (per task)
inline constexpr uint32_t kTraceSlots = 2048;  // records per task ring (2 s at 1 ms)

// Where one traced value comes from: a channel's region and index (what the
// channel table says); the task resolves it to the value its program used.
struct TraceSource {
  uint16_t region;
  uint16_t pad;
  uint32_t index;
};

struct alignas(64) TraceControl {
  std::atomic<uint64_t> requested;     // selection generation (control thread, release)
  std::atomic<uint64_t> applied;       // generation the task records (task, release)
  std::atomic<uint64_t> first_record;  // first record of the applied selection (task)
  uint32_t n;                          // channels selected; 0 = not tracing
  uint32_t pad;
  TraceSource src[kTraceChannels];
};

struct alignas(64) TraceRingHeader {
  std::atomic<uint64_t> head;  // records written so far (task, release)
};

struct TraceRecord {
  std::atomic<uint64_t> seq;         // 2i+1 while record i is written, 2i+2 when complete
  std::atomic<uint64_t> cycle;       // the task's cycle counter
  std::atomic<int64_t> release_ns;   // the cycle's release time (CLOCK_MONOTONIC)
  std::atomic<double> values[kTraceChannels];
};
static_assert(std::atomic<double>::is_always_lock_free);

struct alignas(64) TraceBlock {
  TraceControl control;
  TraceRingHeader ring;
  TraceRecord records[kTraceSlots];
};

// The task thread's side: picks the selection up at cycle boundaries and
// appends records. Everything here is wait-free and makes no system call.
class TraceWriter {
 public:
  explicit TraceWriter(TraceBlock* block = nullptr) : block_(block) {}
  // At a cycle boundary: true when a new selection was taken (the caller
  // re-resolves its sources, see sources()); n() is 0 when tracing stopped.
  bool pick_up() noexcept;
  uint32_t n() const noexcept { return n_; }
  const TraceSource* sources() const noexcept { return src_; }
  // One record: `values` holds n() values. The same in three steps (what
  // append() does; tests put a preempting reader between them):
  void append(uint64_t cycle, int64_t release_ns, const double* values) noexcept;
  TraceRecord& begin(uint64_t cycle, int64_t release_ns) noexcept;
  static void put(TraceRecord& r, uint32_t k, double v) noexcept {
    r.values[k].store(v, std::memory_order_release);
  }
  void commit(TraceRecord& r) noexcept;

 private:
  TraceBlock* block_;
  uint64_t generation_ = 0;
  uint32_t n_ = 0;
  TraceSource src_[kTraceChannels] = {};
};

// One record as a tool gets it.
struct TraceSample {
  uint64_t record = 0;  // its number in the ring (consecutive while one selection runs)
  uint64_t cycle = 0;
  int64_t release_ns = 0;
  double values[kTraceChannels] = {};
};

// A tool's side: drains one task's ring from a given record on.
class TraceReader {
 public:
  TraceReader(const TraceBlock* block, uint64_t first_record, uint32_t n)
      : block_(block), next_(first_record), n_(n) {}
  // Appends every record written since the last call to `out`; returns how
  // many. Records overwritten before they could be read are added to lost().
  size_t drain(std::vector<TraceSample>& out);
  uint64_t lost() const { return lost_; }
  uint64_t next_record() const { return next_; }
  // Records written and not read yet (what the tool is behind by).
  uint64_t behind() const;

 private:
  const TraceBlock* block_;
  uint64_t next_;
  uint32_t n_;
  uint64_t lost_ = 0;
};

// The control thread's side (runtime): publishes a selection and waits for
// the task to take it. Returns false when the previous request was not taken
// yet (then nothing was written).
bool request_trace(TraceBlock& block, const TraceSource* src, uint32_t n) noexcept;
// True once the task took the last request; `first_record` then says where its
// records start.
bool trace_applied(const TraceBlock& block, uint64_t* first_record = nullptr) noexcept;
// Touches every page of the block (the runtime, before a trace starts), so the
// task's first records fault no page in.
void prefault(TraceBlock& block) noexcept;

}  // namespace rtplc::io
