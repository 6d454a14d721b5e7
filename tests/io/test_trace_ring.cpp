// The trace ring (io/trace_ring.h): every record is delivered exactly once or
// counted lost, with a reader keeping up, a reader falling behind, a reader
// racing the writer on another CPU, and a reader preempting the writer on the
// same CPU in the middle of a record; and the selection hand-over.
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <thread>
#include <vector>

#include "io/trace_ring.h"
#include "tests/support/same_cpu_preemption.h"

namespace rtplc::io {
namespace {

// Record i carries cycle 1000 + i and values i * 10 + k: a torn record (parts
// of two records) cannot pass check().
void write_records(TraceWriter& w, uint64_t from, uint64_t to) {
  double v[kTraceChannels];
  for (uint64_t i = from; i < to; ++i) {
    for (uint32_t k = 0; k < kTraceChannels; ++k) v[k] = static_cast<double>(i * 10 + k);
    w.append(1000 + i, static_cast<int64_t>(i) * 1000, v);
  }
}

bool check(const TraceSample& s) {
  if (s.cycle != 1000 + s.record || s.release_ns != static_cast<int64_t>(s.record) * 1000) return false;
  for (uint32_t k = 0; k < kTraceChannels; ++k) {
    if (s.values[k] != static_cast<double>(s.record * 10 + k)) return false;
  }
  return true;
}

// A block with a full selection already taken by the writer.
std::unique_ptr<TraceBlock> selected_block(TraceWriter& w) {
  auto b = std::make_unique<TraceBlock>();
  TraceSource src[kTraceChannels] = {};
  EXPECT_TRUE(request_trace(*b, src, kTraceChannels));
  w = TraceWriter(b.get());
  EXPECT_TRUE(w.pick_up());
  EXPECT_EQ(w.n(), kTraceChannels);
  return b;
}

TEST(TraceRing, a_reader_keeping_up_gets_every_record_once_in_order) {
  TraceWriter w;
  auto b = selected_block(w);
  TraceReader r(b.get(), 0, kTraceChannels);
  std::vector<TraceSample> got;
  for (uint64_t chunk = 0; chunk < 10; ++chunk) {
    write_records(w, chunk * 700, (chunk + 1) * 700);  // more than one lap in all
    r.drain(got);
  }
  ASSERT_EQ(got.size(), 7000u);
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].record, i);
    EXPECT_TRUE(check(got[i])) << "record " << i;
  }
  EXPECT_EQ(r.lost(), 0u);
  EXPECT_EQ(r.behind(), 0u);
}

TEST(TraceRing, a_reader_that_fell_behind_counts_exactly_the_overwritten_records) {
  TraceWriter w;
  auto b = selected_block(w);
  TraceReader r(b.get(), 0, kTraceChannels);
  std::vector<TraceSample> got;
  write_records(w, 0, 100);
  r.drain(got);
  write_records(w, 100, 100 + 3 * kTraceSlots);  // three laps while the reader sleeps
  r.drain(got);
  const uint64_t written = 100 + 3 * kTraceSlots;
  // The kTraceSlots - 1 newest survive (the slot of the oldest may be refilled
  // at any moment); everything else is counted.
  EXPECT_EQ(got.size(), 100u + (kTraceSlots - 1));
  EXPECT_EQ(r.lost(), written - got.size());
  EXPECT_EQ(r.next_record(), written);
  for (const TraceSample& s : got) EXPECT_TRUE(check(s)) << "record " << s.record;
  EXPECT_EQ(got[100].record, written - (kTraceSlots - 1));
}

TEST(TraceRing, a_concurrent_reader_accounts_for_every_record_and_accepts_no_torn_one) {
  TraceWriter w;
  auto b = selected_block(w);
  constexpr uint64_t kRecords = 400000;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    write_records(w, 0, kRecords);
    done.store(true, std::memory_order_release);
  });
  TraceReader r(b.get(), 0, kTraceChannels);
  std::vector<TraceSample> got;
  uint64_t bad = 0, out_of_order = 0, last = 0;
  bool any = false;
  uint64_t rounds = 0;
  while (!done.load(std::memory_order_acquire) || r.behind() > 0) {
    const size_t before = got.size();
    r.drain(got);
    for (size_t i = before; i < got.size(); ++i) {
      if (!check(got[i])) ++bad;
      if (any && got[i].record <= last) ++out_of_order;
      last = got[i].record;
      any = true;
    }
    // Now and then a slow reader, so the writer laps it.
    if (++rounds % 64 == 0) std::this_thread::sleep_for(std::chrono::microseconds(300));
  }
  writer.join();
  r.drain(got);
  EXPECT_EQ(bad, 0u);
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(got.size() + r.lost(), kRecords);
}

TEST(TraceRing, a_reader_preempting_the_writer_mid_record_reads_the_completed_ones_at_once) {
  TraceWriter w;
  auto b = selected_block(w);
  write_records(w, 0, 5);
  auto res = testing::run_preempting_reader(
      [&](const std::function<void()>& preempt) {
        TraceRecord& rec = w.begin(1005, 5000);
        for (uint32_t k = 0; k < kTraceChannels / 2; ++k) TraceWriter::put(rec, k, 50.0 + k);
        preempt();
        for (uint32_t k = kTraceChannels / 2; k < kTraceChannels; ++k) TraceWriter::put(rec, k, 50.0 + k);
        w.commit(rec);
      },
      [&] {
        TraceReader r(b.get(), 0, kTraceChannels);
        std::vector<TraceSample> got;
        r.drain(got);
        if (got.size() != 5 || r.lost() != 0) return false;
        for (const TraceSample& s : got) {
          if (!check(s)) return false;
        }
        return true;
      });
  if (!res.ran) GTEST_SKIP() << res.why;
  EXPECT_TRUE(res.reader_preempted_writer);
  EXPECT_TRUE(res.read_ok);
}

TEST(TraceRing, a_new_selection_waits_until_the_task_took_the_last_and_says_where_it_starts) {
  auto b = std::make_unique<TraceBlock>();
  TraceWriter w(b.get());
  TraceSource one[1] = {{3, 0, 7}};
  ASSERT_TRUE(request_trace(*b, one, 1));
  EXPECT_FALSE(trace_applied(*b));
  TraceSource two[2] = {{1, 0, 2}, {1, 0, 3}};
  EXPECT_FALSE(request_trace(*b, two, 2)) << "the task has not read the first selection yet";
  ASSERT_TRUE(w.pick_up());
  EXPECT_FALSE(w.pick_up()) << "nothing new";
  ASSERT_EQ(w.n(), 1u);
  EXPECT_EQ(w.sources()[0].region, 3);
  EXPECT_EQ(w.sources()[0].index, 7u);
  uint64_t first = 99;
  ASSERT_TRUE(trace_applied(*b, &first));
  EXPECT_EQ(first, 0u);
  double v = 1;
  for (int i = 0; i < 10; ++i) w.append(static_cast<uint64_t>(i), i, &v);
  ASSERT_TRUE(request_trace(*b, two, 2));
  ASSERT_TRUE(w.pick_up());
  ASSERT_TRUE(trace_applied(*b, &first));
  EXPECT_EQ(first, 10u) << "records of the new selection start after the old ones";
  EXPECT_EQ(w.n(), 2u);
  ASSERT_TRUE(request_trace(*b, nullptr, 0));
  ASSERT_TRUE(w.pick_up());
  EXPECT_EQ(w.n(), 0u);
  w.append(11, 11, &v);
  EXPECT_EQ(b->ring.head.load(), 10u) << "no selection: no record";
}

TEST(TraceRing, selections_handed_to_a_running_writer_arrive_whole_and_in_order) {
  auto b = std::make_unique<TraceBlock>();
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> torn{0};
  // The "task": picks selections up at cycle boundaries and records. Selection
  // g has n = g % 8 + 1 sources, each {g, k}: a mixed one is torn.
  std::thread task([&] {
    TraceWriter w(b.get());
    double v[kTraceChannels] = {};
    uint64_t cycle = 0;
    while (!stop.load(std::memory_order_relaxed)) {
      if (w.pick_up()) {
        for (uint32_t k = 0; k < w.n(); ++k) {
          if (w.sources()[k].index != k || w.sources()[k].region != w.sources()[0].region) torn.fetch_add(1);
        }
        if (w.n() != static_cast<uint32_t>(w.sources()[0].region % kTraceChannels) + 1) torn.fetch_add(1);
      }
      w.append(cycle++, 0, v);
    }
  });
  uint64_t last_first = 0;
  for (uint16_t g = 1; g <= 2000; ++g) {
    TraceSource src[kTraceChannels];
    const uint32_t n = g % kTraceChannels + 1u;
    for (uint32_t k = 0; k < n; ++k) src[k] = {g, 0, k};
    while (!request_trace(*b, src, n)) std::this_thread::yield();
    uint64_t first = 0;
    while (!trace_applied(*b, &first)) std::this_thread::yield();
    EXPECT_GE(first, last_first);
    last_first = first;
  }
  stop.store(true);
  task.join();
  EXPECT_EQ(torn.load(), 0u);
}

}  // namespace
}  // namespace rtplc::io
