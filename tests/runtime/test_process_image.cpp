// The process image: layout, attach checks, and the snapshot-ring protocol under
// a writer and readers running at once (consistent snapshots, never torn).
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <thread>
#include <vector>

#include "io/process_image.h"

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
  img->values(0, k)[3] = 42.5;
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

TEST(ProcessImage, a_second_live_runtime_with_the_same_name_is_refused) {
  const std::string n = unique_name("twice");
  auto a = ProcessImage::create(layout(n, 4));
  ASSERT_TRUE(a.ok());
  // Our own pid owns it; a different live pid is what blocks. Simulate one.
  const_cast<ImageHeader&>(a->header()).pid = getppid();
  auto b = ProcessImage::create(layout(n, 4));
  EXPECT_FALSE(b.ok());
  if (!b.ok()) {
    EXPECT_NE(b.error().find("already running"), std::string::npos);
  }
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
// all-equal snapshots, and the snapshot number never goes backwards.
TEST(ProcessImage, readers_never_see_a_torn_snapshot) {
  constexpr uint32_t kCap = 64;
  auto img = ProcessImage::create(layout(unique_name("ring"), kCap));
  ASSERT_TRUE(img.ok());
  const ProcessImage& im = *img;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (uint64_t n = 1; n <= 200000; ++n) {
      const uint32_t k = im.begin_write(0);
      double* v = im.values(0, k);
      for (uint32_t i = 0; i < kCap; ++i) store_relaxed(v + i, static_cast<double>(n));
      im.end_write(0, k, static_cast<int64_t>(n), n);
    }
    done.store(true);
  });
  std::vector<uint32_t> src(kCap), dst(kCap);
  for (uint32_t i = 0; i < kCap; ++i) src[i] = dst[i] = i;
  auto reader = [&](uint64_t* reads, uint64_t* misses) {
    std::vector<double> out(kCap);
    double last = 0;
    while (!done.load()) {
      if (!im.read_values(0, src.data(), dst.data(), kCap, out.data(), 3)) {
        ++*misses;
        continue;
      }
      ++*reads;
      for (uint32_t i = 1; i < kCap; ++i) ASSERT_EQ(out[i], out[0]) << "torn snapshot";
      ASSERT_GE(out[0], last);
      last = out[0];
    }
  };
  uint64_t r1 = 0, m1 = 0, r2 = 0, m2 = 0;
  std::thread a(reader, &r1, &m1), b(reader, &r2, &m2);
  writer.join();
  a.join();
  b.join();
  EXPECT_GT(r1 + r2, 0u);
}

}  // namespace
}  // namespace rtplc::io
