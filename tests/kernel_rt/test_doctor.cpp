// Tests of the doctor's verdicts on fake /proc + /sys trees, and of its renderings
// (kernel_rt/doctor.h, kernel_rt/doctor_render.h).
#include "kernel_rt/doctor.h"

#include <gtest/gtest.h>

#include "kernel_rt/doctor_render.h"
#include "kernel_rt/fake_host_tree.h"

namespace rtplc::kernel_rt {
namespace {

// A process that may do everything: root on an RT box.
ProcessFacts privileged() {
  ProcessFacts p;
  p.euid = 0;
  p.memlock_soft = p.memlock_hard = 8u << 20;
  p.rtprio_soft = p.rtprio_hard = 0;
  p.cap_sys_nice = p.cap_ipc_lock = true;
  p.fifo_probe_priority = kFifoProbePriority;
  p.fifo_obtained = true;
  p.fifo_detail = "a probe thread ran SCHED_FIFO priority 49";
  p.monotonic_resolution_ns = 1;
  return p;
}

// A service user with the limits a systemd unit from scripts/deploy gives it.
ProcessFacts service_user() {
  ProcessFacts p = privileged();
  p.euid = 1000;
  p.cap_sys_nice = p.cap_ipc_lock = false;
  p.memlock_soft = p.memlock_hard = kUnlimited;
  p.rtprio_soft = p.rtprio_hard = 99;
  return p;
}

Verdict verdict_of(const DoctorReport& r, std::string_view id) {
  const DoctorCheck* c = r.find(id);
  EXPECT_NE(c, nullptr) << id;
  return c != nullptr ? c->verdict : Verdict::kFail;
}

std::string found_of(const DoctorReport& r, std::string_view id) {
  const DoctorCheck* c = r.find(id);
  return c != nullptr ? c->found : "";
}

std::string fix_of(const DoctorReport& r, std::string_view id) {
  const DoctorCheck* c = r.find(id);
  return c != nullptr ? c->fix : "";
}

struct Box {
  FakeHostTree tree;
  explicit Box(bool rt) {
    if (rt) {
      FakeHostTree::make_tuned_rt_box(tree);
    } else {
      FakeHostTree::make_stock_box(tree);
    }
  }
  DoctorReport run(const ProcessFacts& p = privileged()) const {
    return run_doctor(tree.files(), p);
  }
};

TEST(Doctor, tuned_rt_box_passes_every_check) {
  Box box(true);
  const DoctorReport r = box.run();
  for (const auto& c : r.checks) {
    EXPECT_EQ(c.verdict, Verdict::kOk) << c.id << ": " << c.found << " | " << c.fix;
    EXPECT_EQ(c.fix, "") << c.id;
  }
  EXPECT_TRUE(r.ready());
  EXPECT_EQ(r.checks.size(), 14u);
}

TEST(Doctor, every_check_has_a_stable_id_and_a_finding) {
  Box box(false);
  const DoctorReport r = box.run();
  for (const char* id :
       {"kernel.realtime", "kernel.preemption", "sched.fifo", "limits.rtprio", "limits.memlock",
        "sched.rt_throttling", "clock.hres", "clock.source", "cpu.count", "cpu.isolation",
        "irq.affinity", "cpu.governor", "cpu.smt", "pm.cpu_dma_latency"}) {
    const DoctorCheck* c = r.find(id);
    ASSERT_NE(c, nullptr) << id;
    EXPECT_FALSE(c->found.empty()) << id;
    EXPECT_EQ(c->verdict != Verdict::kOk, !c->fix.empty())
        << id << ": every non-OK line says how to fix it";
  }
}

TEST(Doctor, non_rt_kernel_fails_and_says_how_to_get_one) {
  Box box(false);
  const DoctorReport r = box.run();
  EXPECT_FALSE(r.ready());
  EXPECT_EQ(verdict_of(r, "kernel.realtime"), Verdict::kFail);
  EXPECT_NE(found_of(r, "kernel.realtime").find("NOT a PREEMPT_RT kernel 6.1.0-56-amd64"),
            std::string::npos);
  EXPECT_NE(fix_of(r, "kernel.realtime").find("apt-get install linux-image-rt-amd64"),
            std::string::npos);
  EXPECT_EQ(verdict_of(r, "kernel.preemption"), Verdict::kWarn);
  EXPECT_NE(fix_of(r, "kernel.preemption").find("preempt=full"), std::string::npos);
}

TEST(Doctor, rt_kernel_is_ok_even_when_the_rest_is_untuned) {
  Box box(false);
  box.tree.write("/sys/kernel/realtime", "1\n");
  const DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "kernel.realtime"), Verdict::kOk);
  EXPECT_EQ(verdict_of(r, "kernel.preemption"), Verdict::kOk);
  EXPECT_TRUE(r.ready()) << "untuned settings are warnings, not failures";
  EXPECT_GT(r.count(Verdict::kWarn), 3u);
}

TEST(Doctor, rt_throttling_on_warns_with_the_sysctl_and_off_is_ok) {
  Box box(true);
  box.tree.write("/proc/sys/kernel/sched_rt_runtime_us", "950000\n");
  DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "sched.rt_throttling"), Verdict::kWarn);
  EXPECT_NE(found_of(r, "sched.rt_throttling").find("950000 us of every 1000000 us (95%)"),
            std::string::npos)
      << found_of(r, "sched.rt_throttling");
  EXPECT_NE(fix_of(r, "sched.rt_throttling").find("sysctl -w kernel.sched_rt_runtime_us=-1"),
            std::string::npos);

  box.tree.write("/proc/sys/kernel/sched_rt_runtime_us", "-1\n");
  r = box.run();
  EXPECT_EQ(verdict_of(r, "sched.rt_throttling"), Verdict::kOk);

  box.tree.write("/proc/sys/kernel/sched_rt_runtime_us",
                 "1000000\n");  // runtime == period: never throttles
  EXPECT_EQ(verdict_of(box.run(), "sched.rt_throttling"), Verdict::kOk);

  box.tree.remove("/proc/sys/kernel/sched_rt_runtime_us");
  EXPECT_EQ(verdict_of(box.run(), "sched.rt_throttling"), Verdict::kWarn);
}

TEST(Doctor, no_isolation_suggests_all_cpus_but_the_first) {
  Box box(false);
  const DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "cpu.isolation"), Verdict::kWarn);
  const std::string fix = fix_of(r, "cpu.isolation");
  EXPECT_NE(fix.find("isolcpus=managed_irq,domain,1-3 nohz_full=1-3 rcu_nocbs=1-3"),
            std::string::npos)
      << fix;
  EXPECT_NE(fix.find("update-grub"), std::string::npos);
  EXPECT_EQ(verdict_of(r, "irq.affinity"), Verdict::kOk)
      << "nothing isolated, nothing to keep IRQs off";
}

TEST(Doctor, isolation_without_rcu_nocbs_asks_only_for_what_is_missing) {
  Box box(true);
  box.tree.write("/proc/cmdline", "ro isolcpus=2-3 nohz_full=2-3\n");
  const DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "cpu.isolation"), Verdict::kWarn);
  const std::string fix = fix_of(r, "cpu.isolation");
  EXPECT_NE(fix.find("`rcu_nocbs=2-3`"), std::string::npos) << fix;
  EXPECT_EQ(fix.find("isolcpus="), std::string::npos) << fix;
}

TEST(Doctor, nohz_full_is_not_asked_of_a_kernel_built_without_it) {
  Box box(false);
  box.tree.write("/boot/config-6.1.0-56-amd64",
                 "CONFIG_PREEMPT_VOLUNTARY=y\nCONFIG_PREEMPT_DYNAMIC=y\n");
  const DoctorReport r = box.run();
  EXPECT_EQ(fix_of(r, "cpu.isolation").find("nohz_full="), std::string::npos)
      << fix_of(r, "cpu.isolation");
  EXPECT_NE(found_of(r, "cpu.isolation").find("without NO_HZ_FULL"), std::string::npos);
}

TEST(Doctor, one_cpu_cannot_be_isolated) {
  Box box(false);
  box.tree.write("/sys/devices/system/cpu/online", "0\n");
  const DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "cpu.count"), Verdict::kWarn);
  EXPECT_EQ(verdict_of(r, "cpu.isolation"), Verdict::kWarn);
  EXPECT_NE(fix_of(r, "cpu.isolation").find("at least 2 CPUs"), std::string::npos);
}

TEST(Doctor, irqs_on_isolated_cpus_warn_with_a_mask_for_the_rest) {
  Box box(true);
  box.tree.write("/proc/irq/24/effective_affinity_list", "3\n");
  box.tree.write("/proc/irq/default_smp_affinity", "f\n");
  const DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "irq.affinity"), Verdict::kWarn);
  EXPECT_NE(found_of(r, "irq.affinity").find("1 of 6 IRQs"), std::string::npos)
      << found_of(r, "irq.affinity");
  EXPECT_NE(found_of(r, "irq.affinity").find("IRQ 24"), std::string::npos);
  // Housekeeping CPUs 0-1 = mask 3.
  EXPECT_NE(fix_of(r, "irq.affinity").find("echo 3 > /proc/irq/default_smp_affinity"),
            std::string::npos)
      << fix_of(r, "irq.affinity");
  EXPECT_NE(fix_of(r, "irq.affinity").find("IRQBALANCE_BANNED_CPULIST=2-3"), std::string::npos);
}

TEST(Doctor, low_memlock_fails_for_an_unprivileged_user) {
  Box box(true);
  ProcessFacts p = service_user();
  EXPECT_EQ(verdict_of(box.run(p), "limits.memlock"), Verdict::kOk);

  p.memlock_soft = p.memlock_hard = 64u * 1024u;
  DoctorReport r = box.run(p);
  EXPECT_EQ(verdict_of(r, "limits.memlock"), Verdict::kFail);
  EXPECT_NE(found_of(r, "limits.memlock").find("RLIMIT_MEMLOCK 64 KiB"), std::string::npos);
  EXPECT_NE(fix_of(r, "limits.memlock").find("LimitMEMLOCK=infinity"), std::string::npos);
  EXPECT_FALSE(r.ready());

  p.memlock_soft = p.memlock_hard = 512u << 20;
  EXPECT_EQ(verdict_of(box.run(p), "limits.memlock"), Verdict::kWarn);

  // Root's 8 MiB limit does not matter: CAP_IPC_LOCK lifts it.
  r = box.run(privileged());
  EXPECT_EQ(verdict_of(r, "limits.memlock"), Verdict::kOk);
  EXPECT_NE(found_of(r, "limits.memlock").find("CAP_IPC_LOCK"), std::string::npos);
}

TEST(Doctor, rtprio_limit_and_fifo_probe) {
  Box box(true);
  ProcessFacts p = service_user();
  EXPECT_EQ(verdict_of(box.run(p), "limits.rtprio"), Verdict::kOk);

  p.rtprio_soft = p.rtprio_hard = 20;
  EXPECT_EQ(verdict_of(box.run(p), "limits.rtprio"), Verdict::kWarn);

  p.rtprio_soft = p.rtprio_hard = 0;
  p.fifo_obtained = false;
  p.fifo_detail = "a probe thread asking for SCHED_FIFO 49 was refused and ran SCHED_OTHER";
  const DoctorReport r = box.run(p);
  EXPECT_EQ(verdict_of(r, "limits.rtprio"), Verdict::kFail);
  EXPECT_EQ(verdict_of(r, "sched.fifo"), Verdict::kFail);
  EXPECT_NE(fix_of(r, "sched.fifo").find("LimitRTPRIO=99"), std::string::npos);
  EXPECT_FALSE(r.ready());
}

TEST(Doctor, governor_other_than_performance_warns) {
  Box box(true);
  box.tree.write("/sys/devices/system/cpu/cpu2/cpufreq/scaling_governor", "powersave\n");
  const DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "cpu.governor"), Verdict::kWarn);
  EXPECT_NE(found_of(r, "cpu.governor").find("performance on CPU 0-1,3"), std::string::npos)
      << found_of(r, "cpu.governor");
  EXPECT_NE(found_of(r, "cpu.governor").find("powersave on CPU 2"), std::string::npos);
  for (int cpu = 0; cpu < 4; ++cpu)
    box.tree.remove("/sys/devices/system/cpu/cpu" + std::to_string(cpu));
  EXPECT_EQ(verdict_of(box.run(), "cpu.governor"), Verdict::kOk) << "no cpufreq: nothing to tune";
}

TEST(Doctor, slow_clocksource_warns_and_offers_tsc_when_available) {
  Box box(true);
  box.tree.write("/sys/devices/system/clocksource/clocksource0/current_clocksource", "hpet\n");
  DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "clock.source"), Verdict::kWarn);
  EXPECT_NE(fix_of(r, "clock.source").find("echo tsc >"), std::string::npos);
  box.tree.write("/sys/devices/system/clocksource/clocksource0/current_clocksource", "kvm-clock\n");
  EXPECT_EQ(verdict_of(box.run(), "clock.source"), Verdict::kOk);
}

TEST(Doctor, tick_resolution_timers_fail) {
  Box box(true);
  ProcessFacts p = privileged();
  p.monotonic_resolution_ns = 4'000'000;
  EXPECT_EQ(verdict_of(box.run(p), "clock.hres"), Verdict::kFail);
}

TEST(Doctor, smt_and_missing_dma_latency_warn) {
  Box box(true);
  box.tree.write("/sys/devices/system/cpu/smt/active", "1\n");
  box.tree.remove("/dev/cpu_dma_latency");
  const DoctorReport r = box.run();
  EXPECT_EQ(verdict_of(r, "cpu.smt"), Verdict::kWarn);
  EXPECT_NE(fix_of(r, "cpu.smt").find("nosmt"), std::string::npos);
  EXPECT_EQ(verdict_of(r, "pm.cpu_dma_latency"), Verdict::kWarn);
  EXPECT_NE(fix_of(r, "pm.cpu_dma_latency").find("max_cstate"), std::string::npos);
  EXPECT_TRUE(r.ready());
}

TEST(DoctorRender, table_states_the_outcome_and_the_fixes) {
  Box box(false);
  const DoctorReport r = box.run();
  const std::string table = render_doctor_table(r, TableStyle{80, false});
  EXPECT_NE(table.find("is NOT PREEMPT_RT"), std::string::npos);
  EXPECT_NE(table.find("FAIL  PREEMPT_RT kernel"), std::string::npos) << table;
  EXPECT_NE(table.find("fix: "), std::string::npos);
  EXPECT_NE(table.find("NOT READY for real time: 1 FAIL"), std::string::npos) << table;
  EXPECT_EQ(table.find("\x1b["), std::string::npos) << "no colour unless asked";
  size_t start = 0;
  while (start < table.size()) {
    const size_t nl = table.find('\n', start);
    const size_t len = (nl == std::string::npos ? table.size() : nl) - start;
    const std::string line = table.substr(start, len);
    // Lines stay within the width unless a single word (a path, a command) is longer.
    if (line.find(' ', 40) != std::string::npos) {
      EXPECT_LE(len, 80u) << line;
    }
    start = nl == std::string::npos ? table.size() : nl + 1;
  }

  Box good(true);
  EXPECT_NE(render_doctor_table(good.run()).find("READY for real time: all 14 checks OK."),
            std::string::npos);
}

TEST(DoctorRender, json_carries_every_check_and_escapes_strings) {
  Box box(false);
  const DoctorReport r = box.run();
  const std::string json = render_doctor_json(r);
  EXPECT_NE(json.find("\"ready\": false"), std::string::npos);
  EXPECT_NE(json.find("\"realtime\": false"), std::string::npos);
  EXPECT_NE(
      json.find(
          "\"id\": \"kernel.realtime\", \"title\": \"PREEMPT_RT kernel\", \"verdict\": \"fail\""),
      std::string::npos)
      << json;
  EXPECT_NE(json.find("\"fail\": 1"), std::string::npos);
  EXPECT_NE(json.find("uname -v \\\"#1 SMP PREEMPT_DYNAMIC"), std::string::npos)
      << "quotes escaped";
  EXPECT_EQ(json_quote("a\"b\\c\nd\x01"), "\"a\\\"b\\\\c\\nd\\u0001\"");
}

TEST(Doctor, live_run_works_on_any_kernel) {
  const DoctorReport r = run_doctor();
  EXPECT_EQ(r.checks.size(), 14u);
  EXPECT_FALSE(r.kernel.release.empty());
  const DoctorCheck* k = r.find("kernel.realtime");
  ASSERT_NE(k, nullptr);
  EXPECT_EQ(k->verdict == Verdict::kOk, r.kernel.realtime);
}

}  // namespace
}  // namespace rtplc::kernel_rt
