// The lock-free handoff of the engine (handoff.h): a reader never sees a torn
// value, and the bounded queue hands every accepted item over exactly once.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

#include "io/s7/handoff.h"
#include "io/s7/rtt_histogram.h"
#include "io/s7/timer_heap.h"

namespace rtplc::s7 {
namespace {

struct Wide {
  uint64_t a, b, c, d, e;
};

TEST(Handoff, never_hands_a_reader_a_torn_value) {
  SeqlockSlot<Wide> slot;
  std::atomic<bool> go{false};
  std::atomic<bool> done{false};
  std::thread writer([&] {
    while (!go.load()) {
    }
    for (uint64_t i = 1; i <= 200000; ++i) slot.store(Wide{i, i, i, i, i});
    done = true;
  });
  uint64_t reads = 0;
  go = true;
  do {
    const Wide w = slot.load();
    ASSERT_TRUE(w.a == w.b && w.b == w.c && w.c == w.d && w.d == w.e) << w.a << " " << w.e;
    ++reads;
  } while (!done.load());
  writer.join();
  EXPECT_EQ(slot.load().a, 200000u);
  EXPECT_GT(reads, 0u);
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
      if (q.pop(v)) {
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
  EXPECT_TRUE(small.push(1));
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
}  // namespace rtplc::s7
