// Tests of the one-call process preparation (kernel_rt/rt_process.h).
#include "kernel_rt/rt_process.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include "kernel_rt/rt_kernel.h"

namespace rtplc::kernel_rt {
namespace {

TEST(RtProcess, says_once_what_is_missing_and_locks_when_it_can) {
  MemoryLockOptions opt;
  opt.heap_reserve_bytes = 4u << 20;
  opt.stack_prefault_bytes = 64u << 10;
  RtProcess p = prepare_process_for_rt(opt);
  EXPECT_EQ(p.rt_kernel, running_on_rt_kernel());
  size_t expected_notices = 0;
  if (!p.rt_kernel) {
    ++expected_notices;
    EXPECT_NE(p.notices.front().find("is not PREEMPT_RT"), std::string::npos) << p.notices.front();
  }
  if (geteuid() == 0 && memory_locking_supported()) {
    EXPECT_TRUE(p.memory_locked);
  } else {
    ++expected_notices;
  }
  if (access(kCpuDmaLatencyPath, W_OK) == 0) {
    EXPECT_TRUE(p.cpu_dma_latency.active()) << p.cpu_dma_latency.status();
  } else {
    ++expected_notices;
  }
  EXPECT_EQ(p.notices.size(), expected_notices);
  unlock_memory();
}

}  // namespace
}  // namespace rtplc::kernel_rt
