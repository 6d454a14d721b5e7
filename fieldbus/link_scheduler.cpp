// The frame scheduler of a link that runs on a plan (see link_scheduler.h).
#include "fieldbus/link_scheduler.h"

#include <algorithm>
#include <bit>
#include <utility>

namespace rtplc::fieldbus {
namespace {

// floor(a / b) for b > 0, also for negative a.
int64_t floor_div(int64_t a, int64_t b) {
  const int64_t q = a / b;
  return (a % b != 0 && a < 0) ? q - 1 : q;
}

}  // namespace

const char* to_string(TrafficClass c) {
  switch (c) {
    case TrafficClass::kPeriodic: return "periodic";
    case TrafficClass::kUrgent: return "urgent";
    case TrafficClass::kNonRt: return "non-RT";
  }
  return "?";
}

// ---- DelayStats ---------------------------------------------------------------

size_t DelayStats::bucket_of(Nanos delay) {
  const auto x = static_cast<uint64_t>(std::max<Nanos>(delay, 0));
  if (x < 8) return static_cast<size_t>(x);
  const int e = static_cast<int>(std::bit_width(x)) - 1;  // 3..62
  const auto sub = static_cast<size_t>((x >> (e - 3)) & 7);
  return std::min(kBuckets - 1, 8 * static_cast<size_t>(e - 2) + sub);
}

Nanos DelayStats::bucket_top(size_t bucket) {
  if (bucket < 8) return static_cast<Nanos>(bucket);
  const int e = static_cast<int>(bucket / 8) + 2;
  const auto sub = static_cast<uint64_t>(bucket % 8);
  return static_cast<Nanos>(((8 + sub + 1) << (e - 3)) - 1);
}

void DelayStats::record(Nanos delay, Nanos packet) noexcept {
  delay = std::max<Nanos>(delay, 0);
  ++buckets_[bucket_of(delay)];
  ++count_;
  max_ = std::max(max_, delay);
  packet_max_ = std::max(packet_max_, packet);
}

Nanos DelayStats::p99() const {
  if (count_ == 0) return 0;
  const uint64_t rank = (count_ * 99 + 99) / 100;  // ceil(0.99 n)
  uint64_t seen = 0;
  for (size_t b = 0; b < kBuckets; ++b) {
    seen += buckets_[b];
    if (seen >= rank) return std::min(bucket_top(b), max_);
  }
  return max_;
}

// ---- LinkScheduler --------------------------------------------------------------

LinkScheduler::LinkScheduler(SchedulerSetup setup, Clock clock)
    : setup_(std::move(setup)),
      clock_(clock),
      periodic_pending_(setup_.periodic.size(), 0),
      urgent_pending_(setup_.urgent.size(), 0),
      urgent_late_(setup_.urgent.size(), 0),
      urgent_since_(setup_.urgent.size(), 0) {
  if (setup_.t1 <= 0) setup_.t1 = 1;
}

LinkFigures LinkScheduler::figures() const {
  LinkFigures f{};
  for (size_t c = 0; c < kTrafficClasses; ++c) {
    const DelayStats& d = stats_[c];
    f[c] = {d.count(), d.missed(), d.p99(), d.max(), d.packet_max()};
  }
  return f;
}

void LinkScheduler::start(int64_t epoch_ns) noexcept {
  epoch_ = epoch_ns;
  frame_ = -1;
  started_ = true;
}

int64_t LinkScheduler::frame_of(int64_t t_ns) const {
  return floor_div(t_ns - epoch_, setup_.t1);
}

bool LinkScheduler::due_in(uint32_t i, int64_t f) const {
  const PeriodicSlot& s = setup_.periodic[i];
  return f >= 0 && (f - s.offset) % s.period_frames == 0 && f >= s.offset;
}

void LinkScheduler::urgent_ready(uint32_t i, int64_t at_ns) noexcept {
  if (i >= urgent_pending_.size() || urgent_pending_[i]) return;
  urgent_pending_[i] = 1;
  urgent_late_[i] = 0;
  // Ready before frame 0 (a link's first cycle runs before its first release):
  // it waits from frame 0, the first time it could go.
  urgent_since_[i] = started_ ? std::max(at_ns, epoch_) : at_ns;
}

void LinkScheduler::nonrt_ready(int64_t at_ns) noexcept {
  if (nonrt_pending_) return;
  nonrt_pending_ = true;
  nonrt_since_ = started_ ? std::max(at_ns, epoch_) : at_ns;
}

void LinkScheduler::enter_frame(int64_t f) noexcept {
  DelayStats& periodic = stats_of(TrafficClass::kPeriodic);
  for (uint32_t i = 0; i < setup_.periodic.size(); ++i) {
    // Still waiting from its frame: the window is over, the new sample replaces it.
    if (periodic_pending_[i]) periodic.count_missed();
    periodic_pending_[i] = 0;
    // Frames no cycle ran in (the thread was stalled for more than T_1).
    if (frame_ >= 0 && f > frame_ + 1) {
      const PeriodicSlot& s = setup_.periodic[i];
      const int64_t skipped =
          floor_div(f - 1 - s.offset, s.period_frames) - floor_div(frame_ - s.offset, s.period_frames);
      if (skipped > 0) periodic.count_missed(static_cast<uint64_t>(skipped));
    }
    if (due_in(i, f)) periodic_pending_[i] = 1;
  }
  DelayStats& urgent = stats_of(TrafficClass::kUrgent);
  for (uint32_t i = 0; i < setup_.urgent.size(); ++i) {
    if (urgent_pending_[i] && !urgent_late_[i] && frame_of(urgent_since_[i]) < f) {
      urgent.count_missed();
      urgent_late_[i] = 1;  // still sent, as soon as it can be
    }
  }
  frame_ = f;
  nonrt_sent_this_frame_ = false;
}

void LinkScheduler::tick(int64_t now_ns, LinkSender& sender) noexcept {
  if (!started_ || now_ns < epoch_) return;
  const int64_t f = frame_of(now_ns);
  if (f != frame_) enter_frame(f);
  const int64_t frame_start = epoch_ + f * setup_.t1;
  const int64_t frame_end = frame_start + setup_.t1;
  Nanos ahead = 0;  // wire time handed over in this tick, still in front of what follows
  bool blocked = false;

  for (uint32_t i = 0; i < setup_.urgent.size(); ++i) {
    if (!urgent_pending_[i]) continue;
    const SendOutcome o = sender.send_urgent(i);
    if (o == SendOutcome::kFailed) {
      blocked = true;
      continue;
    }
    urgent_pending_[i] = 0;
    if (o == SendOutcome::kSent) {
      stats_of(TrafficClass::kUrgent).record(clock_() - urgent_since_[i], setup_.urgent[i]);
      ahead += setup_.urgent[i];
    }
  }
  for (uint32_t i = 0; i < setup_.periodic.size(); ++i) {
    if (!periodic_pending_[i]) continue;
    const SendOutcome o = sender.send_periodic(i);
    if (o == SendOutcome::kFailed) {
      blocked = true;
      continue;
    }
    periodic_pending_[i] = 0;
    if (o == SendOutcome::kSent) {
      stats_of(TrafficClass::kPeriodic).record(clock_() - frame_start, setup_.periodic[i].packet);
      ahead += setup_.periodic[i].packet;
    }
  }
  // Non-RT only when everything real-time of this frame is out, one fragment a
  // frame, cut to what is left of the frame and to L_n.
  if (blocked || !nonrt_pending_ || nonrt_sent_this_frame_) return;
  const Nanos budget = std::min<Nanos>(setup_.ln, frame_end - clock_() - ahead);
  if (budget <= 0) return;
  bool more = false;
  const Nanos sent = sender.send_nonrt(budget, more);
  if (sent <= 0) {
    nonrt_pending_ = more;
    return;
  }
  const int64_t t = clock_();
  stats_of(TrafficClass::kNonRt).record(t - nonrt_since_, sent);
  nonrt_sent_this_frame_ = true;
  nonrt_pending_ = more;
  nonrt_since_ = t;  // the next fragment waits from here
}

}  // namespace rtplc::fieldbus
