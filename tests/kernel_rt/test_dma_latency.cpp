// Tests of the /dev/cpu_dma_latency request holder (kernel_rt/dma_latency.h).
#include "kernel_rt/dma_latency.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>

#include "kernel_rt/fake_host_tree.h"
#include "kernel_rt/host_files.h"

namespace rtplc::kernel_rt {
namespace {

TEST(CpuDmaLatency, default_request_holds_nothing) {
  CpuDmaLatencyRequest req;
  EXPECT_FALSE(req.active());
  req = CpuDmaLatencyRequest(0, "/nonexistent/cpu_dma_latency");
  EXPECT_FALSE(req.active());
}

TEST(CpuDmaLatency, missing_device_is_harmless_and_explained) {
  CpuDmaLatencyRequest req(0, "/nonexistent/cpu_dma_latency");
  EXPECT_FALSE(req.active());
  EXPECT_NE(req.status().find("absent"), std::string::npos) << req.status();
}

TEST(CpuDmaLatency, writes_the_value_as_32_bit_binary_and_holds_until_release) {
  FakeHostTree tree;
  tree.write("/dev/cpu_dma_latency", "");
  const std::string path = tree.root() + "/dev/cpu_dma_latency";
  CpuDmaLatencyRequest req(7, path);
  ASSERT_TRUE(req.active()) << req.status();
  const std::string bytes = HostFiles{}.read(path).value_or("");
  ASSERT_EQ(bytes.size(), 4u);
  int32_t v = -1;
  std::memcpy(&v, bytes.data(), 4);
  EXPECT_EQ(v, 7);

  CpuDmaLatencyRequest moved = std::move(req);
  EXPECT_FALSE(req.active());
  EXPECT_TRUE(moved.active());
  moved.release();
  EXPECT_FALSE(moved.active());
}

TEST(CpuDmaLatency, real_device_is_held_when_root) {
  if (access(kCpuDmaLatencyPath, W_OK) != 0) GTEST_SKIP() << "no writable " << kCpuDmaLatencyPath;
  CpuDmaLatencyRequest req(0);
  EXPECT_TRUE(req.active()) << req.status();
  EXPECT_NE(req.status().find("held at 0 us"), std::string::npos);
}

}  // namespace
}  // namespace rtplc::kernel_rt
