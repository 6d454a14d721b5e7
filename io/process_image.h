// The process image (spec runtime.md, "The process image"): one POSIX
// shared-memory object holding every channel's value, quality and timestamp, the
// channel table, and each task's timing statistics, so tools outside the runtime
// (`rtplc monitor`, `rtplc stats`, an HMI) can attach read-only and see it live.
//
// Layout (all offsets from the start of the mapping, 64-byte aligned):
//   ImageHeader | ChannelDesc[capacity] | RegionDesc[n_regions] | TaskStatsSlot[n_tasks]
//   | region rings...
//
// Every value has exactly one writer. Values are grouped into *regions*, one per
// writer: each task's outputs, each driver's inputs, the set-points (written by
// the control thread). A region is a ring of kRingSlots snapshots.
//
// Exchange protocol (writer: the region's one thread; readers: anyone):
//   writer  begin_write(): slot k = (published + 1) % kRingSlots;
//                          k.version = odd (release)   — "being written"
//           fills k's values (plain stores: a task's executor writes them in place)
//           end_write():   k.version = even (release); published = n + 1 (release)
//   reader  n = published (acquire); k = n % kRingSlots; v1 = k.version (acquire);
//           odd -> retry; copy; fence(acquire); v2 = k.version; v1 != v2 -> retry
// The writer never waits. A reader only ever reads the last *completed* slot, so a
// reader that preempts the writer (a SCHED_FIFO task preempting a driver on the
// same CPU, the case where a plain seqlock spins forever) reads a slot the writer
// is not touching; a retry is needed only if the writer completed kRingSlots-1
// more snapshots during one copy. Readers on the RT path bound their retries and
// keep their previous values if they run out (counted, never blocking).
//
// Values are written with plain stores and read with relaxed atomic loads: every
// field is naturally aligned (no tearing of a single double on x86-64 or AArch64)
// and the version check discards any snapshot that changed during the copy.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "common/result.h"

namespace rtplc::io {

inline constexpr char kProcessImageMagic[8] = {'R', 'T', 'P', 'L', 'C', 'S', 'H', 'M'};
inline constexpr uint32_t kProcessImageVersion = 2;
inline constexpr uint32_t kRingSlots = 4;
inline constexpr size_t kLabelBytes = 32;

enum class Quality : uint8_t { kGood = 0, kStale = 1, kBad = 2, kForced = 3 };
const char* quality_name(Quality q);

enum class ChannelDir : uint8_t { kInput, kOutput, kSetpoint };
enum class RegionKind : uint8_t { kTask, kDriver, kSetpoints, kUnwired };

struct ChannelDesc {
  char label[kLabelBytes];  // NUL-terminated
  char key[40];             // binding_key(): "out/DIO/p0.d0.c0"
  uint8_t dir;              // ChannelDir
  uint8_t kind;             // rtplc::Kind: 0 analog, 1 digital
  uint16_t region;          // where its value lives
  uint32_t index;           // position inside the region
  double init;              // set-points: initial value
  uint8_t retain;           // set-points kept across restarts
  uint8_t pad[7];
};
static_assert(sizeof(ChannelDesc) == 96);

struct RegionDesc {
  char name[kLabelBytes];  // "task:loop1", "driver:plant", "setpoints"
  uint8_t kind;            // RegionKind
  uint8_t pad[3];
  uint32_t owner;          // task or driver index
  uint32_t capacity;       // values per snapshot
  uint32_t pad2;
  uint64_t ring_offset;    // RingHeader, then kRingSlots snapshots
  uint64_t slot_stride;    // bytes per snapshot
};
static_assert(sizeof(RegionDesc) == 64);

// Per-snapshot header; values[capacity], quality[capacity] and
// timestamp_ns[capacity] follow (quality/timestamps are per channel: an S7 value
// can be older than the snapshot holding it).
struct alignas(64) SlotHeader {
  std::atomic<uint64_t> version;     // odd while being written
  std::atomic<int64_t> written_ns;   // CLOCK_MONOTONIC when completed
  std::atomic<uint64_t> cycle;       // the writer's cycle counter
  std::atomic<uint8_t> region_state; // 0 running, 1 stopped (outputs at safe values)
};

struct alignas(64) RingHeader {
  std::atomic<uint64_t> published;  // number of completed snapshots; latest = published % kRingSlots
};

struct alignas(64) ImageHeader {
  char magic[8];
  uint32_t version;
  uint32_t header_size;
  uint64_t total_size;
  uint64_t layout_hash;
  int32_t pid;                    // the runtime's pid (stale image detection)
  uint32_t n_channels;
  uint32_t channel_capacity;
  uint32_t n_regions;
  uint32_t n_tasks;
  uint32_t task_stats_size;       // bytes per TaskStatsSlot (sanity check for readers)
  uint64_t off_channels;
  uint64_t off_regions;
  uint64_t off_tasks;
  uint32_t n_links;
  uint32_t pad_links;
  uint64_t off_links;
  int64_t started_realtime_ns;
  std::atomic<uint32_t> state;    // 0 starting, 1 running, 2 stopped
  char name[kLabelBytes];
};

// Per-task header in the image, followed by the task's timing statistics
// (sched/jitter.h, CycleStats). Written by the runtime and the task thread.
struct alignas(64) TaskInfo {
  char name[kLabelBytes];
  char program[96];
  int64_t period_ns;
  int32_t priority;         // SCHED_FIFO priority obtained, 0 for SCHED_OTHER
  int32_t cpu;              // -1 = not pinned
  uint32_t n_blocks;
  uint8_t fifo;             // 1 when the thread really runs SCHED_FIFO
  std::atomic<uint8_t> state;          // TaskState
  uint8_t pad[2];
  std::atomic<uint64_t> block_errors;  // sum of the blocks' error counters
  std::atomic<uint64_t> swaps;         // code replacements applied
  std::atomic<uint64_t> input_misses;  // input snapshots not read consistently (kept old values)
  std::atomic<int64_t> last_swap_ns;   // CLOCK_MONOTONIC of the last applied swap
  std::atomic<uint64_t> minor_faults;  // only counted in fault-check mode
  std::atomic<uint64_t> swap_overruns; // overruns of cycles that applied a swap (goal: 0)
};
// Per-link status of a driver that talks to remote peers (one per S7 PLC): what
// `rtplc monitor` and `rtplc status` show. One writer (the driver's thread);
// every field a reader uses is atomic.
struct alignas(64) LinkStatus {
  char name[kLabelBytes];     // the PLC's name
  char driver[kLabelBytes];   // the driver's name
  char address[48];           // "10.0.0.11:102"
  std::atomic<uint8_t> state; // driver-specific; for S7: s7::PlcState
  uint8_t pad[1];
  std::atomic<uint16_t> pdu;
  std::atomic<uint16_t> amq;
  uint16_t pad2;
  std::atomic<uint32_t> rtt_p50_us;
  std::atomic<uint32_t> rtt_p99_us;
  std::atomic<uint64_t> connects;
  std::atomic<uint64_t> reconnects;
  std::atomic<uint64_t> timeouts;
  std::atomic<uint64_t> errors;
  std::atomic<uint64_t> polls_completed;
  std::atomic<uint64_t> polls_missed;
  std::atomic<uint64_t> polls_offline;
  std::atomic<uint64_t> writes_acked;
  std::atomic<uint64_t> writes_failed;
  std::atomic<uint64_t> writes_pending;
  std::atomic<uint64_t> writes_rejected;
};

enum class TaskState : uint8_t { kStarting = 0, kRunning = 1, kStoppedWatchdog = 2, kStopped = 3 };
const char* task_state_name(TaskState s);

// Access to the plain data of a snapshot (see the protocol above). Normal builds
// order data against the version with fences and move the data relaxed. Under
// ThreadSanitizer, which does not model standalone fences, the data accesses
// themselves carry the ordering instead: release stores after the odd version,
// acquire loads before the closing version check. Same guarantee, either way.
#if defined(__SANITIZE_THREAD__)
#define RTPLC_IMAGE_TSAN 1
inline double load_relaxed(const double* p) noexcept {
  double v;
  __atomic_load(p, &v, __ATOMIC_ACQUIRE);
  return v;
}
inline void store_relaxed(double* p, double v) noexcept { __atomic_store(p, &v, __ATOMIC_RELEASE); }
inline void writer_fence() noexcept {}
inline void reader_fence() noexcept {}
#else
#define RTPLC_IMAGE_TSAN 0
inline double load_relaxed(const double* p) noexcept {
  double v;
  __atomic_load(p, &v, __ATOMIC_RELAXED);
  return v;
}
inline void store_relaxed(double* p, double v) noexcept { __atomic_store(p, &v, __ATOMIC_RELAXED); }
inline void writer_fence() noexcept { std::atomic_thread_fence(std::memory_order_release); }
inline void reader_fence() noexcept { std::atomic_thread_fence(std::memory_order_acquire); }
#endif
// True when a task may let its executor write outputs straight into its slot;
// under ThreadSanitizer it copies them with the ordered stores above instead.
inline constexpr bool kZeroCopyOutputs = RTPLC_IMAGE_TSAN == 0;

// What a reader gets for one channel.
struct ChannelValue {
  double value = 0;
  Quality quality = Quality::kBad;
  int64_t timestamp_ns = 0;  // CLOCK_MONOTONIC
  bool fresh = false;        // false when the snapshot could not be read consistently
};

// Sizes the image is created with.
struct ImageLayout {
  std::string name;  // shm object is "/rtplc-" + name
  uint32_t channel_capacity = 0;
  struct Region {
    std::string name;
    RegionKind kind;
    uint32_t owner;
    uint32_t capacity;
  };
  std::vector<Region> regions;
  uint32_t n_tasks = 0;
  size_t task_stats_bytes = 0;  // one opaque stats block per task (sched/jitter.h)
  uint32_t n_links = 0;         // LinkStatus entries (S7 PLCs)
};

// A mapping of the process image: created (read-write) by the runtime, attached
// read-only by tools.
class ProcessImage {
 public:
  ProcessImage() = default;
  ProcessImage(ProcessImage&&) noexcept;
  ProcessImage& operator=(ProcessImage&&) noexcept;
  ProcessImage(const ProcessImage&) = delete;
  ProcessImage& operator=(const ProcessImage&) = delete;
  ~ProcessImage();

  // Creates "/rtplc-<name>", replacing a stale one left by a dead runtime; refuses
  // when a live runtime owns it. Mode 0644: readable by tools, writable by us.
  static Result<ProcessImage> create(const ImageLayout& layout);
  // Attaches read-only to a running runtime's image.
  static Result<ProcessImage> attach(const std::string& name);
  static std::string shm_name(const std::string& name) { return "/rtplc-" + name; }

  bool valid() const { return base_ != nullptr; }
  bool writable() const { return writable_; }
  ImageHeader& header() const { return *reinterpret_cast<ImageHeader*>(base_); }
  ChannelDesc& channel(uint32_t i) const;
  uint32_t channel_count() const { return header().n_channels; }
  RegionDesc& region(uint32_t r) const;
  uint32_t region_count() const { return header().n_regions; }
  TaskInfo& task_info(uint32_t task) const;
  LinkStatus& link(uint32_t i) const;
  uint32_t link_count() const { return header().n_links; }
  // The task's CycleStats block (task_stats_bytes, 64-byte aligned).
  void* task_stats(uint32_t task) const;

  // Appends a channel description (runtime, before start). Returns its index.
  Result<uint32_t> add_channel(const ChannelDesc& d);
  // Looks a channel up by label; -1 if none.
  int find_channel(const std::string& label) const;

  // ---- ring access ----
  RingHeader& ring(uint32_t r) const;
  SlotHeader& slot(uint32_t r, uint32_t k) const;
  double* values(uint32_t r, uint32_t k) const;
  uint8_t* quality(uint32_t r, uint32_t k) const;
  int64_t* timestamps(uint32_t r, uint32_t k) const;

  // Writer side: the slot to fill next, one channel's value, quality and time
  // into it, and its publication.
  uint32_t begin_write(uint32_t r) const noexcept;
  void put(uint32_t r, uint32_t k, uint32_t index, double value, Quality q, int64_t timestamp_ns) const noexcept;
  void end_write(uint32_t r, uint32_t k, int64_t now_ns, uint64_t cycle) const noexcept;

  // Reader side: reads one channel consistently (unbounded retries: for tools).
  ChannelValue read_channel(uint32_t channel) const noexcept;
  // Reads `n` values of region r at `src` indices into `dst` positions, with at most
  // `max_tries` attempts. Returns false (and leaves dst unchanged) if no
  // consistent snapshot was obtained. Used on the RT path with a small bound.
  bool read_values(uint32_t r, const uint32_t* src, const uint32_t* dst, uint32_t n, double* out,
                   uint32_t max_tries, uint64_t* published_seen = nullptr) const noexcept;

  const std::string& object_name() const { return object_; }

 private:
  void release();
  void* base_ = nullptr;
  size_t size_ = 0;
  bool writable_ = false;
  bool owner_ = false;  // unlink on destruction
  std::string object_;
};

// Seconds since a CLOCK_MONOTONIC timestamp.
double age_s(int64_t monotonic_ns);

}  // namespace rtplc::io
