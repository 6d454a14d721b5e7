// The force table of the process image (io/process_image.h, "Forcing"): a
// forced value replaces its writer's own in every snapshot until released,
// safe snapshots are never forced, a reader never sees a value nobody forced
// while the control thread forces and releases concurrently, and a region's
// writer that preempts the control thread mid-force on its CPU goes on at once.
#include <gtest/gtest.h>

#include <cstring>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <functional>
#include <thread>
#include <vector>

#include "io/process_image.h"
#include "tests/support/same_cpu_preemption.h"

namespace rtplc::io {
namespace {

std::string unique_name(const char* what) {
  return std::string("test-force-") + what + "-" + std::to_string(getpid());
}

ImageLayout layout(const std::string& name, uint32_t cap) {
  ImageLayout l;
  l.name = name;
  l.channel_capacity = 16;
  l.regions.push_back({"driver:a", RegionKind::kDriver, 0, cap});
  l.regions.push_back({"task:b", RegionKind::kTask, 0, cap});
  l.n_tasks = 1;
  l.task_stats_bytes = 128;
  return l;
}

// One snapshot of region r with every value `v`, as a writer publishes it.
void write_all(const ProcessImage& im, uint32_t r, uint32_t cap, double v, uint8_t state = 0) {
  const uint32_t k = im.begin_write(r);
  for (uint32_t i = 0; i < cap; ++i) im.put(r, k, i, v, Quality::kGood, 1);
  im.slot(r, k).region_state.store(state, std::memory_order_relaxed);
  im.end_write(r, k, 1, 1);
}

std::vector<double> read_all(const ProcessImage& im, uint32_t r, uint32_t cap) {
  std::vector<uint32_t> src(cap);
  for (uint32_t i = 0; i < cap; ++i) src[i] = i;
  std::vector<double> out(cap);
  EXPECT_TRUE(im.read_values(r, src.data(), cap, out.data(), 100));
  return out;
}

// What a reader shows as forced is what the snapshot holds: the flag comes
// with the forced value, in the writer's next snapshot, never before it (a
// source's value shown as forced) and never after the release.
TEST(ForceTable, a_channel_reads_forced_only_in_the_snapshot_that_holds_the_forced_value) {
  auto img = ProcessImage::create(layout(unique_name("flag"), 4));
  ASSERT_TRUE(img.ok()) << img.error();
  ChannelDesc d{};
  std::strcpy(d.label, "PV");
  std::strcpy(d.key, "in/DIO/p0.d0.c2");
  d.region = 0;
  d.index = 2;
  ASSERT_TRUE(img->add_channel(d).ok());
  const ProcessImage& im = *img;
  write_all(im, 0, 4, 1.0);
  im.force(0, 2, 7.5);
  ChannelValue cv = im.read_channel(0);
  EXPECT_FALSE(cv.forced) << "the source's value is still what the snapshot holds";
  EXPECT_EQ(cv.value, 1.0);
  EXPECT_EQ(cv.quality, Quality::kGood);
  write_all(im, 0, 4, 1.0);
  cv = im.read_channel(0);
  EXPECT_TRUE(cv.forced);
  EXPECT_EQ(cv.value, 7.5);
  EXPECT_EQ(cv.quality, Quality::kForced);
  EXPECT_TRUE(im.unforce(0, 2));
  cv = im.read_channel(0);
  EXPECT_TRUE(cv.forced) << "until the writer's next snapshot the value is the forced one";
  EXPECT_EQ(cv.value, 7.5);
  write_all(im, 0, 4, 2.0);
  cv = im.read_channel(0);
  EXPECT_FALSE(cv.forced);
  EXPECT_EQ(cv.value, 2.0);
  EXPECT_EQ(cv.quality, Quality::kGood);
}

TEST(ForceTable, a_forced_value_replaces_the_writers_own_until_released) {
  auto img = ProcessImage::create(layout(unique_name("basic"), 4));
  ASSERT_TRUE(img.ok()) << img.error();
  const ProcessImage& im = *img;
  EXPECT_EQ(im.force_region(0).n_forced.load(), 0u);
  im.force(0, 2, 7.5);
  EXPECT_EQ(im.force_region(0).n_forced.load(), 1u);
  EXPECT_EQ(im.force_region(1).n_forced.load(), 0u) << "another region is not touched";
  write_all(im, 0, 4, 1.0);
  write_all(im, 1, 4, 1.0);
  EXPECT_EQ(read_all(im, 0, 4), (std::vector<double>{1.0, 1.0, 7.5, 1.0}));
  EXPECT_EQ(read_all(im, 1, 4), (std::vector<double>{1.0, 1.0, 1.0, 1.0}));
  // Forcing it again changes the value, not the count.
  im.force(0, 2, -3);
  EXPECT_EQ(im.force_region(0).n_forced.load(), 1u);
  write_all(im, 0, 4, 2.0);
  EXPECT_EQ(read_all(im, 0, 4), (std::vector<double>{2.0, 2.0, -3.0, 2.0}));
  const ForcedValue f = im.forced(0, 2);
  EXPECT_TRUE(f.forced);
  EXPECT_EQ(f.value, -3.0);
  EXPECT_FALSE(im.forced(0, 1).forced);
  // A tool attached read-only sees the same table.
  auto tool = ProcessImage::attach(im.header().name);
  ASSERT_TRUE(tool.ok()) << tool.error();
  EXPECT_TRUE(tool->forced(0, 2).forced);
  EXPECT_EQ(tool->forced(0, 2).value, -3.0);
  // Released: the writer's value from the next snapshot on.
  EXPECT_TRUE(im.unforce(0, 2));
  EXPECT_FALSE(im.unforce(0, 2)) << "a second release has nothing to release";
  EXPECT_EQ(im.force_region(0).n_forced.load(), 0u);
  write_all(im, 0, 4, 3.0);
  EXPECT_EQ(read_all(im, 0, 4), (std::vector<double>{3.0, 3.0, 3.0, 3.0}));
  EXPECT_FALSE(tool->forced(0, 2).forced);
}

TEST(ForceTable, safe_values_of_a_stopped_task_win_over_forces) {
  auto img = ProcessImage::create(layout(unique_name("safe"), 2));
  ASSERT_TRUE(img.ok()) << img.error();
  const ProcessImage& im = *img;
  im.force(1, 0, 99);
  write_all(im, 1, 2, 0.0, /*state: outputs at their safe values*/ 1);
  EXPECT_EQ(read_all(im, 1, 2), (std::vector<double>{0.0, 0.0}));
  write_all(im, 1, 2, 5.0, 0);
  EXPECT_EQ(read_all(im, 1, 2), (std::vector<double>{99.0, 5.0}));
}

// The control thread forces, re-forces and releases entry 0 as fast as it
// can while the region's writer publishes snapshots and two readers read them:
// entry 0 is always either the writer's value of that snapshot (the same as
// entry 1's) or a value the control thread forced (a multiple of 1000), never
// anything else, and the readers see both.
TEST(ForceTable, readers_never_see_a_value_nobody_forced_while_forces_change) {
  constexpr uint32_t kCap = 8;
  auto img = ProcessImage::create(layout(unique_name("race"), kCap));
  ASSERT_TRUE(img.ok()) << img.error();
  const ProcessImage& im = *img;
  std::atomic<bool> done{false};
  std::atomic<uint64_t> saw_forced{0}, saw_own{0};
  std::thread control([&] {
    // Until the readers saw enough of both (bounded: on a box too busy to
    // interleave, the counts below say the test proved nothing).
    for (int n = 1; n <= 2000000 && (saw_forced.load() < 200 || saw_own.load() < 200); ++n) {
      // Each state gets its turn: the others run while this thread yields.
      im.force(0, 0, 1000.0 * n);
      std::this_thread::yield();
      if (n % 3 == 0) {
        im.unforce(0, 0);
        std::this_thread::yield();
      }
    }
    done.store(true);
  });
  std::thread writer([&] {
    for (uint64_t n = 1; !done.load(); ++n) write_all(im, 0, kCap, 0.5 + static_cast<double>(n % 1000));
  });
  auto reader = [&] {
    std::vector<uint32_t> src(kCap);
    for (uint32_t i = 0; i < kCap; ++i) src[i] = i;
    std::vector<double> out(kCap);
    while (!done.load()) {
      if (!im.read_values(0, src.data(), kCap, out.data(), 3)) continue;
      for (uint32_t i = 2; i < kCap; ++i) ASSERT_EQ(out[i], out[1]) << "torn snapshot";
      if (out[0] == out[1]) {
        saw_own.fetch_add(1);
      } else {
        ASSERT_GE(out[0], 1000.0) << "a value nobody forced: " << out[0];
        ASSERT_EQ(out[0], 1000.0 * static_cast<double>(static_cast<int64_t>(out[0] / 1000.0)))
            << "a torn forced value: " << out[0];
        saw_forced.fetch_add(1);
      }
    }
  };
  std::thread a(reader), b(reader);
  control.join();
  writer.join();
  a.join();
  b.join();
  EXPECT_GT(saw_forced.load(), 0u) << "no read saw a force: the test proved nothing";
  EXPECT_GT(saw_own.load(), 0u) << "no read saw a released entry: the test proved nothing";
}

// The control thread (FIFO 10 here) is between storing a force's value and
// its flag when a region's writer (FIFO 20, same CPU) preempts it: the writer
// publishes its snapshot and a reader reads it at once, with the entry not
// forced yet (its flag is not set), and nothing waits for the control thread.
TEST(ForceTable, a_writer_preempting_the_control_thread_mid_force_goes_on_at_once) {
  auto img = ProcessImage::create(layout(unique_name("preempt"), 4));
  ASSERT_TRUE(img.ok()) << img.error();
  const ProcessImage& im = *img;
  im.force(0, 1, 11.0);  // another entry of the region is already forced
  write_all(im, 0, 4, 1.0);
  auto r = testing::run_preempting_reader(
      [&](const std::function<void()>& preempt) {
        // force(0, 3, 42) in its two steps (see "Forcing" in process_image.h).
        im.force_entry(0, 3).value_bits.store(std::bit_cast<uint64_t>(42.0), std::memory_order_release);
        preempt();
        im.force(0, 3, 42.0);
      },
      [&] {
        write_all(im, 0, 4, 2.0);
        std::vector<uint32_t> src = {0, 1, 2, 3};
        double out[4] = {};
        if (!im.read_values(0, src.data(), 4, out, 1)) return false;
        return out[0] == 2.0 && out[1] == 11.0 && out[2] == 2.0 && out[3] == 2.0;
      });
  if (!r.ran) GTEST_SKIP() << r.why;
  EXPECT_TRUE(r.reader_preempted_writer);
  EXPECT_TRUE(r.read_ok);
  // The force completed afterwards (in the child: this process still sees its own table).
}

}  // namespace
}  // namespace rtplc::io
