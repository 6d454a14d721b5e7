// Fake /proc + /sys trees for tests (spec: runtime.md, the doctor paragraph).
#include "kernel_rt/fake_host_tree.h"

#include <fmt/format.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace rtplc::kernel_rt {
namespace fs = std::filesystem;

FakeHostTree::FakeHostTree() {
  std::string tmpl = (fs::temp_directory_path() / "rtplc-host-XXXXXX").string();
  if (mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed for " + tmpl);
  root_ = tmpl;
}

FakeHostTree::~FakeHostTree() {
  std::error_code ec;
  fs::remove_all(root_, ec);
}

void FakeHostTree::write(std::string_view abs_path, std::string_view text) {
  const fs::path p = fs::path(root_) / fs::path(abs_path).relative_path();
  fs::create_directories(p.parent_path());
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) throw std::runtime_error("cannot write " + p.string());
}

void FakeHostTree::remove(std::string_view abs_path) {
  std::error_code ec;
  fs::remove_all(fs::path(root_) / fs::path(abs_path).relative_path(), ec);
}

namespace {

void write_common_hardware(FakeHostTree& t) {
  t.write("/sys/devices/system/cpu/online", "0-3\n");
  t.write("/sys/devices/system/clocksource/clocksource0/available_clocksource",
          "tsc hpet acpi_pm \n");
  t.write("/proc/sys/kernel/sched_rt_period_us", "1000000\n");
  t.write("/dev/cpu_dma_latency", "");
  for (int irq : {0, 1, 8, 9, 24, 25})
    t.write(fmt::format("/proc/irq/{}/smp_affinity_list", irq), "0-3\n");
}

}  // namespace

void FakeHostTree::make_tuned_rt_box(FakeHostTree& t) {
  write_common_hardware(t);
  const std::string release = "6.1.0-56-rt-amd64";
  t.write("/proc/sys/kernel/osrelease", release + "\n");
  t.write("/proc/sys/kernel/version", "#1 SMP PREEMPT_RT Debian 6.1.192-2 (2026-11-16)\n");
  t.write("/sys/kernel/realtime", "1\n");
  t.write("/boot/config-" + release,
          "CONFIG_PREEMPT_RT=y\nCONFIG_PREEMPT_LAZY=y\nCONFIG_NO_HZ_FULL=y\nCONFIG_HIGH_RES_TIMERS="
          "y\n");
  t.write("/proc/cmdline",
          "BOOT_IMAGE=/vmlinuz-6.1.0-56-rt-amd64 root=/dev/sda1 ro quiet "
          "isolcpus=managed_irq,domain,2-3 "
          "nohz_full=2-3 rcu_nocbs=2-3 nosmt\n");
  t.write("/sys/devices/system/cpu/isolated", "2-3\n");
  t.write("/sys/devices/system/cpu/nohz_full", "2-3\n");
  t.write("/proc/sys/kernel/sched_rt_runtime_us", "-1\n");
  t.write("/proc/irq/default_smp_affinity", "3\n");
  for (int irq : {0, 1, 8, 9, 24, 25})
    t.write(fmt::format("/proc/irq/{}/effective_affinity_list", irq), "0\n");
  for (int cpu = 0; cpu < 4; ++cpu) {
    t.write(fmt::format("/sys/devices/system/cpu/cpu{}/cpufreq/scaling_governor", cpu),
            "performance\n");
  }
  t.write("/sys/devices/system/clocksource/clocksource0/current_clocksource", "tsc\n");
  t.write("/sys/devices/system/cpu/smt/active", "0\n");
  t.write("/sys/devices/system/cpu/smt/control", "forceoff\n");
}

void FakeHostTree::make_stock_box(FakeHostTree& t) {
  write_common_hardware(t);
  const std::string release = "6.1.0-56-amd64";
  t.write("/proc/sys/kernel/osrelease", release + "\n");
  t.write("/proc/sys/kernel/version", "#1 SMP PREEMPT_DYNAMIC Debian 6.1.192-2 (2026-11-16)\n");
  t.write("/boot/config-" + release,
          "CONFIG_PREEMPT_VOLUNTARY=y\nCONFIG_PREEMPT_DYNAMIC=y\nCONFIG_NO_HZ_FULL=y\n"
          "CONFIG_HIGH_RES_TIMERS=y\n");
  t.write("/proc/cmdline", "BOOT_IMAGE=/vmlinuz-6.1.0-56-amd64 root=/dev/sda1 ro quiet\n");
  t.write("/sys/devices/system/cpu/isolated", "\n");
  t.write("/proc/sys/kernel/sched_rt_runtime_us", "950000\n");
  t.write("/proc/irq/default_smp_affinity", "f\n");
  for (int cpu = 0; cpu < 4; ++cpu) {
    t.write(fmt::format("/sys/devices/system/cpu/cpu{}/cpufreq/scaling_governor", cpu),
            "schedutil\n");
  }
  t.write("/sys/devices/system/clocksource/clocksource0/current_clocksource", "tsc\n");
  t.write("/sys/devices/system/cpu/smt/active", "1\n");
  t.write("/sys/devices/system/cpu/smt/control", "on\n");
}

}  // namespace rtplc::kernel_rt
