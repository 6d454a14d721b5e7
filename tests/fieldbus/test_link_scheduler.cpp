// The frame scheduler of a planned link (fieldbus/link_scheduler.h) on a
// virtual clock: periodic messages land in their loop's frames only, urgent
// ones go first in the frame they arrive in, non-RT fragments never exceed L_n
// and take one per frame, missed windows are counted, and the measured delays
// stay within the planner's bounds for the worked example of docs/fieldbus.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "fieldbus/link_scheduler.h"
#include "fieldbus/planner.h"

namespace rtplc::fieldbus {
namespace {

constexpr Nanos kUs = 1000;
constexpr Nanos kMs = 1000000;

int64_t g_now = 0;
int64_t virtual_now() noexcept { return g_now; }

// Records what the scheduler asked for; each send advances the virtual clock
// by the message's wire time (a controller that takes it at once).
struct Recorder final : LinkSender {
  struct Sent {
    TrafficClass cls;
    uint32_t index;
    int64_t at;
    Nanos wire;
  };
  std::vector<Sent> sent;
  std::vector<Nanos> periodic_wire, urgent_wire;
  Nanos nonrt_left = 0;       // wire time the transfer still has
  Nanos nonrt_frame = 270 * kUs;  // one CAN frame of it
  bool fail = false;

  SendOutcome send_periodic(uint32_t i) noexcept override {
    if (fail) return SendOutcome::kFailed;
    sent.push_back({TrafficClass::kPeriodic, i, g_now, periodic_wire[i]});
    g_now += periodic_wire[i];
    return SendOutcome::kSent;
  }
  SendOutcome send_urgent(uint32_t i) noexcept override {
    if (fail) return SendOutcome::kFailed;
    sent.push_back({TrafficClass::kUrgent, i, g_now, urgent_wire[i]});
    g_now += urgent_wire[i];
    return SendOutcome::kSent;
  }
  Nanos send_nonrt(Nanos budget, bool& more) noexcept override {
    Nanos used = 0;
    while (nonrt_left > 0 && used + std::min(nonrt_frame, nonrt_left) <= budget) {
      const Nanos w = std::min(nonrt_frame, nonrt_left);
      used += w;
      nonrt_left -= w;
    }
    more = nonrt_left > 0;
    if (used > 0) sent.push_back({TrafficClass::kNonRt, 0, g_now, used});
    g_now += used;
    return used;
  }
};

// The worked example's plan as a link: L1 every frame, L2 every 4th.
struct Rig {
  Plan p = plan(worked_example());
  Recorder rec;
  LinkScheduler sched;

  static SchedulerSetup setup_of(const Plan& p) {
    SchedulerSetup s;
    s.t1 = p.t1;
    s.ln = p.ln_max;
    for (const LoopPlan& l : p.loops) s.periodic.push_back({int64_t{1} << l.shift, l.offset, 100 * kUs});
    s.urgent = {150 * kUs, 150 * kUs};
    return s;
  }
  Rig() : sched(setup_of(p), &virtual_now) {
    rec.periodic_wire = {100 * kUs, 100 * kUs};
    rec.urgent_wire = {150 * kUs, 150 * kUs};
    g_now = 0;
    sched.start(0);
  }
  // Cycles every `period` from `from` for `frames` T_1 frames.
  void run(int64_t from, int frames, Nanos period) {
    for (int64_t t = from; t < from + frames * p.t1; t += period) {
      g_now = std::max(g_now, t);
      sched.tick(t, rec);
    }
  }
};

TEST(LinkScheduler, sends_each_periodic_message_in_its_loops_frames_only) {
  Rig r;
  ASSERT_TRUE(r.p.feasible);
  r.run(0, 16, 1 * kMs);
  int l1 = 0, l2 = 0;
  for (const Recorder::Sent& s : r.rec.sent) {
    ASSERT_EQ(s.cls, TrafficClass::kPeriodic);
    const int64_t f = s.at / r.p.t1;
    if (s.index == 0) ++l1;
    if (s.index == 1) {
      ++l2;
      EXPECT_EQ(f % 4, r.p.loops[1].offset) << "L2 sent outside its window, frame " << f;
    }
    EXPECT_LT(s.at - f * r.p.t1, r.p.transfer_bound) << "not in the frame's periodic part";
  }
  EXPECT_EQ(l1, 16);
  EXPECT_EQ(l2, 4);
  EXPECT_EQ(r.sched.stats(TrafficClass::kPeriodic).count(), 20u);
  EXPECT_EQ(r.sched.stats(TrafficClass::kPeriodic).missed(), 0u);
}

TEST(LinkScheduler, sends_urgent_messages_first_in_the_frame_they_arrive_in) {
  Rig r;
  r.run(0, 1, 1 * kMs);  // frame 0 done
  r.rec.sent.clear();
  // Both urgent messages become ready just before frame 1 begins.
  r.sched.urgent_ready(1, 5 * kMs);
  r.sched.urgent_ready(0, 5 * kMs);
  r.run(5 * kMs, 1, 1 * kMs);
  ASSERT_GE(r.rec.sent.size(), 3u);
  EXPECT_EQ(r.rec.sent[0].cls, TrafficClass::kUrgent);
  EXPECT_EQ(r.rec.sent[1].cls, TrafficClass::kUrgent);
  EXPECT_EQ(r.rec.sent[2].cls, TrafficClass::kPeriodic);
  // One arriving mid-frame goes at the next scheduling point, in that frame.
  g_now = 10 * kMs;
  r.sched.tick(10 * kMs, r.rec);  // frame 2's periodic part
  r.rec.sent.clear();
  r.sched.urgent_ready(0, 12 * kMs);
  g_now = 12 * kMs;
  r.sched.tick(12 * kMs, r.rec);
  ASSERT_EQ(r.rec.sent.size(), 1u);
  EXPECT_EQ(r.rec.sent[0].at / r.p.t1, 2);
  const DelayStats& u = r.sched.stats(TrafficClass::kUrgent);
  EXPECT_EQ(u.count(), 3u);
  EXPECT_EQ(u.missed(), 0u);
  EXPECT_LE(u.max(), r.p.t1);
}

TEST(LinkScheduler, cuts_nonrt_transfers_to_ln_one_fragment_per_frame) {
  Rig r;
  r.rec.nonrt_left = 40 * kMs;  // far more than one frame can carry
  r.sched.nonrt_ready(0);
  r.run(0, 20, 1 * kMs);
  std::vector<int64_t> frames;
  for (const Recorder::Sent& s : r.rec.sent) {
    if (s.cls != TrafficClass::kNonRt) continue;
    EXPECT_LE(s.wire, r.p.ln_max);
    const int64_t f = s.at / r.p.t1;
    EXPECT_TRUE(frames.empty() || frames.back() != f) << "two fragments in frame " << f;
    frames.push_back(f);
    // It ends inside its frame: the next frame's periodic part is not delayed.
    EXPECT_LE(s.at + s.wire, (f + 1) * r.p.t1);
  }
  EXPECT_EQ(frames.size(), 20u);
  // Periodic traffic of each frame went before the fragment.
  for (size_t i = 1; i < r.rec.sent.size(); ++i) {
    const auto& a = r.rec.sent[i - 1];
    const auto& b = r.rec.sent[i];
    if (a.at / r.p.t1 == b.at / r.p.t1) {
      EXPECT_FALSE(a.cls == TrafficClass::kNonRt && b.cls == TrafficClass::kPeriodic);
    }
  }
  const DelayStats& n = r.sched.stats(TrafficClass::kNonRt);
  EXPECT_EQ(n.count(), 20u);
  EXPECT_LE(n.packet_max(), r.p.ln_max);
}

TEST(LinkScheduler, gives_nonrt_only_what_is_left_of_the_frame) {
  Rig r;
  r.rec.nonrt_left = 40 * kMs;
  r.sched.nonrt_ready(0);
  // One cycle a frame, late: 4.5 ms into each 5 ms frame only 500 us remain.
  for (int f = 0; f < 4; ++f) {
    const int64_t t = f * r.p.t1 + 4500 * kUs;
    g_now = t;
    r.sched.tick(t, r.rec);
  }
  for (const Recorder::Sent& s : r.rec.sent) {
    const int64_t f = s.at / r.p.t1;
    EXPECT_LE(s.at + s.wire, (f + 1) * r.p.t1) << "a fragment ran into the next frame";
  }
}

TEST(LinkScheduler, lets_messages_ready_before_frame_0_wait_from_frame_0) {
  Rig r;
  r.sched.start(10 * kMs);  // the first release; the link's first cycle runs before it
  r.sched.urgent_ready(0, 7 * kMs);
  g_now = 8 * kMs;
  r.sched.tick(8 * kMs, r.rec);  // before frame 0: nothing goes
  EXPECT_TRUE(r.rec.sent.empty());
  g_now = 10 * kMs;
  r.sched.tick(10 * kMs, r.rec);
  ASSERT_FALSE(r.rec.sent.empty());
  EXPECT_EQ(r.rec.sent[0].cls, TrafficClass::kUrgent);
  EXPECT_EQ(r.sched.stats(TrafficClass::kUrgent).missed(), 0u);
  EXPECT_EQ(r.sched.stats(TrafficClass::kUrgent).max(), 150 * kUs);  // its own hand-over, not the 3 ms before frame 0
}

TEST(LinkScheduler, counts_a_window_missed_when_its_frame_ends_unsent) {
  Rig r;
  r.rec.fail = true;
  r.run(0, 2, 1 * kMs);  // frames 0 and 1: every send refused
  r.rec.fail = false;
  r.run(2 * r.p.t1, 1, 1 * kMs);
  const DelayStats& p = r.sched.stats(TrafficClass::kPeriodic);
  // Frame 0: L1 and L2; frame 1: L1. Frame 2 sends L1.
  EXPECT_EQ(p.missed(), 3u);
  EXPECT_EQ(p.count(), 1u);
}

TEST(LinkScheduler, counts_windows_of_frames_no_cycle_ran_in) {
  Rig r;
  r.run(0, 1, 1 * kMs);
  g_now = 9 * r.p.t1;  // the thread stalled from frame 1 to frame 8
  r.sched.tick(9 * r.p.t1, r.rec);
  // L1 missed frames 1..8 (8), L2 (offset 0, every 4th) missed 4 and 8 (2).
  EXPECT_EQ(r.sched.stats(TrafficClass::kPeriodic).missed(), 10u);
}

TEST(LinkScheduler, measured_delays_stay_within_the_planners_bounds) {
  Rig r;
  std::mt19937 rng(7);
  r.rec.nonrt_left = 1000 * kMs;
  r.sched.nonrt_ready(0);
  for (int64_t t = 0; t < 2000 * r.p.t1; t += 500 * kUs) {
    // A cycle wakes a little late, urgent values change at random.
    g_now = std::max(g_now, t + static_cast<int64_t>(rng() % 50) * kUs);
    if (rng() % 7 == 0) r.sched.urgent_ready(static_cast<uint32_t>(rng() % 2), t);
    r.sched.tick(t, r.rec);
  }
  const DelayStats& p = r.sched.stats(TrafficClass::kPeriodic);
  const DelayStats& u = r.sched.stats(TrafficClass::kUrgent);
  const DelayStats& n = r.sched.stats(TrafficClass::kNonRt);
  EXPECT_EQ(p.count(), 2000u + 500u);
  EXPECT_EQ(p.missed(), 0u);
  EXPECT_LE(p.max(), r.p.transfer_bound);
  EXPECT_LE(p.p99(), p.max());
  EXPECT_GT(u.count(), 100u);
  EXPECT_EQ(u.missed(), 0u);
  EXPECT_LE(u.max(), r.p.t1);
  EXPECT_GT(n.count(), 1000u);
  EXPECT_LE(n.packet_max(), r.p.ln_max);
}

TEST(DelayStats, reports_p99_never_below_the_true_one_and_close_to_it) {
  std::mt19937_64 rng(3);
  for (int round = 0; round < 20; ++round) {
    DelayStats s;
    std::vector<Nanos> v;
    const int n = 100 + static_cast<int>(rng() % 5000);
    for (int i = 0; i < n; ++i) {
      const Nanos d = static_cast<Nanos>(rng() % 20000000);
      v.push_back(d);
      s.record(d, 0);
    }
    std::sort(v.begin(), v.end());
    const Nanos truth = v[static_cast<size_t>((static_cast<uint64_t>(n) * 99 + 99) / 100 - 1)];
    EXPECT_GE(s.p99(), truth);
    EXPECT_LE(s.p99(), truth + truth / 8 + 1);
    EXPECT_EQ(s.max(), v.back());
  }
  for (Nanos d : {Nanos{0}, Nanos{7}, Nanos{8}, Nanos{1000}, Nanos{123456789}}) {
    EXPECT_GE(DelayStats::bucket_top(DelayStats::bucket_of(d)), d);
  }
}

}  // namespace
}  // namespace rtplc::fieldbus
