// Tests of root-prefixed reads and the parsers of /proc and /sys contents (kernel_rt/host_files.h).
#include "kernel_rt/host_files.h"

#include <gtest/gtest.h>

#include "kernel_rt/fake_host_tree.h"

namespace rtplc::kernel_rt {
namespace {

using Cpus = std::vector<unsigned>;

TEST(HostFiles, parse_cpu_list_reads_ranges_singles_and_isolcpus_flags) {
  EXPECT_EQ(parse_cpu_list("0-3,8,10-11\n"), (Cpus{0, 1, 2, 3, 8, 10, 11}));
  EXPECT_EQ(parse_cpu_list("managed_irq,domain,2-3"), (Cpus{2, 3}));
  EXPECT_EQ(parse_cpu_list("nohz,1"), (Cpus{1}));
  EXPECT_EQ(parse_cpu_list(""), Cpus{});
  EXPECT_EQ(parse_cpu_list("(null)"), Cpus{});
  EXPECT_EQ(parse_cpu_list("3,1,1-2"), (Cpus{1, 2, 3}));
  EXPECT_EQ(parse_cpu_list("1,3-x,5"), (Cpus{1})) << "stops at garbage";
  EXPECT_EQ(parse_cpu_list("5-2"), Cpus{}) << "reversed range is malformed";
}

TEST(HostFiles, format_cpu_list_collapses_runs) {
  EXPECT_EQ(format_cpu_list({0, 1, 2, 3, 8, 10, 11}), "0-3,8,10-11");
  EXPECT_EQ(format_cpu_list({}), "");
  EXPECT_EQ(format_cpu_list({5}), "5");
}

TEST(HostFiles, parse_cpu_mask_reads_comma_grouped_hex) {
  EXPECT_EQ(parse_cpu_mask("f"), (Cpus{0, 1, 2, 3}));
  EXPECT_EQ(parse_cpu_mask("00000000,00000003\n"), (Cpus{0, 1}));
  EXPECT_EQ(parse_cpu_mask("A"), (Cpus{1, 3}));
  EXPECT_EQ(parse_cpu_mask("1,00000000"), (Cpus{32}));
  EXPECT_EQ(parse_cpu_mask("zz"), Cpus{});
}

TEST(HostFiles, cmdline_value_finds_keys_flags_and_ignores_init_arguments) {
  const std::string cl =
      "BOOT_IMAGE=/vmlinuz ro isolcpus=1 quiet nosmt isolcpus=2-3 "
      "dyndbg=\"file x +p\" -- nohz_full=1";
  EXPECT_EQ(cmdline_value(cl, "isolcpus"), "2-3") << "the last one wins";
  EXPECT_EQ(cmdline_value(cl, "nosmt"), "");
  EXPECT_EQ(cmdline_value(cl, "dyndbg"), "file x +p");
  EXPECT_EQ(cmdline_value(cl, "nohz_full"), std::nullopt) << "after -- it is init's";
  EXPECT_EQ(cmdline_value(cl, "iso"), std::nullopt);
}

TEST(HostFiles, config_value_reads_set_and_unset_options) {
  const std::string cfg =
      "# comment\nCONFIG_PREEMPT_RT=y\n# CONFIG_PREEMPT is not set\n"
      "CONFIG_LOCALVERSION=\"-rt\"\nCONFIG_HZ=250";
  EXPECT_EQ(config_value(cfg, "PREEMPT_RT"), "y");
  EXPECT_EQ(config_value(cfg, "PREEMPT"), std::nullopt);
  EXPECT_EQ(config_value(cfg, "LOCALVERSION"), "-rt");
  EXPECT_EQ(config_value(cfg, "HZ"), "250");
  EXPECT_EQ(config_value(cfg, "PREEMPT_R"), std::nullopt);
}

TEST(HostFiles, reads_below_the_root_prefix) {
  FakeHostTree tree;
  tree.write("/proc/sys/kernel/sched_rt_runtime_us", "  950000 \n");
  tree.write("/sys/devices/system/cpu/cpu1/online", "1\n");
  tree.write("/sys/devices/system/cpu/cpu0/online", "1\n");
  const HostFiles files = tree.files();
  EXPECT_FALSE(files.is_live());
  EXPECT_EQ(files.path("/proc/cmdline"), tree.root() + "/proc/cmdline");
  EXPECT_EQ(files.read_integer("/proc/sys/kernel/sched_rt_runtime_us"), 950000);
  EXPECT_EQ(files.read_line("/proc/sys/kernel/sched_rt_runtime_us"), "950000");
  EXPECT_EQ(files.read("/nope"), std::nullopt);
  EXPECT_FALSE(files.exists("/nope"));
  EXPECT_TRUE(files.exists("/sys/devices/system/cpu/cpu1"));
  EXPECT_EQ(files.list_dir("/sys/devices/system/cpu"), (std::vector<std::string>{"cpu0", "cpu1"}));
  EXPECT_TRUE(files.list_dir("/nope").empty());
}

TEST(HostFiles, kernel_config_falls_back_to_boot_config_of_the_release) {
  FakeHostTree tree;
  EXPECT_EQ(tree.files().kernel_config(), std::nullopt);
  tree.write("/proc/sys/kernel/osrelease", "6.1.0-56-rt-amd64\n");
  tree.write("/boot/config-6.1.0-56-rt-amd64", "CONFIG_PREEMPT_RT=y\n");
  const auto cfg = tree.files().kernel_config();
  ASSERT_TRUE(cfg.has_value());
  EXPECT_EQ(cfg->second, "/boot/config-6.1.0-56-rt-amd64");
  EXPECT_EQ(config_value(cfg->first, "PREEMPT_RT"), "y");
}

TEST(HostFiles, live_proc_files_of_size_zero_are_read_whole) {
  const HostFiles live;
  EXPECT_TRUE(live.is_live());
  const auto status = live.read("/proc/self/status");
  ASSERT_TRUE(status.has_value());
  EXPECT_NE(status->find("VmRSS"), std::string::npos);
}

}  // namespace
}  // namespace rtplc::kernel_rt
