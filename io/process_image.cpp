// Creation, attachment and the exchange protocol of the process image (see
// process_image.h for the layout and the protocol).
#include "io/process_image.h"

#include <fcntl.h>
#include <grp.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <bit>
#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "kernel_rt/clock.h"

namespace rtplc::io {
namespace {

constexpr uint64_t align64(uint64_t n) { return (n + 63) & ~uint64_t{63}; }

uint64_t slot_stride(uint32_t capacity) {
  return align64(sizeof(SlotHeader) + uint64_t{capacity} * (8 + 8) + align64(capacity));
}

uint64_t task_block_size(size_t stats_bytes) {
  return align64(sizeof(TaskInfo)) + align64(stats_bytes);
}

std::string errno_text(int e) { return std::strerror(e); }

bool pid_alive(pid_t pid) { return pid > 0 && (kill(pid, 0) == 0 || errno == EPERM); }

// Field 22 of /proc/PID/stat: when the process started, in clock ticks since
// boot. With the pid it names one process for the life of the machine: a pid
// reused by another process after the runtime died has another start time.
uint64_t process_start_ticks(pid_t pid) {
  const std::string path = "/proc/" + std::to_string(pid) + "/stat";
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 0;
  char buf[1024];
  const ssize_t n = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  if (n <= 0) return 0;
  buf[n] = '\0';
  // The command name (field 2) is in parentheses and may hold spaces: count
  // fields from the last ')'.
  const char* p = std::strrchr(buf, ')');
  if (p == nullptr) return 0;
  int field = 2;
  while (*p != '\0' && field < 22) {
    if (*p == ' ') ++field;
    ++p;
  }
  return field == 22 ? std::strtoull(p, nullptr, 10) : 0;
}

using kernel_rt::realtime_now_ns;

}  // namespace

const char* link_state_name(LinkState s) {
  switch (s) {
    case LinkState::kUnused: return "unused";
    case LinkState::kDown: return "down";
    case LinkState::kConnecting: return "connecting";
    case LinkState::kUp: return "up";
  }
  return "?";
}

const char* task_state_name(TaskState s) {
  switch (s) {
    case TaskState::kStarting: return "starting";
    case TaskState::kRunning: return "running";
    case TaskState::kStoppedWatchdog: return "STOPPED (watchdog)";
    case TaskState::kStopped: return "stopped";
    case TaskState::kStoppedLoop: return "STOPPED (runaway loop)";
  }
  return "?";
}

double age_s(int64_t monotonic_ns) {
  return static_cast<double>(kernel_rt::monotonic_now_ns() - monotonic_ns) / 1e9;
}

ProcessImage::ProcessImage(ProcessImage&& o) noexcept { *this = std::move(o); }

ProcessImage& ProcessImage::operator=(ProcessImage&& o) noexcept {
  if (this != &o) {
    release();
    base_ = o.base_;
    size_ = o.size_;
    writable_ = o.writable_;
    owner_ = o.owner_;
    object_ = std::move(o.object_);
    o.base_ = nullptr;
    o.size_ = 0;
    o.owner_ = false;
  }
  return *this;
}

ProcessImage::~ProcessImage() { release(); }

void ProcessImage::release() {
  if (base_ != nullptr) {
    if (owner_) header().state.store(2, std::memory_order_release);
    munmap(base_, size_);
    if (owner_) shm_unlink(object_.c_str());
  }
  base_ = nullptr;
  size_ = 0;
  owner_ = false;
}

Result<ProcessImage> ProcessImage::create(const ImageLayout& layout) {
  if (layout.name.empty() || layout.name.size() >= kLabelBytes) {
    return make_error("process image name must have 1 to 31 characters");
  }
  // Layout.
  const uint64_t off_channels = align64(sizeof(ImageHeader));
  const uint64_t off_regions = off_channels + align64(uint64_t{layout.channel_capacity} * sizeof(ChannelDesc));
  const uint64_t off_tasks = off_regions + align64(layout.regions.size() * sizeof(RegionDesc));
  const uint64_t task_bytes = task_block_size(layout.task_stats_bytes);
  const uint64_t off_links = off_tasks + layout.n_tasks * task_bytes;
  uint64_t off = off_links + align64(uint64_t{layout.n_links} * sizeof(LinkStatus));
  std::vector<uint64_t> ring_off;
  for (const auto& r : layout.regions) {
    ring_off.push_back(off);
    off += align64(sizeof(RingHeader)) + kRingSlots * slot_stride(r.capacity);
  }
  // The force table, then the trace rings, last, so the layout before them is
  // what it was without them.
  const uint64_t off_forces = align64(off);
  off = off_forces + layout.regions.size() * sizeof(ForceRegion);
  std::vector<uint64_t> force_off;
  for (const auto& r : layout.regions) {
    off = align64(off);
    force_off.push_back(off);
    off += uint64_t{r.capacity} * sizeof(ForceEntry);
  }
  const uint64_t off_trace = align64(off);
  const uint64_t total = align64(off_trace + uint64_t{layout.n_tasks} * sizeof(TraceBlock));

  ProcessImage img;
  img.object_ = shm_name(layout.name);
  const mode_t mode = layout.monitor_gid >= 0 ? 0640 : 0600;
  int fd = shm_open(img.object_.c_str(), O_RDWR | O_CREAT | O_EXCL, mode);
  if (fd < 0 && errno == EEXIST) {
    // Left by a runtime that died (kill -9, power loss), or planted. The caller
    // holds the runtime's lock, so no live runtime of this name uses it.
    if (shm_unlink(img.object_.c_str()) != 0) {
      struct stat st {};
      const int probe = shm_open(img.object_.c_str(), O_RDONLY, 0);
      const bool known = probe >= 0 && fstat(probe, &st) == 0;
      if (probe >= 0) close(probe);
      return make_error("cannot replace the shared memory " + img.object_ + " left there" +
                        (known ? " by uid " + std::to_string(st.st_uid) : std::string()) + ": " +
                        errno_text(errno) + "; remove /dev/shm" + img.object_ +
                        " as its owner or root, or choose another runtime name");
    }
    fd = shm_open(img.object_.c_str(), O_RDWR | O_CREAT | O_EXCL, mode);
  }
  if (fd < 0) {
    return make_error("cannot create shared memory " + img.object_ + ": " + errno_text(errno));
  }
  // Whatever the umask: exactly the owner, plus the monitor group when there is one.
  if (layout.monitor_gid >= 0 && fchown(fd, static_cast<uid_t>(-1), static_cast<gid_t>(layout.monitor_gid)) != 0) {
    const int e = errno;
    close(fd);
    shm_unlink(img.object_.c_str());
    const group* g = getgrgid(static_cast<gid_t>(layout.monitor_gid));
    const std::string gname = g != nullptr ? g->gr_name : std::to_string(layout.monitor_gid);
    return make_error("cannot give " + img.object_ + " to group " + gname + " (runtime.monitor_group): " +
                      errno_text(e) +
                      (e == EPERM ? "; a runtime that is not root may only share its image with a group it is a "
                                    "member of: usermod -aG " + gname + " USER, then log in again"
                                  : std::string()));
  }
  fchmod(fd, mode);
  if (ftruncate(fd, static_cast<off_t>(total)) != 0) {
    const int e = errno;
    close(fd);
    shm_unlink(img.object_.c_str());
    return make_error("cannot size shared memory " + img.object_ + " to " + std::to_string(total) +
                      " bytes: " + errno_text(e));
  }
  void* base = mmap(nullptr, total, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  close(fd);
  if (base == MAP_FAILED) {
    shm_unlink(img.object_.c_str());
    return make_error("cannot map " + img.object_ + ": " + errno_text(errno));
  }
  img.base_ = base;
  img.size_ = total;
  img.writable_ = true;
  img.owner_ = true;
  // Also faults every page in before RT starts. The trace rings are left as
  // ftruncate made them (zero): their pages are touched when a trace starts
  // (io/trace_ring.h, prefault), so a runtime nobody traces does not hold them
  // (unless mlockall, with lock_memory, makes every mapped page resident).
  std::memset(base, 0, off_trace);

  ImageHeader& h = img.header();
  std::memcpy(h.magic, kProcessImageMagic, sizeof h.magic);
  h.version = kProcessImageVersion;
  h.header_size = sizeof(ImageHeader);
  h.total_size = total;
  h.pid = getpid();
  h.owner_start_ticks = process_start_ticks(getpid());
  h.channel_capacity = layout.channel_capacity;
  h.n_regions = static_cast<uint32_t>(layout.regions.size());
  h.n_tasks = layout.n_tasks;
  h.task_stats_size = static_cast<uint32_t>(layout.task_stats_bytes);
  h.off_channels = off_channels;
  h.off_regions = off_regions;
  h.off_tasks = off_tasks;
  h.n_links = layout.n_links;
  h.off_links = off_links;
  h.started_realtime_ns = realtime_now_ns();
  h.off_trace = off_trace;
  h.n_trace = layout.n_tasks;
  h.trace_block_size = sizeof(TraceBlock);
  img.beat();
  std::strncpy(h.name, layout.name.c_str(), kLabelBytes - 1);
  uint64_t hash = 1469598103934665603ull;
  for (size_t i = 0; i < layout.regions.size(); ++i) {
    RegionDesc& rd = img.region(static_cast<uint32_t>(i));
    std::strncpy(rd.name, layout.regions[i].name.c_str(), kLabelBytes - 1);
    rd.kind = static_cast<uint8_t>(layout.regions[i].kind);
    rd.owner = layout.regions[i].owner;
    rd.capacity = layout.regions[i].capacity;
    rd.ring_offset = ring_off[i];
    rd.slot_stride = slot_stride(rd.capacity);
    hash = (hash ^ rd.capacity) * 1099511628211ull;
  }
  h.off_forces = off_forces;
  for (size_t i = 0; i < layout.regions.size(); ++i) {
    ForceRegion& fr = img.force_region(static_cast<uint32_t>(i));
    fr.capacity = layout.regions[i].capacity;
    fr.entries_offset = force_off[i];
  }
  h.layout_hash = hash;
  return img;
}

Result<ProcessImage> ProcessImage::attach(const std::string& name) {
  ProcessImage img;
  img.object_ = shm_name(name);
  const int fd = shm_open(img.object_.c_str(), O_RDONLY, 0);
  if (fd < 0 && errno == EACCES) {
    return make_error("the image of runtime '" + name + "' (" + img.object_ +
                      ") is readable by its owner only; run this as that user, or set "
                      "runtime.monitor_group in its config and join that group");
  }
  if (fd < 0) {
    return make_error("no runtime named '" + name + "' is running (" + img.object_ + ": " +
                      errno_text(errno) + "); start one with `rtplc run CONFIG`");
  }
  struct stat st {};
  if (fstat(fd, &st) != 0 || st.st_size < static_cast<off_t>(sizeof(ImageHeader))) {
    close(fd);
    return make_error(img.object_ + " is too small to be a process image");
  }
  // Another user's image is trusted only as that user shared it on purpose:
  // mode 0640 with a group we are in (runtime.monitor_group), so a runtime
  // that is not root can still be watched by its operators.
  auto shared_with_us = [&st] {
    if ((st.st_mode & 0777) != 0640) return false;
    if (st.st_gid == getegid()) return true;
    gid_t groups[256];
    const int n = getgroups(256, groups);
    for (int i = 0; i < n; ++i) {
      if (groups[i] == st.st_gid) return true;
    }
    return false;
  };
  if (st.st_uid != 0 && st.st_uid != geteuid() && !shared_with_us()) {
    close(fd);
    return make_error("refusing " + img.object_ + ": it belongs to uid " + std::to_string(st.st_uid) +
                      ", neither root nor you (uid " + std::to_string(geteuid()) +
                      ") and is not shared with a group of yours (runtime.monitor_group): it is not a "
                      "runtime you started, and what it shows cannot be trusted");
  }
  const auto size = static_cast<size_t>(st.st_size);
  void* base = mmap(nullptr, size, PROT_READ, MAP_SHARED, fd, 0);
  close(fd);
  if (base == MAP_FAILED) return make_error("cannot map " + img.object_ + ": " + errno_text(errno));
  img.base_ = base;
  img.size_ = size;
  const ImageHeader& h = img.header();
  // A reader trusts nothing it has not checked: every table must lie inside the mapping.
  const bool ok = std::memcmp(h.magic, kProcessImageMagic, 8) == 0 &&
                  h.version == kProcessImageVersion && h.total_size == size &&
                  h.n_channels.load(std::memory_order_acquire) <= h.channel_capacity &&
                  h.off_channels + uint64_t{h.channel_capacity} * sizeof(ChannelDesc) <= size &&
                  h.off_regions + uint64_t{h.n_regions} * sizeof(RegionDesc) <= size &&
                  h.off_tasks + uint64_t{h.n_tasks} * task_block_size(h.task_stats_size) <= size &&
                  h.off_links % 64 == 0 && h.off_links + uint64_t{h.n_links} * sizeof(LinkStatus) <= size &&
                  h.off_trace % 64 == 0 && h.trace_block_size == sizeof(TraceBlock) &&
                  h.off_trace + uint64_t{h.n_trace} * sizeof(TraceBlock) <= size;
  if (!ok) return make_error(img.object_ + " is not a process image this rtplc understands");
  for (uint32_t r = 0; r < h.n_regions; ++r) {
    const RegionDesc& rd = img.region(r);
    if (rd.slot_stride != slot_stride(rd.capacity) ||
        rd.ring_offset + align64(sizeof(RingHeader)) + kRingSlots * rd.slot_stride > size) {
      return make_error(img.object_ + ": region table is inconsistent");
    }
  }
  if (h.off_forces % 64 != 0 || h.off_forces + uint64_t{h.n_regions} * sizeof(ForceRegion) > size) {
    return make_error(img.object_ + ": force table is inconsistent");
  }
  for (uint32_t r = 0; r < h.n_regions; ++r) {
    const ForceRegion& fr = img.force_region(r);
    if (fr.capacity != img.region(r).capacity || fr.entries_offset % 16 != 0 ||
        fr.entries_offset + uint64_t{fr.capacity} * sizeof(ForceEntry) > size) {
      return make_error(img.object_ + ": force table is inconsistent");
    }
  }
  for (uint32_t c = 0; c < img.channel_count(); ++c) {
    const ChannelDesc& cd = img.channel(c);
    if (cd.region >= h.n_regions || cd.index >= img.region(cd.region).capacity) {
      return make_error(img.object_ + ": channel table is inconsistent");
    }
  }
  return img;
}

ChannelDesc& ProcessImage::channel(uint32_t i) const {
  return reinterpret_cast<ChannelDesc*>(static_cast<char*>(base_) + header().off_channels)[i];
}

RegionDesc& ProcessImage::region(uint32_t r) const {
  return reinterpret_cast<RegionDesc*>(static_cast<char*>(base_) + header().off_regions)[r];
}

TaskInfo& ProcessImage::task_info(uint32_t task) const {
  return *reinterpret_cast<TaskInfo*>(static_cast<char*>(base_) + header().off_tasks +
                                      task * task_block_size(header().task_stats_size));
}

LinkStatus& ProcessImage::link(uint32_t i) const {
  return reinterpret_cast<LinkStatus*>(static_cast<char*>(base_) + header().off_links)[i];
}

void* ProcessImage::task_stats(uint32_t task) const {
  return reinterpret_cast<char*>(&task_info(task)) + align64(sizeof(TaskInfo));
}

TraceBlock* ProcessImage::trace_block(uint32_t task) const {
  if (task >= header().n_trace) return nullptr;
  return reinterpret_cast<TraceBlock*>(static_cast<char*>(base_) + header().off_trace) + task;
}

Result<uint32_t> ProcessImage::add_channel(const ChannelDesc& d) {
  ImageHeader& h = header();
  // Only the runtime's control thread adds channels: a relaxed load is exact.
  const uint32_t n = h.n_channels.load(std::memory_order_relaxed);
  if (n >= h.channel_capacity) return make_error("process image channel table is full");
  channel(n) = d;
  h.n_channels.store(n + 1, std::memory_order_release);  // publishes the entry (see the header)
  return n;
}

void ProcessImage::beat() const noexcept {
  header().heartbeat_ns.store(kernel_rt::monotonic_now_ns(), std::memory_order_relaxed);
  header().heartbeat_realtime_ns.store(realtime_now_ns(), std::memory_order_relaxed);
}

Liveness ProcessImage::liveness() const {
  Liveness l;
  const ImageHeader& h = header();
  l.last_heartbeat_realtime_ns = h.heartbeat_realtime_ns.load(std::memory_order_relaxed);
  if (h.state.load(std::memory_order_acquire) == 2) {
    l.why = "it stopped";
    return l;
  }
  if (!pid_alive(h.pid)) {
    l.why = "process " + std::to_string(h.pid) + " is gone";
    return l;
  }
  const uint64_t ticks = process_start_ticks(h.pid);
  if (ticks != 0 && h.owner_start_ticks != 0 && ticks != h.owner_start_ticks) {
    l.why = "process " + std::to_string(h.pid) + " is another program now";
    return l;
  }
  const int64_t age = kernel_rt::monotonic_now_ns() - h.heartbeat_ns.load(std::memory_order_relaxed);
  if (age > kHeartbeatTimeoutNs) {
    l.why = "no heartbeat for " + std::to_string(age / 1000000000) + " s (process " +
            std::to_string(h.pid) + " hangs or is stopped)";
    return l;
  }
  l.alive = true;
  return l;
}

int ProcessImage::find_channel(const std::string& label) const {
  for (uint32_t i = 0; i < channel_count(); ++i) {
    if (std::strncmp(channel(i).label, label.c_str(), kLabelBytes) == 0) return static_cast<int>(i);
  }
  return -1;
}

RingHeader& ProcessImage::ring(uint32_t r) const {
  return *reinterpret_cast<RingHeader*>(static_cast<char*>(base_) + region(r).ring_offset);
}

SlotHeader& ProcessImage::slot(uint32_t r, uint32_t k) const {
  const RegionDesc& rd = region(r);
  return *reinterpret_cast<SlotHeader*>(static_cast<char*>(base_) + rd.ring_offset +
                                        align64(sizeof(RingHeader)) + k * rd.slot_stride);
}

double* ProcessImage::values(uint32_t r, uint32_t k) const {
  return reinterpret_cast<double*>(reinterpret_cast<char*>(&slot(r, k)) + sizeof(SlotHeader));
}

int64_t* ProcessImage::timestamps(uint32_t r, uint32_t k) const {
  return reinterpret_cast<int64_t*>(values(r, k) + region(r).capacity);
}

uint8_t* ProcessImage::quality(uint32_t r, uint32_t k) const {
  return reinterpret_cast<uint8_t*>(timestamps(r, k) + region(r).capacity);
}

uint32_t ProcessImage::begin_write(uint32_t r) const noexcept {
  // Only this region's writer changes `published`, so a relaxed read is exact.
  const uint64_t next = ring(r).published.load(std::memory_order_relaxed) + 1;
  const uint32_t k = static_cast<uint32_t>(next % kRingSlots);
  // Odd: being written. The acq_rel read-modify-write keeps the stores that
  // follow after it (see the protocol in process_image.h).
  slot(r, k).version.fetch_add(1, std::memory_order_acq_rel);
  return k;
}

void ProcessImage::put(uint32_t r, uint32_t k, uint32_t index, double value, Quality q,
                       int64_t timestamp_ns) const noexcept {
  store_value(values(r, k) + index, value);
  std::atomic_ref<uint8_t>(quality(r, k)[index]).store(static_cast<uint8_t>(q), std::memory_order_release);
  std::atomic_ref<int64_t>(timestamps(r, k)[index]).store(timestamp_ns, std::memory_order_release);
}

ForceRegion& ProcessImage::force_region(uint32_t r) const {
  return reinterpret_cast<ForceRegion*>(static_cast<char*>(base_) + header().off_forces)[r];
}

ForceEntry& ProcessImage::force_entry(uint32_t r, uint32_t index) const {
  return reinterpret_cast<ForceEntry*>(static_cast<char*>(base_) + force_region(r).entries_offset)[index];
}

void ProcessImage::force(uint32_t r, uint32_t index, double v) const noexcept {
  ForceEntry& e = force_entry(r, index);
  // Value first, flag second (see "Forcing" in the header): a reader that sees
  // the flag sees this value or a later one.
  e.value_bits.store(std::bit_cast<uint64_t>(v), std::memory_order_release);
  if (e.forced.load(std::memory_order_relaxed) == 1) return;  // only the control thread writes it
  e.forced.store(1, std::memory_order_release);
  ForceRegion& fr = force_region(r);
  fr.n_forced.store(fr.n_forced.load(std::memory_order_relaxed) + 1, std::memory_order_release);
}

bool ProcessImage::unforce(uint32_t r, uint32_t index) const noexcept {
  ForceEntry& e = force_entry(r, index);
  if (e.forced.load(std::memory_order_relaxed) == 0) return false;
  e.forced.store(0, std::memory_order_release);
  ForceRegion& fr = force_region(r);
  fr.n_forced.store(fr.n_forced.load(std::memory_order_relaxed) - 1, std::memory_order_release);
  return true;
}

ForcedValue ProcessImage::forced(uint32_t r, uint32_t index) const noexcept {
  ForcedValue f;
  const ForceEntry& e = force_entry(r, index);
  f.forced = e.forced.load(std::memory_order_acquire) == 1;
  if (f.forced) f.value = std::bit_cast<double>(e.value_bits.load(std::memory_order_acquire));
  return f;
}

void ProcessImage::apply_forces(uint32_t r, uint32_t k) const noexcept {
  const ForceRegion& fr = force_region(r);
  // The one check a cycle pays when nothing of its region is forced.
  if (fr.n_forced.load(std::memory_order_acquire) == 0) return;
  const ForceEntry* e = reinterpret_cast<const ForceEntry*>(static_cast<const char*>(base_) + fr.entries_offset);
  double* vals = values(r, k);
  uint8_t* q = quality(r, k);
  for (uint32_t i = 0; i < fr.capacity; ++i) {
    if (e[i].forced.load(std::memory_order_acquire) != 1) continue;
    store_value(vals + i, std::bit_cast<double>(e[i].value_bits.load(std::memory_order_acquire)));
    // The status travels in the same snapshot as the value: no reader can pair
    // a forced value with its source's quality, or the source's with `forced`.
    std::atomic_ref<uint8_t>(q[i]).store(static_cast<uint8_t>(Quality::kForced), std::memory_order_release);
  }
}

void ProcessImage::end_write(uint32_t r, uint32_t k, int64_t now_ns, uint64_t cycle) const noexcept {
  SlotHeader& s = slot(r, k);
  // Forced values replace the writer's own while the slot is still odd, so
  // they are part of the snapshot; safe values (a stopped task) are never forced.
  if (s.region_state.load(std::memory_order_relaxed) == 0) apply_forces(r, k);
  s.written_ns.store(now_ns, std::memory_order_relaxed);
  s.cycle.store(cycle, std::memory_order_relaxed);
  s.version.store(s.version.load(std::memory_order_relaxed) + 1, std::memory_order_release);
  RingHeader& ring_h = ring(r);
  ring_h.published.store(ring_h.published.load(std::memory_order_relaxed) + 1,
                         std::memory_order_release);
}

bool ProcessImage::read_values(uint32_t r, const uint32_t* src, uint32_t n, double* scratch,
                               uint32_t max_tries, uint64_t* published_seen,
                               Quality* quality_out, int64_t* times) const noexcept {
  for (uint32_t t = 0; t < max_tries; ++t) {
    const uint64_t pub = ring(r).published.load(std::memory_order_acquire);
    if (pub == 0) return false;  // nothing written yet
    const auto k = static_cast<uint32_t>(pub % kRingSlots);
    const SlotHeader& s = slot(r, k);
    const uint64_t v1 = s.version.load(std::memory_order_acquire);
    if (v1 != slot_version_after(pub)) continue;  // being written, or already a later publication
    const double* vals = values(r, k);
    for (uint32_t i = 0; i < n; ++i) scratch[i] = load_value(vals + src[i]);
    if (quality_out != nullptr) {
      uint8_t* q = quality(r, k);
      for (uint32_t i = 0; i < n; ++i) {
        quality_out[i] = static_cast<Quality>(std::atomic_ref<uint8_t>(q[src[i]]).load(std::memory_order_acquire));
      }
    }
    if (times != nullptr) {
      const int64_t* ts = timestamps(r, k);
      const int64_t written = s.written_ns.load(std::memory_order_acquire);
      for (uint32_t i = 0; i < n; ++i) {
        const int64_t t_i = std::atomic_ref<const int64_t>(ts[src[i]]).load(std::memory_order_acquire);
        times[i] = t_i != 0 ? t_i : written;
      }
    }
    if (s.version.load(std::memory_order_relaxed) == v1) {
      if (published_seen) *published_seen = pub;
      return true;
    }
  }
  return false;
}

ChannelValue ProcessImage::read_channel(uint32_t c) const noexcept {
  const ChannelDesc& d = channel(c);
  ChannelValue cv = read_at(d.region, d.index);
  if (cv.fresh) {
    cv.quality = judge_quality(cv.quality, cv.value, cv.timestamp_ns, kernel_rt::monotonic_now_ns(), d.max_age_ns);
  }
  // Forced is what the snapshot says (its writer stamped `forced` beside the
  // forced value, apply_forces), never the force table: between a force and
  // the writer's next snapshot the value is still the source's, and so is its
  // status; after an unforce, the same the other way.
  cv.forced = cv.fresh && cv.quality == Quality::kForced;
  if (d.has_delivery && d.delivery_region < region_count()) {
    // An output is only as good as its delivery: a driver that cannot send it
    // (its peer is gone) says so in its own region.
    const ChannelValue dv = read_at(d.delivery_region, d.delivery_index);
    cv.quality = worse(cv.quality, dv.fresh ? dv.quality : Quality::kBad);
  }
  return cv;
}

ChannelValue ProcessImage::read_at(uint32_t r, uint32_t index) const noexcept {
  ChannelValue cv;
  ChannelDesc d{};
  d.index = index;
  for (int t = 0; t < 1000; ++t) {
    const uint64_t pub = ring(r).published.load(std::memory_order_acquire);
    if (pub == 0) return cv;
    const auto k = static_cast<uint32_t>(pub % kRingSlots);
    const SlotHeader& s = slot(r, k);
    const uint64_t v1 = s.version.load(std::memory_order_acquire);
    if (v1 != slot_version_after(pub)) continue;  // being written, or already a later publication
    cv.value = load_value(values(r, k) + d.index);
    cv.quality = static_cast<Quality>(std::atomic_ref<uint8_t>(quality(r, k)[d.index]).load(std::memory_order_acquire));
    cv.timestamp_ns = std::atomic_ref<int64_t>(timestamps(r, k)[d.index]).load(std::memory_order_acquire);
    if (cv.timestamp_ns == 0) cv.timestamp_ns = s.written_ns.load(std::memory_order_acquire);
    if (s.version.load(std::memory_order_relaxed) == v1) {
      cv.fresh = true;
      return cv;
    }
  }
  return cv;
}

}  // namespace rtplc::io
