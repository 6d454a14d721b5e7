// The shared link machinery (io/link/): a snapshot reader never sees a torn
// value, not even when it preempts the writer mid-store on the same CPU; the
// bounded queue hands every accepted item over exactly once; timers and
// histograms.
#include <gtest/gtest.h>

#include <atomic>
#include <functional>
#include <thread>
#include <vector>

#include "io/link/handoff.h"
#include "io/link/rtt_histogram.h"
#include "io/link/timer_heap.h"
#include "tests/support/same_cpu_preemption.h"

namespace rtplc::link {
namespace {

struct Wide {
  uint64_t a, b, c, d, e;
};

// The writer hands the reader the CPU every 1000 stores and waits until the
// reader has read again, so reads provably happen while stores go on (not all
// before or after them); every one of those reads must be consistent.
TEST(Handoff, never_hands_a_reader_a_torn_value) {
  SnapshotSlot<Wide> slot;
  std::atomic<uint64_t> reads{0};
  std::atomic<bool> done{false};
  std::atomic<uint64_t> torn{0};
  std::atomic<uint64_t> misses{0};
  std::thread reader([&] {
    uint64_t last = 0;
    while (!done.load()) {
      Wide w{};
      if (!slot.try_load(w)) {
        misses.fetch_add(1);
        continue;
      }
      if (!(w.a == w.b && w.b == w.c && w.c == w.d && w.d == w.e) || w.a < last) torn.fetch_add(1);
      last = w.a;
      reads.fetch_add(1);
    }
  });
  uint64_t handshakes = 0;
  for (uint64_t i = 1; i <= 200000; ++i) {
    slot.store(Wide{i, i, i, i, i});
    if (i % 1000 == 0) {
      const uint64_t seen = reads.load();
      while (reads.load() == seen) std::this_thread::yield();
      ++handshakes;
    }
  }
  done = true;
  reader.join();
  EXPECT_EQ(torn.load(), 0u);
  EXPECT_EQ(handshakes, 200u);
  EXPECT_GE(reads.load(), 200u);  // at least one read inside every 1000 stores
  Wide last{};
  ASSERT_TRUE(slot.try_load(last));
  EXPECT_EQ(last.a, 200000u);
  EXPECT_EQ(slot.writer_value().e, 200000u);
}

// The ordering bug a loaded machine found: a reader that loaded `published`
// and was delayed there, while the writer rewrote that very copy whole with a
// publication kSlots later but had not yet published it, took the newer value;
// its next read (of the older, still-published number) went backwards. The
// hooks stop each side exactly there, so this fails every time on a slot
// without the generation check, on any machine.
TEST(Handoff, a_delayed_reader_never_gets_an_older_value_after_a_newer_one) {
  SnapshotSlot<Wide> slot;
  auto wide = [](uint64_t v) { return Wide{v, v, v, v, v}; };
  slot.store(wide(1));  // copy 1
  std::atomic<int> phase{0};
  auto wait_for = [&](int p) {
    while (phase.load() != p) std::this_thread::yield();
  };
  std::thread writer([&] {
    wait_for(1);
    for (uint64_t v = 2; v <= 4; ++v) slot.store(wide(v));
    // 5 goes into copy 1 again (5 % 4): whole, but not yet published.
    slot.store(wide(5), [] {}, [&] {
      phase.store(2);
      wait_for(3);
    });
  });
  Wide first{}, second{};
  bool delayed = false;
  const bool ok1 = slot.try_load(first, SnapshotSlot<Wide>::kDefaultTries, [&] {
    if (delayed) return;
    delayed = true;
    phase.store(1);  // holding published = 1
    wait_for(2);
  });
  const bool ok2 = slot.try_load(second);
  phase.store(3);
  writer.join();
  ASSERT_TRUE(ok1);
  ASSERT_TRUE(ok2);
  EXPECT_LE(first.a, second.a) << "read " << first.a << ", then the older " << second.a;
  EXPECT_EQ(first.a, first.e);
  Wide last{};
  ASSERT_TRUE(slot.try_load(last));
  EXPECT_EQ(last.a, 5u);
}

// What the SnapshotSlot replaced: one copy guarded by one sequence. A reader
// that preempts its writer between the two sequence stores sees an odd
// sequence on every try (bounded here; the old code retried forever).
class SingleCopySeqlock {
 public:
  template <typename Mid>
  void store(uint64_t v, Mid&& mid) {
    const uint64_t s = seq_.fetch_add(1, std::memory_order_acq_rel);
    mid();
    value_.store(v, std::memory_order_release);
    seq_.store(s + 2, std::memory_order_release);
  }
  bool try_load(uint64_t& out, uint64_t tries) const {
    for (uint64_t t = 0; t < tries; ++t) {
      const uint64_t s1 = seq_.load(std::memory_order_acquire);
      const uint64_t v = value_.load(std::memory_order_acquire);
      if ((s1 & 1) == 0 && seq_.load(std::memory_order_relaxed) == s1) {
        out = v;
        return true;
      }
    }
    return false;
  }

 private:
  std::atomic<uint64_t> seq_{0};
  std::atomic<uint64_t> value_{0};
};

TEST(Handoff, a_reader_preempting_the_writer_mid_store_on_its_cpu_reads_at_once) {
  // The reference first: proves the scenario really catches the writer mid-store.
  SingleCopySeqlock old;
  auto before = testing::run_preempting_reader(
      [&](const std::function<void()>& preempt) { old.store(2, preempt); },
      [&] {
        uint64_t v = 0;
        return old.try_load(v, 20000000);
      });
  if (!before.ran && !before.why.empty() && before.why.find("SCHED_FIFO") != std::string::npos) {
    GTEST_SKIP() << before.why;
  }
  ASSERT_TRUE(before.ran) << before.why;
  EXPECT_TRUE(before.reader_preempted_writer) << "the reader did not run while the writer was mid-store";
  EXPECT_FALSE(before.read_ok) << "a single-copy seqlock cannot be read while its writer is preempted";

  SnapshotSlot<Wide> slot;
  slot.store(Wide{1, 1, 1, 1, 1});
  Wide got{};
  auto after = testing::run_preempting_reader(
      [&](const std::function<void()>& preempt) { slot.store(Wide{2, 2, 2, 2, 2}, preempt); },
      [&] {
        Wide w{};
        const bool ok = slot.try_load(w);
        got = w;
        return ok && w.a == 1 && w.e == 1;  // the last completed value, whole
      });
  ASSERT_TRUE(after.ran) << after.why;
  EXPECT_TRUE(after.reader_preempted_writer);
  EXPECT_TRUE(after.read_ok) << "the reader could not read while the writer was preempted mid-store";
}

TEST(Handoff, queue_delivers_every_accepted_item_once_and_rejects_when_full) {
  BoundedQueue<uint64_t> q(1024);
  constexpr int kProducers = 3;
  constexpr uint64_t kEach = 50000;
  std::atomic<uint64_t> accepted{0};
  std::vector<std::thread> producers;
  std::atomic<bool> stop{false};
  std::vector<uint8_t> seen(kProducers * kEach, 0);
  uint64_t got = 0;
  std::thread consumer([&] {
    uint64_t v = 0;
    while (true) {
      const bool finished = stop.load();  // read before popping: nothing is missed
      // Not empty: the next pop takes an item (the consumer alone removes them).
      const bool has = !q.empty();
      const bool popped = q.pop(v);
      ASSERT_TRUE(popped || !has) << "empty() said an item was there";
      if (popped) {
        ASSERT_LT(v, seen.size());
        ASSERT_EQ(seen[v], 0) << "delivered twice";
        seen[v] = 1;
        ++got;
      } else if (finished) {
        break;
      }
    }
  });
  for (int p = 0; p < kProducers; ++p) {
    producers.emplace_back([&, p] {
      for (uint64_t i = 0; i < kEach; ++i) {
        if (q.push(static_cast<uint64_t>(p) * kEach + i)) accepted.fetch_add(1);
      }
    });
  }
  for (auto& t : producers) t.join();
  stop = true;
  consumer.join();
  EXPECT_EQ(got, accepted.load());
  BoundedQueue<int> small(2);
  EXPECT_TRUE(small.empty());
  EXPECT_TRUE(small.push(1));
  EXPECT_FALSE(small.empty());
  EXPECT_TRUE(small.push(2));
  EXPECT_FALSE(small.push(3));
  uint64_t ticket = 99;
  int v = 0;
  EXPECT_TRUE(small.pop(v));
  EXPECT_TRUE(small.push(4, &ticket));
  EXPECT_EQ(ticket, 2u);
}

TEST(Handoff, timer_heap_pops_in_deadline_order_after_moves) {
  TimerHeap h(8);
  const int64_t d[] = {50, 10, 40, 30, 20, 60, 70, 5};
  for (uint32_t k = 0; k < 8; ++k) h.schedule(k, d[k]);
  h.schedule(7, 100);  // move later
  h.schedule(5, 1);    // move earlier
  h.cancel(6);
  std::vector<uint32_t> order;
  while (!h.empty()) {
    order.push_back(h.top());
    h.cancel(h.top());
  }
  EXPECT_EQ(order, (std::vector<uint32_t>{5, 1, 4, 3, 2, 0, 7}));
}

TEST(Handoff, rtt_histogram_quantiles_are_within_a_bucket) {
  RttHistogram h;
  for (uint64_t v = 1; v <= 1000; ++v) h.record(v * 100);  // 100 us .. 100 ms
  const double p50 = static_cast<double>(h.quantile(0.5));
  const double p99 = static_cast<double>(h.quantile(0.99));
  EXPECT_NEAR(p50, 50000, 50000 * 0.07);
  EXPECT_NEAR(p99, 99000, 99000 * 0.07);
  EXPECT_EQ(h.max(), 100000u);
  for (uint64_t v : {0ull, 31ull, 32ull, 1000ull, 123456789ull}) {
    EXPECT_GE(RttHistogram::bucket_upper(RttHistogram::bucket_of(v)), v);
  }
}

}  // namespace
}  // namespace rtplc::link
