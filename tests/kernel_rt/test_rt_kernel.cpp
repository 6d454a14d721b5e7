// Tests of PREEMPT_RT detection and of the preemption model (kernel_rt/rt_kernel.h).
#include "kernel_rt/rt_kernel.h"

#include <gtest/gtest.h>

#include "kernel_rt/fake_host_tree.h"

namespace rtplc::kernel_rt {
namespace {

TEST(RtKernel, tuned_rt_box_is_realtime_by_every_witness) {
  FakeHostTree tree;
  FakeHostTree::make_tuned_rt_box(tree);
  const RtKernelInfo k = detect_rt_kernel(tree.files());
  EXPECT_TRUE(k.realtime);
  EXPECT_EQ(k.model, PreemptModel::kRt);
  EXPECT_EQ(k.release, "6.1.0-56-rt-amd64");
  ASSERT_EQ(k.evidence.size(), 3u);
  EXPECT_EQ(k.evidence[0], "/sys/kernel/realtime is 1");
}

TEST(RtKernel, each_witness_alone_is_enough) {
  {
    FakeHostTree t;
    t.write("/sys/kernel/realtime", "1\n");
    EXPECT_TRUE(detect_rt_kernel(t.files()).realtime);
  }
  {
    FakeHostTree t;
    t.write("/proc/sys/kernel/version", "#1 SMP PREEMPT_RT Debian 6.1.192-2\n");
    EXPECT_TRUE(detect_rt_kernel(t.files()).realtime);
  }
  {
    FakeHostTree t;  // the RT patch set before 5.x spelled it with a space
    t.write("/proc/sys/kernel/version", "#1 SMP PREEMPT RT Tue Jan 1 2019\n");
    EXPECT_TRUE(detect_rt_kernel(t.files()).realtime);
  }
  {
    FakeHostTree t;
    t.write("/proc/sys/kernel/osrelease", "6.12.0-custom\n");
    t.write("/boot/config-6.12.0-custom", "CONFIG_PREEMPT_RT=y\n");
    EXPECT_TRUE(detect_rt_kernel(t.files()).realtime);
  }
}

TEST(RtKernel, stock_kernel_is_not_realtime_and_reports_its_dynamic_default) {
  FakeHostTree tree;
  FakeHostTree::make_stock_box(tree);
  const RtKernelInfo k = detect_rt_kernel(tree.files());
  EXPECT_FALSE(k.realtime);
  EXPECT_TRUE(k.dynamic);
  EXPECT_EQ(k.model, PreemptModel::kVoluntary);
  EXPECT_NE(k.model_source.find("build default"), std::string::npos) << k.model_source;
  EXPECT_EQ(k.evidence.front(), "no /sys/kernel/realtime");
}

TEST(RtKernel, preempt_on_the_command_line_overrides_the_build_default) {
  FakeHostTree tree;
  FakeHostTree::make_stock_box(tree);
  tree.write("/proc/cmdline", "ro quiet preempt=full\n");
  const RtKernelInfo k = detect_rt_kernel(tree.files());
  EXPECT_EQ(k.model, PreemptModel::kFull);
  EXPECT_EQ(k.model_source, "preempt=full on the kernel command line");
}

TEST(RtKernel, debugfs_shows_the_model_chosen_at_run_time) {
  FakeHostTree tree;
  FakeHostTree::make_stock_box(tree);
  tree.write("/sys/kernel/debug/sched/preempt", "none voluntary full (lazy)\n");
  EXPECT_EQ(detect_rt_kernel(tree.files()).model, PreemptModel::kLazy);
}

TEST(RtKernel, sys_kernel_realtime_zero_is_not_rt) {
  FakeHostTree tree;
  tree.write("/sys/kernel/realtime", "0\n");
  tree.write("/proc/sys/kernel/version", "#1 SMP PREEMPT Debian\n");
  const RtKernelInfo k = detect_rt_kernel(tree.files());
  EXPECT_FALSE(k.realtime);
  EXPECT_EQ(k.model, PreemptModel::kFull);
}

TEST(RtKernel, live_detection_runs_and_names_the_kernel) {
  const RtKernelInfo k = detect_rt_kernel(HostFiles{});
  EXPECT_FALSE(k.release.empty());
  EXPECT_FALSE(k.version.empty());
  EXPECT_EQ(k.realtime, running_on_rt_kernel());
}

}  // namespace
}  // namespace rtplc::kernel_rt
