// A link that runs on a plan (spec io-links.md, "Fieldbus bandwidth
// allocation"; docs/fieldbus.md, "Running a link on a plan"): the scheduler a
// CAN or Modbus RTU link's periodic thread calls every cycle. Time is divided
// into T_1 frames from an epoch (the link's first release); in each frame
//   1. urgent (real-time) messages that became ready go first, in the frame
//      in which they arrive;
//   2. then the periodic messages whose loop samples in this frame (frame f
//      with f = offset mod 2^k, the plan's window schedule);
//   3. then, with what remains of the frame, at most one fragment of the
//      pending non-RT transfer, never longer than L_n of wire time.
// A periodic message not handed over inside its frame is a missed window (as
// is an urgent one not sent in the frame it arrived in). Per class it keeps
// the delay from ready to handed over (count, max, p99) and the longest
// packet, to be shown beside the plan's bounds.
//
// Steady state allocates nothing: every table is sized when it is built.
// Single-threaded: only the link's thread calls it (its stats are copied out
// by that same thread into the image's link row).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fieldbus/units.h"

namespace rtplc::fieldbus {

enum class TrafficClass : uint8_t { kPeriodic = 0, kUrgent = 1, kNonRt = 2 };
inline constexpr size_t kTrafficClasses = 3;
const char* to_string(TrafficClass c);  // "periodic", "urgent", "non-RT"

// Delays of one traffic class in a fixed log-linear histogram: exact below
// 8 ns, then 8 buckets per power of two (a bucket is at most 12.5 % wide), so
// p99 is read with no allocation and never below the true value (it is capped
// at the largest delay seen).
class DelayStats {
 public:
  void record(Nanos delay, Nanos packet) noexcept;
  void count_missed(uint64_t n = 1) noexcept { missed_ += n; }
  uint64_t count() const { return count_; }
  uint64_t missed() const { return missed_; }
  Nanos max() const { return max_; }
  Nanos p99() const;
  Nanos packet_max() const { return packet_max_; }

  static size_t bucket_of(Nanos delay);
  static Nanos bucket_top(size_t bucket);  // the largest delay the bucket holds

 private:
  static constexpr size_t kBuckets = 8 * 62;
  std::array<uint32_t, kBuckets> buckets_{};
  uint64_t count_ = 0;
  uint64_t missed_ = 0;
  Nanos max_ = 0;
  Nanos packet_max_ = 0;
};

// The figures of one class, plain data: what a link's thread hands to the
// thread that writes its link row.
struct ClassFigures {
  uint64_t count = 0;
  uint64_t missed = 0;
  Nanos delay_p99 = 0;
  Nanos delay_max = 0;
  Nanos packet_max = 0;
};
using LinkFigures = std::array<ClassFigures, kTrafficClasses>;

// One periodic message: it samples in the frames f with f mod period = offset.
struct PeriodicSlot {
  int64_t period_frames = 1;  // 2^k
  int64_t offset = 0;         // 0 <= offset < period_frames
  Nanos packet = 0;           // its wire time
};

struct SchedulerSetup {
  Nanos t1 = 0;  // the plan's basic period
  Nanos ln = 0;  // the largest non-RT fragment (the plan's L_n max)
  std::vector<PeriodicSlot> periodic;
  std::vector<Nanos> urgent;  // wire time of each urgent message
};

// What a send asked of the link did.
enum class SendOutcome : uint8_t {
  kSent,     // handed to the controller / the line
  kFailed,   // the link refused (queue full, down): retried while its window lasts
  kNothing,  // nothing to send we can vouch for (an output not good): not a miss
};

// The link's side: it owns the messages, the scheduler says which and when.
class LinkSender {
 public:
  virtual SendOutcome send_periodic(uint32_t i) noexcept = 0;
  virtual SendOutcome send_urgent(uint32_t i) noexcept = 0;
  // Sends the next fragment of the pending non-RT transfer, at most `budget`
  // of wire time. Returns the wire time sent (0: nothing fitted or the link
  // refused); `more` says whether the transfer has fragments left.
  virtual Nanos send_nonrt(Nanos budget, bool& more) noexcept = 0;

 protected:
  ~LinkSender() = default;
};

class LinkScheduler {
 public:
  using Clock = int64_t (*)() noexcept;
  // `clock` stamps each hand-over (kernel_rt's monotonic clock in the links,
  // a virtual one in tests).
  LinkScheduler(SchedulerSetup setup, Clock clock);

  // Frame 0 starts at `epoch_ns`.
  void start(int64_t epoch_ns) noexcept;
  // Urgent message i became ready at `at_ns` (a value changed). A message
  // already waiting keeps its first ready time (its newer value goes with it).
  void urgent_ready(uint32_t i, int64_t at_ns) noexcept;
  // A non-RT transfer has fragments waiting since `at_ns`.
  void nonrt_ready(int64_t at_ns) noexcept;
  bool nonrt_pending() const { return nonrt_pending_; }

  // One scheduling point; `now_ns` is the cycle's release time.
  void tick(int64_t now_ns, LinkSender& sender) noexcept;

  const DelayStats& stats(TrafficClass c) const { return stats_[static_cast<size_t>(c)]; }
  LinkFigures figures() const;
  int64_t frame() const { return frame_; }
  int64_t frame_of(int64_t t_ns) const;
  Nanos t1() const { return setup_.t1; }
  Nanos ln() const { return setup_.ln; }
  // Whether periodic message i samples in frame f.
  bool due_in(uint32_t i, int64_t f) const;

 private:
  void enter_frame(int64_t f) noexcept;
  DelayStats& stats_of(TrafficClass c) { return stats_[static_cast<size_t>(c)]; }

  SchedulerSetup setup_;
  Clock clock_;
  int64_t epoch_ = 0;
  int64_t frame_ = -1;
  bool started_ = false;
  std::vector<uint8_t> periodic_pending_;
  std::vector<uint8_t> urgent_pending_;
  std::vector<uint8_t> urgent_late_;  // counted missed once already
  std::vector<int64_t> urgent_since_;
  bool nonrt_pending_ = false;
  bool nonrt_sent_this_frame_ = false;
  int64_t nonrt_since_ = 0;
  std::array<DelayStats, kTrafficClasses> stats_{};
};

}  // namespace rtplc::fieldbus
