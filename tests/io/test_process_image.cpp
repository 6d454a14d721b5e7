// The process image: layout, attach checks, and the snapshot-ring protocol under
// a writer and readers running at once (consistent snapshots, never torn).
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <functional>
#include <thread>
#include <vector>

#include "io/process_image.h"
#include "sched/program.h"
#include "tests/support/same_cpu_preemption.h"

namespace rtplc::io {
namespace {

std::string unique_name(const char* what) {
  return std::string("test-") + what + "-" + std::to_string(getpid());
}

ImageLayout layout(const std::string& name, uint32_t cap) {
  ImageLayout l;
  l.name = name;
  l.channel_capacity = 16;
  l.regions.push_back({"task:a", RegionKind::kTask, 0, cap});
  l.regions.push_back({"setpoints", RegionKind::kSetpoints, 0, 4});
  l.n_tasks = 1;
  l.task_stats_bytes = 128;
  return l;
}

TEST(ProcessImage, creates_attaches_and_finds_channels) {
  auto img = ProcessImage::create(layout(unique_name("basic"), 8));
  ASSERT_TRUE(img.ok()) << img.error();
  ChannelDesc d{};
  std::strcpy(d.label, "PV");
  std::strcpy(d.key, "in/DIO/p0.d0.c0");
  d.region = 0;
  d.index = 3;
  ASSERT_TRUE(img->add_channel(d).ok());
  const uint32_t k = img->begin_write(0);
  img->put(0, k, 3, 42.5, Quality::kGood, 0);
  img->end_write(0, k, 123, 1);

  auto ro = ProcessImage::attach(std::string(img->header().name));
  ASSERT_TRUE(ro.ok()) << ro.error();
  EXPECT_FALSE(ro->writable());
  ASSERT_EQ(ro->find_channel("PV"), 0);
  const ChannelValue v = ro->read_channel(0);
  EXPECT_TRUE(v.fresh);
  EXPECT_EQ(v.value, 42.5);
  EXPECT_EQ(ro->find_channel("nope"), -1);
}

// Whether another runtime of the name runs is the runtime's lock's to say
// (tests/runtime/test_operating_safely.cpp), never a pid in the object: create()
// replaces whatever object is there, even one claiming a live pid.
TEST(ProcessImage, create_replaces_an_object_whatever_pid_it_claims) {
  const std::string n = unique_name("twice");
  auto a = ProcessImage::create(layout(n, 4));
  ASSERT_TRUE(a.ok());
  const_cast<ImageHeader&>(a->header()).pid = getppid();
  auto b = ProcessImage::create(layout(n, 4));
  ASSERT_TRUE(b.ok()) << b.error();
  EXPECT_EQ(b->header().pid, getpid());
}

TEST(ProcessImage, a_stale_image_of_a_dead_runtime_is_replaced) {
  const std::string n = unique_name("stale");
  auto leftover = ProcessImage::create(layout(n, 4));
  ASSERT_TRUE(leftover.ok());
  // As if its runtime had been killed with -9: the object stays, its pid is gone.
  const_cast<ImageHeader&>(leftover->header()).pid = 0x7ffffff0;
  auto fresh = ProcessImage::create(layout(n, 4));
  ASSERT_TRUE(fresh.ok()) << fresh.error();
  EXPECT_EQ(fresh->header().pid, getpid());
}

TEST(ProcessImage, liveness_sees_a_dead_pid_a_reused_pid_and_a_stale_heartbeat) {
  auto img = ProcessImage::create(layout(unique_name("alive"), 4));
  ASSERT_TRUE(img.ok());
  ImageHeader& h = img->header();
  EXPECT_TRUE(img->liveness().alive) << img->liveness().why;
  // A pid that exists but is another process than the one that made the image
  // (init: it started long before us, so its start time surely differs).
  const int32_t own = h.pid;
  h.pid = 1;
  EXPECT_FALSE(img->liveness().alive);
  EXPECT_NE(img->liveness().why.find("another program"), std::string::npos) << img->liveness().why;
  // A pid that is gone.
  h.pid = 0x7ffffff0;
  EXPECT_FALSE(img->liveness().alive);
  EXPECT_NE(img->liveness().why.find("is gone"), std::string::npos);
  // Our own process, but silent for longer than the timeout (a hung runtime).
  h.pid = own;
  h.heartbeat_ns.store(h.heartbeat_ns.load() - 2 * kHeartbeatTimeoutNs);
  EXPECT_FALSE(img->liveness().alive);
  EXPECT_NE(img->liveness().why.find("no heartbeat"), std::string::npos);
  img->beat();
  EXPECT_TRUE(img->liveness().alive);
}

TEST(ProcessImage, attach_refuses_something_that_is_not_an_image) {
  const std::string n = unique_name("garbage");
  const std::string obj = ProcessImage::shm_name(n);
  const int fd = shm_open(obj.c_str(), O_RDWR | O_CREAT | O_EXCL, 0600);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(ftruncate(fd, 4096), 0);
  void* p = mmap(nullptr, 4096, PROT_WRITE, MAP_SHARED, fd, 0);
  std::memset(p, 0x5a, 4096);
  munmap(p, 4096);
  close(fd);
  auto r = ProcessImage::attach(n);
  EXPECT_FALSE(r.ok());
  shm_unlink(obj.c_str());
  EXPECT_FALSE(ProcessImage::attach(unique_name("absent")).ok());
}

// Writer fills every value of snapshot n with n; readers must only ever see
// all-equal snapshots, and the snapshot number never goes backwards. All three
// threads start together (a barrier), so the readers really overlap the writer.
// The state a delayed reader can meet: it loaded published = 1, and meanwhile
// the writer rewrote slot 1 whole with publication 5 (version even again) but
// has not yet stored published = 5. The old protocol took 5 there and then 4 at
// its next read; a slot whose version names another lap is not publication 1.
TEST(ProcessImage, a_slot_already_rewritten_a_lap_later_is_not_taken_for_the_loaded_publication) {
  auto img = ProcessImage::create(layout(unique_name("lap"), 4));
  ASSERT_TRUE(img.ok());
  const ProcessImage& im = *img;
  auto write = [&](double v) {
    const uint32_t k = im.begin_write(0);
    for (uint32_t i = 0; i < 4; ++i) store_value(im.values(0, k) + i, v);
    im.end_write(0, k, 1, 1);
  };
  for (double v = 1; v <= 5; ++v) write(v);  // publications 1..5; 5 is in slot 1
  ASSERT_EQ(im.slot(0, 1).version.load(), slot_version_after(5));
  // Hold published at 1, as the delayed reader saw it.
  im.ring(0).published.store(1);
  const uint32_t src[4] = {0, 1, 2, 3};
  double out[4] = {};
  EXPECT_FALSE(im.read_values(0, src, 4, out, 3)) << "took publication " << out[0] << " for publication 1";
  // Once published says 5, it is read.
  im.ring(0).published.store(5);
  ASSERT_TRUE(im.read_values(0, src, 4, out, 3));
  EXPECT_EQ(out[0], 5);
  EXPECT_EQ(slot_version_after(1), 2u);
  EXPECT_EQ(slot_version_after(4), 2u);
  EXPECT_EQ(slot_version_after(5), 4u);
}

TEST(ProcessImage, readers_never_see_a_torn_snapshot) {
  constexpr uint32_t kCap = 64;
  auto img = ProcessImage::create(layout(unique_name("ring"), kCap));
  ASSERT_TRUE(img.ok());
  const ProcessImage& im = *img;
  std::atomic<bool> done{false};
  std::atomic<int> ready{0};
  auto wait_all = [&] {
    ready.fetch_add(1);
    while (ready.load() < 3) std::this_thread::yield();
  };
  std::atomic<uint64_t> overlapped{0};  // consistent reads taken while the writer ran
  std::thread writer([&] {
    wait_all();
    for (uint64_t n = 1; n <= 200000; ++n) {
      const uint32_t k = im.begin_write(0);
      double* v = im.values(0, k);
      for (uint32_t i = 0; i < kCap; ++i) store_value(v + i, static_cast<double>(n));
      im.end_write(0, k, static_cast<int64_t>(n), n);
    }
    done.store(true);
  });
  std::vector<uint32_t> src(kCap);
  for (uint32_t i = 0; i < kCap; ++i) src[i] = i;
  auto reader = [&] {
    std::vector<double> out(kCap);
    double last = 0;
    wait_all();
    while (!done.load()) {
      if (!im.read_values(0, src.data(), kCap, out.data(), 3)) continue;
      for (uint32_t i = 1; i < kCap; ++i) ASSERT_EQ(out[i], out[0]) << "torn snapshot";
      ASSERT_GE(out[0], last);
      last = out[0];
      if (out[0] > 0 && out[0] < 200000) overlapped.fetch_add(1);
    }
  };
  std::thread a(reader), b(reader);
  writer.join();
  a.join();
  b.join();
  EXPECT_GT(overlapped.load(), 0u) << "no read overlapped the writer: the test proved nothing";
}

// A task's input group is copied only from a validated snapshot: on a miss the
// task's inputs keep their last good values (the contract the runtime relies
// on). The writer laps the ring fast (mostly empty snapshots, every fourth a
// full one), so most reads of 512 values miss.
TEST(ProcessImage, a_missed_input_read_leaves_the_inputs_as_they_were) {
  constexpr uint32_t kCap = 512;
  auto img = ProcessImage::create(layout(unique_name("miss"), kCap));
  ASSERT_TRUE(img.ok());
  const ProcessImage& im = *img;
  std::atomic<bool> stop{false};
  std::atomic<bool> go{false};
  std::thread writer([&] {
    while (!go.load()) std::this_thread::yield();
    for (uint64_t n = 1; !stop.load(); ++n) {
      const uint32_t k = im.begin_write(0);
      if (n % 4 == 0) {
        double* v = im.values(0, k);
        for (uint32_t i = 0; i < kCap; ++i) store_value(v + i, static_cast<double>(n));
      }
      im.end_write(0, k, 0, n);
    }
  });
  sched::InputGroup g;
  g.region = 0;
  for (uint32_t i = 0; i < kCap; ++i) {
    g.src.push_back(i);
    g.dst.push_back(kCap - 1 - i);
  }
  g.size_buffers();
  std::vector<double> in(kCap, -1.0);  // -1: never read
  std::vector<uint8_t> status(kCap, 0);
  uint64_t misses = 0, hits = 0;
  go = true;
  for (int attempt = 0; attempt < 20000; ++attempt) {
    const std::vector<double> before = in;
    if (sched::read_group(im, g, in.data(), status.data(), 0, 1)) {
      ++hits;
      for (uint32_t i = 1; i < kCap; ++i) ASSERT_EQ(in[i], in[0]) << "inputs from two snapshots";
    } else {
      ++misses;
      ASSERT_EQ(in, before) << "a missed read changed the inputs";
    }
  }
  stop = true;
  writer.join();
  EXPECT_GT(misses, 0u) << "no read missed: the writer never lapped a reader (" << hits << " hits)";
}

// The writer is preempted between begin_write and end_write by a reader at a
// higher SCHED_FIFO priority on its own CPU: the reader reads the last
// completed snapshot at once (a plain seqlock would spin forever here).
TEST(ProcessImage, a_reader_preempting_the_writer_mid_write_on_its_cpu_reads_at_once) {
  auto img = ProcessImage::create(layout(unique_name("preempt"), 8));
  ASSERT_TRUE(img.ok());
  const ProcessImage& im = *img;
  const uint32_t k0 = im.begin_write(0);
  for (uint32_t i = 0; i < 8; ++i) im.put(0, k0, i, 1.0, Quality::kGood, 1);
  im.end_write(0, k0, 1, 1);
  std::vector<uint32_t> src = {0, 1, 2, 3, 4, 5, 6, 7};
  auto r = testing::run_preempting_reader(
      [&](const std::function<void()>& preempt) {
        const uint32_t k = im.begin_write(0);
        for (uint32_t i = 0; i < 4; ++i) im.put(0, k, i, 2.0, Quality::kGood, 2);
        preempt();
        for (uint32_t i = 4; i < 8; ++i) im.put(0, k, i, 2.0, Quality::kGood, 2);
        im.end_write(0, k, 2, 2);
      },
      [&] {
        double out[8] = {};
        if (!im.read_values(0, src.data(), 8, out, 3)) return false;
        for (double v : out) {
          if (v != 1.0) return false;
        }
        return true;
      });
  if (!r.ran) GTEST_SKIP() << r.why;
  EXPECT_TRUE(r.reader_preempted_writer);
  EXPECT_TRUE(r.read_ok);
}

// ChannelDesc::users (the tasks using each channel): the control thread moves a
// task's bit channel by channel when a program is swapped in; a reader that
// preempts it on its CPU mid-way reads each channel's mask whole, the new one
// where the writer has been and the old one where it has not. (A reader that
// groups channels per task, the Sparkplug link, reads them all again once the
// task's swap count moves, after the whole update.)
TEST(ProcessImage, a_reader_preempting_a_swaps_users_update_reads_each_mask_old_or_new) {
  auto img = ProcessImage::create(layout(unique_name("users"), 8));
  ASSERT_TRUE(img.ok()) << img.error();
  ProcessImage& im = *img;
  for (uint32_t c = 0; c < 4; ++c) {
    ChannelDesc d{};
    std::snprintf(d.label, sizeof d.label, "C%u", c);
    d.index = c;
    d.users = 0x1;
    ASSERT_TRUE(im.add_channel(d).ok());
  }
  auto r = testing::run_preempting_reader(
      [&](const std::function<void()>& preempt) {
        for (uint32_t c = 0; c < 4; ++c) {
          im.set_channel_users(c, 0x3);
          if (c == 1) preempt();
        }
      },
      [&] {
        return im.channel_users(0) == 0x3 && im.channel_users(1) == 0x3 && im.channel_users(2) == 0x1 &&
               im.channel_users(3) == 0x1;
      });
  if (!r.ran) GTEST_SKIP() << r.why;
  EXPECT_TRUE(r.reader_preempted_writer);
  EXPECT_TRUE(r.read_ok) << "each mask is the old or the new, as far as the writer got";
  for (uint32_t c = 0; c < 4; ++c) EXPECT_EQ(im.channel_users(c), 0x3);
}

TEST(ProcessImage, a_new_image_reads_bad_until_written_and_the_channel_count_is_published) {
  auto img = ProcessImage::create(layout(unique_name("fresh"), 4));
  ASSERT_TRUE(img.ok());
  ChannelDesc d{};
  std::strcpy(d.label, "X");
  d.region = 0;
  d.index = 1;
  ASSERT_TRUE(img->add_channel(d).ok());
  EXPECT_EQ(img->channel_count(), 1u);
  const ChannelValue v = img->read_channel(0);
  EXPECT_EQ(v.quality, Quality::kBad);  // nothing written: zeroed memory is never good
}

}  // namespace
}  // namespace rtplc::io
