// The process image (spec runtime.md, "The process image"): one POSIX
// shared-memory object holding every channel's value, quality and timestamp, the
// channel table, and each task's timing statistics, so tools outside the runtime
// (`rtplc monitor`, `rtplc stats`, an HMI) can attach read-only and see it live.
//
// Layout (all offsets from the start of the mapping, 64-byte aligned):
//   ImageHeader | ChannelDesc[capacity] | RegionDesc[n_regions] | TaskStatsSlot[n_tasks]
//   | region rings... | TraceBlock[n_tasks] (io/trace_ring.h: what `rtplc trace` drains)
//
// Every value has exactly one writer. Values are grouped into *regions*, one per
// writer: each task's outputs, each driver's inputs, the set-points (written by
// the control thread). A region is a ring of kRingSlots snapshots.
//
// Exchange protocol (writer: the region's one thread; readers: anyone):
//   writer  begin_write(): slot k = (published + 1) % kRingSlots;
//                          k.version += 1 (odd: "being written"), an acq_rel
//                          read-modify-write, so no store after it moves before it
//           fills k's values, qualities and times (release stores; a task's
//           executor writes its outputs in place the same way)
//           end_write():   k.version += 1 (even, release); published = n + 1 (release)
//   reader  n = published (acquire); k = n % kRingSlots; v1 = k.version (acquire);
//           v1 != slot_version_after(n) -> retry; copy (acquire loads, so the
//           re-check below cannot move before them); v2 = k.version;
//           v1 != v2 -> retry
// If a load saw a store of a later write into slot k, that write's odd
// increment happens-before the re-check, which then differs: a torn copy is
// never accepted. Why v1 must be exactly slot_version_after(n) (each write adds
// 2, slot k is written once per lap, so that value names publication n): a
// reader that loaded n and was delayed could find slot k already rewritten
// whole with publication n + kRingSlots, its version even again, while the
// writer had not yet stored published = n + kRingSlots; it took the newer
// values, and its next load of `published` (still n + kRingSlots - 1) gave it
// older ones. Accepting only publication n, with read-read coherence on
// `published`, means one reader's values never go backwards. The writer never waits. A reader only ever reads the last
// *completed* slot, so a reader that preempts the writer (a SCHED_FIFO task
// preempting a driver on the same CPU, the case where a plain seqlock spins
// forever) reads a slot the writer is not touching; a retry is needed only if
// the writer completed kRingSlots-1 more snapshots during one copy. Readers on
// the RT path bound their retries and keep their previous values if they run
// out (counted, never blocking).
//
// Every value, quality and timestamp is an atomic access (std::atomic_ref on the
// plain arrays of the slot): release stores and acquire loads, each one plain
// move on x86-64 (stlr/ldar on AArch64), and no data race in C++ terms. There
// are no standalone fences, so ThreadSanitizer models this very code, the one
// that ships.
//
// The channel table grows while tools read it (a hot swap adds outputs): the
// runtime writes the new ChannelDesc, then stores n_channels with release;
// readers load n_channels with acquire and read only entries below it.
//
// Liveness: the runtime's heartbeat thread (its control thread before start)
// stores `heartbeat_ns` (CLOCK_MONOTONIC, relaxed: one word, read alone, one
// writer at a time) ten times a second, whatever the control thread is doing. A tool judges a runtime
// dead when its pid is gone, when that pid now belongs to another process (its
// start time differs from `owner_start_ticks`), or when the heartbeat is old.
//
// Forcing (spec runtime.md, "Forcing"): a force table beside the rings, one
// ForceRegion header per region and one ForceEntry per value of the region.
//   writer  the runtime's control thread only (rtplc force / unforce), never RT.
//           force:   entry.value_bits = v (release); entry.forced = 1 (release);
//                    region.n_forced += 1 (release)   [value first, then flag]
//           change:  entry.value_bits = v (release)   [already forced]
//           unforce: entry.forced = 0 (release); region.n_forced -= 1 (release)
//   reader  every region's writer, inside end_write() while its slot is odd:
//           n_forced (acquire) == 0 -> nothing to do (the cost of forcing in a
//           cycle where nothing is forced: one load). Else for each entry:
//           forced (acquire) == 1 -> value_bits (acquire) into the slot's value.
//           Tools read the same way (read_channel() says `forced`).
// Each word is one atomic access, so nothing is torn; the acquire on `forced`
// pairs with the release that followed the value store, so a reader that sees
// an entry forced also sees its value (that one or a later one). A reader may
// see a force or an unforce one snapshot late; it never sees a value nobody
// forced. Reader and writer never wait for each other: a task or driver that
// preempts the control thread mid-store reads two words and goes on (no retry
// loop at all, so no spinning on the same CPU). The writer is serialised (the
// control thread runs one request at a time), so its plain read-modify-write
// of n_forced is exact.
// What a forced entry means: the region's writer publishes the forced value
// in place of its own (a driver's input, a task's output), so every task that
// reads the input, every driver that sends the output and every tool sees it.
// end_write() stamps the slot's quality `forced` beside the forced value, in the
// same snapshot, so a reader never pairs a forced value with its source's
// quality (or a source value with `forced`). Every writer therefore puts every
// quality of its region in every snapshot: after an unforce the next snapshot
// carries the source's own again. A stopped task's safe values win: end_write()
// skips the forces of a snapshot whose region_state is 1 (outputs at their safe values).
#pragma once

#include <sys/types.h>

#include <atomic>
#include <bit>
#include <cstring>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "common/quality.h"
#include "common/result.h"
#include "io/link/handoff.h"
#include "io/trace_ring.h"

namespace rtplc::io {

inline constexpr char kProcessImageMagic[8] = {'R', 'T', 'P', 'L', 'C', 'S', 'H', 'M'};
inline constexpr uint32_t kProcessImageVersion = 9;  // 4: the force table; 5: per-task trace rings;
                                                    // 6: per-class delays of planned links;
                                                    // 7: ChannelDesc::max_age_ns;
                                                    // 8: ChannelDesc::on_bad, safe_value
                                                    // 9: ChannelDesc::users, LinkStatus::gauges, last_error
inline constexpr uint32_t kRingSlots = 4;
// The version slot n % kRingSlots holds once publication n >= 1 is complete:
// two per write, and that slot was written once per lap up to n.
inline constexpr uint64_t slot_version_after(uint64_t n) { return 2 * ((n - 1) / kRingSlots + 1); }
inline constexpr size_t kLabelBytes = 32;


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
  uint8_t has_delivery;     // outputs: a driver reports how their sending goes
  uint16_t delivery_region; // ... in this region (the driver's),
  uint32_t delivery_index;  // ... at this index: quality bad while it cannot send
  int64_t max_age_ns;       // inputs: a good value older than this is stale (judge_quality); 0 never
  uint8_t on_bad;           // outputs: config::OnBad, what drivers send while it is not good
  uint8_t hmi;              // 1: an HMI variable's channel (docs/st.md, "HMI variables")
  // Which tasks' programs use the channel: bit t for task t (at most 16 tasks).
  // Written by the runtime's control thread when a program starts, is swapped
  // in or rolled back (set_channel_users(), a release store); read by any
  // thread or tool with channel_users() (an acquire load). A reader that sees
  // the new bit set also sees the channel's description, which was complete
  // before. Readers group channels per task with it (the Sparkplug link's
  // devices); a mask read during a swap is the old one or the new one, and a
  // reader that needs the whole set consistent reads it again once the task's
  // swap count (TaskInfo::swaps) moves, which happens after the update.
  uint16_t users;
  uint8_t pad2[4];
  double safe_value;        // outputs: what `on_bad: safe` sends (the task's safe_outputs value)
};
static_assert(sizeof(ChannelDesc) == 120);

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
  std::atomic<uint32_t> n_channels;  // release by the runtime after the entry is written
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
  uint64_t owner_start_ticks;     // the runtime's process start time (/proc/PID/stat, field 22)
  std::atomic<int64_t> heartbeat_ns;           // CLOCK_MONOTONIC, a few times a second
  std::atomic<int64_t> heartbeat_realtime_ns;  // the same instant, CLOCK_REALTIME (for "died at")
  // The control socket this runtime listens on (runtime.socket may move it away
  // from the name's default): clients given only --name read it here. Written
  // once by the runtime before it starts any thread; "" = the default path.
  char socket_path[108];
  // The force table (see "Forcing" above): ForceRegion[n_regions] at
  // off_forces, each pointing at its region's ForceEntry[capacity].
  uint64_t off_forces;
  // Per-task trace rings (io/trace_ring.h), one TraceBlock per task; written
  // once at creation.
  uint64_t off_trace;
  uint32_t n_trace;               // TraceBlocks (= n_tasks)
  uint32_t trace_block_size;      // sizeof(TraceBlock) (sanity check for readers)
};

// Per region of the force table. One writer (the control thread).
struct alignas(64) ForceRegion {
  std::atomic<uint32_t> n_forced;  // entries of this region with forced == 1
  uint32_t capacity;               // = the region's capacity
  uint64_t entries_offset;         // ForceEntry[capacity] from the start of the mapping
};

struct ForceEntry {
  std::atomic<uint64_t> value_bits;  // the forced value, a double's bits
  std::atomic<uint32_t> forced;      // 1 while forced
  uint32_t pad;
};
static_assert(sizeof(ForceEntry) == 16);
static_assert(std::atomic<uint64_t>::is_always_lock_free && std::atomic<uint32_t>::is_always_lock_free,
              "the force table is shared memory: its atomics must be lock-free");

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
// The state of one link to a remote peer, whatever the driver's kind.
enum class LinkState : uint8_t {
  kUnused = 0,
  kDown = 1,        // not connected; reconnecting with backoff
  kConnecting = 2,  // dialling, or the protocol's handshake
  kUp = 3,          // exchanging data
};
const char* link_state_name(LinkState s);

inline constexpr size_t kLinkLatencyBuckets = 12;  // io/link/latency_buckets.h

inline constexpr size_t kLinkGauges = 6;  // LinkStatus::gauges
inline constexpr size_t kLinkClasses = 3;  // fieldbus/link_scheduler.h: periodic, urgent, non-RT

// One traffic class of a link that runs on a fieldbus plan (docs/fieldbus.md,
// "Running a link on a plan"): what was measured beside what the plan bounds.
// Same writer and readers as its LinkStatus; relaxed atomics, as there: each
// field is a counter or a maximum read on its own, no reader needs two of them
// to agree. The name is written once before the threads start ("" = unused).
struct LinkClassStatus {
  char name[16];                         // "periodic", "urgent", "non-RT"
  std::atomic<uint64_t> count;           // messages handed to the bus
  std::atomic<uint64_t> missed;          // windows missed (not sent in their T_1 frame)
  std::atomic<int64_t> delay_p99_ns;     // ready -> handed over
  std::atomic<int64_t> delay_max_ns;
  std::atomic<int64_t> delay_bound_ns;   // the plan's bound; 0: the plan claims none
  std::atomic<int64_t> packet_max_ns;    // longest packet sent (wire time)
  std::atomic<int64_t> packet_bound_ns;  // the plan's L_p, L_c, L_n
};

// A link's last error as the row keeps it.
struct LinkError {
  char text[120];
  int64_t at_ns;
};

// Per-link status of a driver that talks to remote peers (one per S7 PLC, per
// Modbus slave, ...): what `rtplc stats`, `monitor` and `status` show without
// knowing the kind. One writer (the driver's bridge thread); every field a
// reader uses after the runtime started is atomic (the texts are written once,
// before the threads start).
struct alignas(64) LinkStatus {
  char name[kLabelBytes];     // the peer's name in the config
  char driver[kLabelBytes];   // the driver's name
  char kind[16];              // the driver's kind ("s7")
  char peer[48];              // "10.0.0.11:102", "/dev/ttyUSB0 unit 7"
  std::atomic<uint8_t> state;    // LinkState
  std::atomic<uint8_t> quality;  // Quality of what it delivers now
  uint8_t pad[2];
  std::atomic<uint32_t> rtt_p50_us;
  std::atomic<uint32_t> rtt_p99_us;
  std::atomic<uint32_t> rtt_max_us;
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
  std::atomic<uint64_t> latency[kLinkLatencyBuckets];  // round trips per bucket
  char plan[64];  // "drive_plan.yaml: T1 5ms, gamma 4, Ln 585.714us"; "" = not planned (written before start)
  LinkClassStatus classes[kLinkClasses];
  // Figures of the kind's own beyond the common ones ("births", "seq",
  // "bdSeq", "queued" of a Sparkplug session), shown by name after the row.
  // Names written once before the threads start ("" = unused); the values by
  // the row's one writer, relaxed like the rest of the row.
  char gauge_names[kLinkGauges][12];
  std::atomic<uint64_t> gauges[kLinkGauges];
  // The link's last error, and when (CLOCK_MONOTONIC; 0: none yet). Its one
  // writer is the thread that meets the errors (the kind says which: the
  // Sparkplug link's I/O thread); readers anywhere. The slot is the lock-free
  // SnapshotSlot (io/link/handoff.h: a reader preempting the writer mid-store
  // on its CPU still reads the last whole text at once); all-zero memory is its
  // valid empty state, so the image needs no constructor for it.
  link::SnapshotSlot<LinkError> last_error;
};

// kStoppedWatchdog and kStoppedLoop: stopped by a fault, outputs at their safe
// values, the code not run until a swap restarts the task.
enum class TaskState : uint8_t {
  kStarting = 0,
  kRunning = 1,
  kStoppedWatchdog = 2,
  kStopped = 3,
  kStoppedLoop = 4,  // a loop ran past the task's loop budget in one cycle
};
inline bool stopped_by_fault(TaskState s) {
  return s == TaskState::kStoppedWatchdog || s == TaskState::kStoppedLoop;
}
const char* task_state_name(TaskState s);

// Atomic access to the plain arrays of a snapshot (see the protocol).
inline double load_value(const double* p) noexcept {
  return std::atomic_ref<const double>(*p).load(std::memory_order_acquire);
}
inline void store_value(double* p, double v) noexcept {
  std::atomic_ref<double>(*p).store(v, std::memory_order_release);
}

// What a reader gets for one channel.
struct ChannelValue {
  double value = 0;
  Quality quality = Quality::kBad;
  int64_t timestamp_ns = 0;  // CLOCK_MONOTONIC
  bool fresh = false;        // false when the snapshot could not be read consistently
  bool forced = false;       // an operator forced it (quality is then kForced unless delivery is worse)
};

// One forced channel, as the force table says.
struct ForcedValue {
  bool forced = false;
  double value = 0;
};

// Why a tool cannot trust an image: the runtime that wrote it is gone.
struct Liveness {
  bool alive = false;
  std::string why;            // "process 1234 is gone", "no heartbeat for 12 s", ...
  int64_t last_heartbeat_realtime_ns = 0;  // when it was last seen alive (0: never)
};

// A heartbeat older than this means the runtime is not running any more.
inline constexpr int64_t kHeartbeatTimeoutNs = 3000000000;

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
  uint32_t n_links = 0;         // LinkStatus entries (one per remote peer)
  // Who may read it: the owner only, or also this group (runtime.monitor_group).
  int monitor_gid = -1;         // -1: mode 0600; else 0640 with this group
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

  // Creates "/rtplc-<name>", mode 0600 (0640 for the monitor group). An object
  // of that name left behind (a runtime that died, or one planted by someone) is
  // removed first: whether another runtime of that name runs is decided by the
  // caller's lock (common/files.h FileLock), never by what an object says.
  static Result<ProcessImage> create(const ImageLayout& layout);
  // Attaches read-only to a running runtime's image. Refuses an object that
  // belongs neither to root nor to the caller: another local user could have
  // put it there to show made-up values.
  static Result<ProcessImage> attach(const std::string& name);
  static std::string shm_name(const std::string& name) { return "/rtplc-" + name; }

  bool valid() const { return base_ != nullptr; }
  bool writable() const { return writable_; }
  ImageHeader& header() const { return *reinterpret_cast<ImageHeader*>(base_); }
  ChannelDesc& channel(uint32_t i) const;
  uint32_t channel_count() const { return header().n_channels.load(std::memory_order_acquire); }
  RegionDesc& region(uint32_t r) const;
  uint32_t region_count() const { return header().n_regions; }
  TaskInfo& task_info(uint32_t task) const;
  LinkStatus& link(uint32_t i) const;
  uint32_t link_count() const { return header().n_links; }
  // The task's CycleStats block (task_stats_bytes, 64-byte aligned).
  void* task_stats(uint32_t task) const;
  // The task's trace ring (io/trace_ring.h); nullptr when the image has none.
  TraceBlock* trace_block(uint32_t task) const;

  // Whether the runtime that owns this image still runs (see "Liveness" above).
  Liveness liveness() const;
  // The runtime: stores the heartbeat (its heartbeat thread, ten times a second).
  void beat() const noexcept;

  // Appends a channel description (runtime, before start). Returns its index.
  Result<uint32_t> add_channel(const ChannelDesc& d);
  // Looks a channel up by label; -1 if none.
  int find_channel(const std::string& label) const;
  // The tasks using channel i (ChannelDesc::users): any thread.
  uint16_t channel_users(uint32_t i) const noexcept {
    return std::atomic_ref<uint16_t>(channel(i).users).load(std::memory_order_acquire);
  }
  // Control thread only.
  void set_channel_users(uint32_t i, uint16_t users) const noexcept {
    std::atomic_ref<uint16_t>(channel(i).users).store(users, std::memory_order_release);
  }

  // ---- the force table (see "Forcing" above) ----
  ForceRegion& force_region(uint32_t r) const;
  ForceEntry& force_entry(uint32_t r, uint32_t index) const;
  // Control thread only: forces value `index` of region r to v, or changes its forced value.
  void force(uint32_t r, uint32_t index, double v) const noexcept;
  // Control thread only: releases a force; false if it was not forced.
  bool unforce(uint32_t r, uint32_t index) const noexcept;
  // Any thread: whether value `index` of region r is forced, and to what.
  ForcedValue forced(uint32_t r, uint32_t index) const noexcept;
  // A region's writer (end_write does it): forced values into slot k.
  void apply_forces(uint32_t r, uint32_t k) const noexcept;

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
  // Reads `n` values of region r at `src` indices into scratch[0..n), and their
  // qualities into quality[0..n) when `quality` is not null, with at most
  // `max_tries` attempts. Returns true when scratch holds one consistent
  // snapshot; on false its contents are meaningless — callers copy from scratch
  // only on success, so their own values stay those of the last good read.
  // Used on the RT path with a small bound.
  // `times`, when not null, receives each value's timestamp (its snapshot's
  // time where the writer keeps none), for judge_quality.
  bool read_values(uint32_t r, const uint32_t* src, uint32_t n, double* scratch, uint32_t max_tries,
                   uint64_t* published_seen = nullptr, Quality* quality = nullptr,
                   int64_t* times = nullptr) const noexcept;

  const std::string& object_name() const { return object_; }

 private:
  ChannelValue read_at(uint32_t region, uint32_t index) const noexcept;
  void release();
  void* base_ = nullptr;
  size_t size_ = 0;
  bool writable_ = false;
  bool owner_ = false;  // unlink on destruction
  std::string object_;
};

// Seconds since a CLOCK_MONOTONIC timestamp.
double age_s(int64_t monotonic_ns);

// The one freshness rule: what a value stored with quality `stored` at
// `timestamp_ns` is worth at `now_ns` for a channel whose driver vouches for
// `max_age_ns` (ChannelDesc::max_age_ns). Every consumer judges through it —
// tasks (sched::read_group), drivers sending outputs, the monitor, stats and
// modbus-server — so a frozen peer, a starved line thread or a driver that
// stopped publishing makes a value stale within its age everywhere at once.
//   not a finite number          -> bad (unless forced: a force is finite by check)
//   good, older than max_age_ns  -> stale (max_age_ns 0: never by age)
//   otherwise                    -> as stored
// A timestamp of 0 (a writer that keeps none) is judged by its snapshot's time.
inline Quality judge_quality(Quality stored, double value, int64_t timestamp_ns, int64_t now_ns,
                             int64_t max_age_ns) noexcept {
  if (stored == Quality::kForced) return stored;
  const uint64_t bits = std::bit_cast<uint64_t>(value);
  if ((bits & 0x7FF0000000000000ull) == 0x7FF0000000000000ull) return Quality::kBad;
  if (stored == Quality::kGood && max_age_ns > 0 && now_ns - timestamp_ns > max_age_ns) return Quality::kStale;
  return stored;
}

}  // namespace rtplc::io
