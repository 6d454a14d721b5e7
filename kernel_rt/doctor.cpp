// The checks behind `rtplc doctor` (spec: runtime.md, "Tasks and the scheduler", the doctor
// paragraph; docs/rt-tuning.md explains each setting at length).
#include "kernel_rt/doctor.h"

#include <fmt/format.h>
#include <algorithm>
#include <map>

namespace rtplc::kernel_rt {
namespace {

// The kernel command line is edited in one place on Debian; every fix that needs a boot
// parameter ends with the same two steps.
constexpr const char* kGrubSteps = "in /etc/default/grub, then `update-grub` and reboot";

std::string mib(uint64_t bytes) {
  if (bytes == kUnlimited) return "unlimited";
  if (bytes < 1024u * 1024u) return fmt::format("{} KiB", bytes / 1024u);
  return fmt::format("{} MiB", bytes / (1024u * 1024u));
}

std::string joined(const std::vector<std::string>& parts, std::string_view sep) {
  std::string out;
  for (const auto& p : parts) {
    if (!out.empty()) out += sep;
    out += p;
  }
  return out;
}

std::vector<unsigned> online_cpus(const HostFiles& files) {
  if (auto online = files.read_line("/sys/devices/system/cpu/online")) {
    auto cpus = parse_cpu_list(*online);
    if (!cpus.empty()) return cpus;
  }
  std::vector<unsigned> cpus;
  for (const auto& name : files.list_dir("/sys/devices/system/cpu")) {
    if (name.size() > 3 && name.compare(0, 3, "cpu") == 0 &&
        std::all_of(name.begin() + 3, name.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      cpus.push_back(static_cast<unsigned>(std::stoul(name.substr(3))));
    }
  }
  std::sort(cpus.begin(), cpus.end());
  return cpus;
}

std::vector<unsigned> minus(const std::vector<unsigned>& a, const std::vector<unsigned>& b) {
  std::vector<unsigned> out;
  std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
  return out;
}

std::vector<unsigned> intersect(const std::vector<unsigned>& a, const std::vector<unsigned>& b) {
  std::vector<unsigned> out;
  std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
  return out;
}

std::string hex_mask(const std::vector<unsigned>& cpus) {
  unsigned max = 0;
  for (unsigned c : cpus) max = std::max(max, c);
  std::string digits((max / 4u) + 1u, '0');
  for (unsigned c : cpus) {
    char& d = digits[digits.size() - 1 - c / 4u];
    const unsigned v = static_cast<unsigned>(d >= 'a' ? d - 'a' + 10 : d - '0') | (1u << (c % 4u));
    d = static_cast<char>(v < 10 ? '0' + v : 'a' + (v - 10));
  }
  return digits;
}

// CPUs to suggest for isolation: every online CPU but the first, which keeps the
// housekeeping (timers, RCU callbacks, interrupts, the non-RT threads of the runtime).
std::vector<unsigned> suggested_isolation(const std::vector<unsigned>& online) {
  if (online.size() < 2) return {};
  return std::vector<unsigned>(online.begin() + 1, online.end());
}

DoctorCheck check_kernel(const RtKernelInfo& k) {
  DoctorCheck c{"kernel.realtime", "PREEMPT_RT kernel", Verdict::kOk, "", ""};
  const std::string evidence = joined(k.evidence, "; ");
  if (k.realtime) {
    c.found = fmt::format("PREEMPT_RT kernel {}: {}", k.release, evidence);
    return c;
  }
  c.verdict = Verdict::kFail;
  c.found = fmt::format("NOT a PREEMPT_RT kernel {}: {}; wake-up latency has no bound", k.release,
                        evidence);
  c.fix =
      "install Debian's real-time kernel and boot it: `apt-get install linux-image-rt-amd64`, "
      "reboot and pick the '-rt-amd64' entry (GRUB 'Advanced options'; make it the default with "
      "GRUB_DEFAULT in /etc/default/grub and `update-grub`)";
  return c;
}

DoctorCheck check_preemption(const RtKernelInfo& k) {
  DoctorCheck c{"kernel.preemption", "preemption model", Verdict::kOk, "", ""};
  std::vector<std::string> notes;
  if (!k.model_source.empty() && k.model != PreemptModel::kRt)
    notes.push_back("from " + k.model_source);
  if (k.dynamic && k.model != PreemptModel::kRt)
    notes.emplace_back("PREEMPT_DYNAMIC kernel: preempt= chooses at boot");
  const std::string tail = notes.empty() ? "" : " (" + joined(notes, "; ") + ")";
  const std::string name = preempt_model_name(k.model);
  switch (k.model) {
    case PreemptModel::kRt:
      c.found =
          "PREEMPT_RT: interrupt handlers run as threads and spinlocks can sleep, so an RT "
          "task preempts almost everything";
      return c;
    case PreemptModel::kFull:
    case PreemptModel::kLazy:
      c.verdict = Verdict::kWarn;
      c.found = name +
                ": the best a non-RT kernel offers, but code under spinlocks or with "
                "interrupts off still delays RT tasks without bound" +
                tail;
      c.fix = "boot a PREEMPT_RT kernel (see kernel.realtime)";
      return c;
    case PreemptModel::kNone:
    case PreemptModel::kVoluntary:
    case PreemptModel::kUnknown:
      break;
  }
  c.verdict = Verdict::kWarn;
  c.found = name +
            ": the kernel preempts only at chosen points, delays of milliseconds are normal" + tail;
  c.fix = k.dynamic ? fmt::format(
                          "boot a PREEMPT_RT kernel (see kernel.realtime); until then add "
                          "`preempt=full` to GRUB_CMDLINE_LINUX {}",
                          kGrubSteps)
                    : "boot a PREEMPT_RT kernel (see kernel.realtime)";
  return c;
}

DoctorCheck check_rt_throttling(const HostFiles& files) {
  DoctorCheck c{"sched.rt_throttling", "RT throttling", Verdict::kOk, "", ""};
  const auto runtime = files.read_integer("/proc/sys/kernel/sched_rt_runtime_us");
  const auto period = files.read_integer("/proc/sys/kernel/sched_rt_period_us");
  if (!runtime) {
    c.verdict = Verdict::kWarn;
    c.found = "/proc/sys/kernel/sched_rt_runtime_us unreadable: throttling state unknown";
    c.fix = "check with `sysctl kernel.sched_rt_runtime_us` (-1 = off)";
    return c;
  }
  if (*runtime < 0 || (period && *runtime >= *period)) {
    c.found = fmt::format(
        "off (kernel.sched_rt_runtime_us = {}): RT tasks are never paused by the "
        "kernel; the runtime's watchdog is what stops a runaway task",
        *runtime);
    return c;
  }
  const long long per = period.value_or(1'000'000);
  c.verdict = Verdict::kWarn;
  c.found = fmt::format(
      "on: RT threads may use {} us of every {} us ({:.0f}%) on a CPU, then the kernel pauses "
      "them for the rest of the period, a missed deadline of up to {} ms",
      *runtime, per, 100.0 * static_cast<double>(*runtime) / static_cast<double>(per),
      (per - *runtime) / 1000);
  c.fix =
      "`sysctl -w kernel.sched_rt_runtime_us=-1` now; for good, "
      "`echo kernel.sched_rt_runtime_us=-1 > /etc/sysctl.d/60-rtplc.conf` "
      "(keep CPU 0 unisolated so a runaway RT task cannot lock up the whole machine)";
  return c;
}

DoctorCheck check_isolation(const HostFiles& files, const std::vector<unsigned>& online) {
  DoctorCheck c{"cpu.isolation", "isolated CPUs", Verdict::kOk, "", ""};
  const std::string cmdline = files.read_line("/proc/cmdline").value_or("");
  const auto isolated =
      parse_cpu_list(files.read_line("/sys/devices/system/cpu/isolated").value_or(""));
  std::vector<unsigned> nohz;
  if (auto f = files.read_line("/sys/devices/system/cpu/nohz_full")) {
    nohz = parse_cpu_list(*f);
  } else if (auto v = cmdline_value(cmdline, "nohz_full")) {
    nohz = parse_cpu_list(*v);
  }
  const auto nocb = parse_cpu_list(cmdline_value(cmdline, "rcu_nocbs").value_or(""));

  // nohz_full only exists in kernels built with NO_HZ_FULL; do not ask for it otherwise.
  bool nohz_possible = true;
  if (auto cfg = files.kernel_config())
    nohz_possible = config_value(cfg->first, "NO_HZ_FULL") == "y";

  auto show = [](const std::vector<unsigned>& v) {
    return v.empty() ? std::string("none") : format_cpu_list(v);
  };
  c.found = fmt::format("isolated: {}; nohz_full: {}; rcu_nocbs: {} (of online CPUs {})",
                        show(isolated), show(nohz), show(nocb), show(online));

  if (online.size() < 2) {
    c.verdict = Verdict::kWarn;
    c.found += "; with one CPU nothing can be isolated";
    c.fix = "give the machine (or the VM) at least 2 CPUs, then isolate all but CPU 0";
    return c;
  }
  const auto target = isolated.empty() ? suggested_isolation(online) : isolated;
  const std::string list = format_cpu_list(target);
  std::vector<std::string> missing;
  if (isolated.empty()) missing.push_back(fmt::format("isolcpus=managed_irq,domain,{}", list));
  if (nohz_possible && !minus(target, nohz).empty())
    missing.push_back(fmt::format("nohz_full={}", list));
  if (!minus(target, nocb).empty()) missing.push_back(fmt::format("rcu_nocbs={}", list));
  if (missing.empty()) {
    c.found += "; tasks pinned there (config `cpu:`) share their CPU with nothing else";
    return c;
  }
  c.verdict = Verdict::kWarn;
  if (isolated.empty()) c.found += "; RT tasks share every CPU with the rest of the system";
  if (!nohz_possible) c.found += "; this kernel is built without NO_HZ_FULL";
  c.fix = fmt::format(
      "add `{}` to GRUB_CMDLINE_LINUX {}; then pin tasks to CPU {} with `cpu:` in the "
      "runtime config",
      joined(missing, " "), kGrubSteps, list);
  return c;
}

DoctorCheck check_irq_affinity(const HostFiles& files, const std::vector<unsigned>& online) {
  DoctorCheck c{"irq.affinity", "IRQs off isolated CPUs", Verdict::kOk, "", ""};
  const auto isolated =
      parse_cpu_list(files.read_line("/sys/devices/system/cpu/isolated").value_or(""));
  if (isolated.empty()) {
    c.found = "nothing to check: no CPU is isolated (see cpu.isolation)";
    return c;
  }
  const auto housekeeping = minus(online, isolated);
  const auto deflt = parse_cpu_mask(files.read_line("/proc/irq/default_smp_affinity").value_or(""));
  size_t total = 0;
  std::vector<std::string> offenders;
  for (const auto& name : files.list_dir("/proc/irq")) {
    if (name.empty() ||
        !std::all_of(name.begin(), name.end(), [](char ch) { return ch >= '0' && ch <= '9'; })) {
      continue;
    }
    // The effective affinity is where the interrupt really lands; the requested one is a
    // superset the chip may narrow.
    auto eff = files.read_line("/proc/irq/" + name + "/effective_affinity_list");
    if (!eff || eff->empty()) eff = files.read_line("/proc/irq/" + name + "/smp_affinity_list");
    if (!eff) continue;
    ++total;
    if (!intersect(parse_cpu_list(*eff), isolated).empty()) offenders.push_back(name);
  }
  const bool default_hits = !intersect(deflt, isolated).empty();
  c.found = fmt::format(
      "{} of {} IRQs may fire on isolated CPUs {}{}", offenders.size(), total,
      format_cpu_list(isolated),
      default_hits ? "; new IRQs default to them too (/proc/irq/default_smp_affinity)" : "");
  if (offenders.size() > 8) {
    offenders.resize(8);
    offenders.emplace_back("...");
  }
  if (!offenders.empty()) c.found += " (IRQ " + joined(offenders, ", ") + ")";
  if (offenders.empty() && !default_hits) return c;
  c.verdict = Verdict::kWarn;
  const std::string hk =
      format_cpu_list(housekeeping.empty() ? std::vector<unsigned>{0} : housekeeping);
  c.fix = fmt::format(
      "`echo {} > /proc/irq/default_smp_affinity; for i in /proc/irq/[0-9]*; do echo {} > "
      "$i/smp_affinity_list; done` (some IRQs refuse, that is fine); if irqbalance runs, set "
      "IRQBALANCE_BANNED_CPULIST={} in /etc/default/irqbalance",
      hex_mask(housekeeping.empty() ? std::vector<unsigned>{0} : housekeeping), hk,
      format_cpu_list(isolated));
  return c;
}

DoctorCheck check_governor(const HostFiles& files, const std::vector<unsigned>& online) {
  DoctorCheck c{"cpu.governor", "CPU frequency governor", Verdict::kOk, "", ""};
  std::map<std::string, std::vector<unsigned>> by_governor;
  for (unsigned cpu : online) {
    if (auto g = files.read_line(
            fmt::format("/sys/devices/system/cpu/cpu{}/cpufreq/scaling_governor", cpu))) {
      by_governor[*g].push_back(cpu);
    }
  }
  if (by_governor.empty()) {
    c.found = "no cpufreq driver: the frequency is fixed or left to the firmware/hypervisor";
    return c;
  }
  std::vector<std::string> parts;
  for (const auto& [g, cpus] : by_governor)
    parts.push_back(fmt::format("{} on CPU {}", g, format_cpu_list(cpus)));
  c.found = joined(parts, "; ");
  if (by_governor.size() == 1 && by_governor.begin()->first == "performance") return c;
  c.verdict = Verdict::kWarn;
  c.found += ": frequency changes stretch execution times and add wake-up latency";
  c.fix =
      "`cpupower frequency-set -g performance` (package linux-cpupower) or `for g in "
      "/sys/devices/system/cpu/cpu*/cpufreq/scaling_governor; do echo performance > $g; done`; for "
      "good, add `cpufreq.default_governor=performance` to GRUB_CMDLINE_LINUX " +
      std::string(kGrubSteps);
  return c;
}

constexpr const char* kLimitsFile = "/etc/security/limits.d/rtplc.conf";

DoctorCheck check_memlock(const ProcessFacts& p) {
  DoctorCheck c{"limits.memlock", "locked-memory limit", Verdict::kOk, "", ""};
  const std::string limit =
      fmt::format("RLIMIT_MEMLOCK {} (hard {})", mib(p.memlock_soft), mib(p.memlock_hard));
  if (p.cap_ipc_lock) {
    c.found = limit + "; CAP_IPC_LOCK lifts it for this process" + (p.euid == 0 ? " (root)" : "");
    return c;
  }
  if (p.memlock_soft == kUnlimited) {
    c.found = limit;
    return c;
  }
  c.fix = fmt::format(
      "`<user> - memlock unlimited` in {} (new login), `LimitMEMLOCK=infinity` in the systemd "
      "unit (scripts/deploy sets it), or `ulimit -l unlimited` as root before starting",
      kLimitsFile);
  if (p.memlock_soft >= kMinMemlockBytes) {
    c.verdict = Verdict::kWarn;
    c.found = limit +
              ": enough for a small configuration; a larger process image or heap reserve will "
              "fail to lock and then page-fault in a cycle";
    return c;
  }
  c.verdict = Verdict::kFail;
  c.found = fmt::format(
      "{}: below the {} the runtime locks; mlockall will fail and cycles will "
      "page-fault",
      limit, mib(kMinMemlockBytes));
  return c;
}

DoctorCheck check_rtprio(const ProcessFacts& p) {
  DoctorCheck c{"limits.rtprio", "real-time priority limit", Verdict::kOk, "", ""};
  const auto show = [](uint64_t v) {
    return v == kUnlimited ? std::string("unlimited") : std::to_string(v);
  };
  const std::string limit =
      fmt::format("RLIMIT_RTPRIO {} (hard {})", show(p.rtprio_soft), show(p.rtprio_hard));
  if (p.cap_sys_nice) {
    c.found = limit + "; CAP_SYS_NICE lifts it for this process" + (p.euid == 0 ? " (root)" : "");
    return c;
  }
  const uint64_t needed = static_cast<uint64_t>(kFifoProbePriority);
  c.fix = fmt::format(
      "`<user> - rtprio 99` in {} (new login) or `LimitRTPRIO=99` in the systemd "
      "unit (scripts/deploy sets it)",
      kLimitsFile);
  if (p.rtprio_soft >= needed) {
    c.found = limit;
    c.fix.clear();
    return c;
  }
  if (p.rtprio_soft > 0) {
    c.verdict = Verdict::kWarn;
    c.found = fmt::format(
        "{}: tasks above priority {} will run SCHED_OTHER (the default band reaches {})", limit,
        p.rtprio_soft, needed);
    return c;
  }
  c.verdict = Verdict::kFail;
  c.found = limit + ": no SCHED_FIFO at all without CAP_SYS_NICE";
  return c;
}

DoctorCheck check_fifo(const ProcessFacts& p) {
  DoctorCheck c{"sched.fifo", "SCHED_FIFO obtainable", Verdict::kOk, "", ""};
  c.found = p.fifo_detail.empty() ? "not probed" : p.fifo_detail;
  if (p.fifo_obtained) return c;
  c.verdict = Verdict::kFail;
  c.found += ": tasks would run SCHED_OTHER, timing is best effort";
  c.fix = fmt::format(
      "run as root, or grant it: `<user> - rtprio 99` in {}, `LimitRTPRIO=99` in the systemd "
      "unit, or `setcap cap_sys_nice,cap_ipc_lock+ep $(command -v rtplc)`; in a container add "
      "`--cap-add=SYS_NICE`",
      kLimitsFile);
  return c;
}

DoctorCheck check_dma_latency(const HostFiles& files) {
  DoctorCheck c{"pm.cpu_dma_latency", "/dev/cpu_dma_latency", Verdict::kOk, "", ""};
  if (!files.exists("/dev/cpu_dma_latency")) {
    c.verdict = Verdict::kWarn;
    c.found =
        "absent: idle states cannot be limited from user space; waking from a deep C-state "
        "adds tens to hundreds of microseconds";
    c.fix = "add `processor.max_cstate=1 intel_idle.max_cstate=0` to GRUB_CMDLINE_LINUX " +
            std::string(kGrubSteps);
    return c;
  }
  if (files.writable("/dev/cpu_dma_latency")) {
    c.found =
        "writable: the runtime holds it at 0 us while it runs (CPUs stay in shallow idle states)";
    return c;
  }
  c.verdict = Verdict::kWarn;
  c.found = "present but not writable by this user: deep idle states stay allowed";
  c.fix =
      "run as root, or allow a group: a udev rule `KERNEL==\"cpu_dma_latency\", GROUP=\"rtplc\", "
      "MODE=\"0660\"` in /etc/udev/rules.d/60-rtplc.rules";
  return c;
}

DoctorCheck check_clocksource(const HostFiles& files) {
  DoctorCheck c{"clock.source", "clock source", Verdict::kOk, "", ""};
  const std::string dir = "/sys/devices/system/clocksource/clocksource0/";
  const auto current = files.read_line(dir + "current_clocksource");
  const std::string available = files.read_line(dir + "available_clocksource").value_or("");
  if (!current) {
    c.verdict = Verdict::kWarn;
    c.found = "unknown (" + dir + "current_clocksource unreadable)";
    c.fix = "check with `cat " + dir + "current_clocksource`";
    return c;
  }
  c.found = *current + (available.empty() ? "" : " (available: " + available + ")");
  if (*current == "tsc") return c;
  if (*current == "kvm-clock" || *current == "hyperv_clocksource_tsc_page" || *current == "xen" ||
      *current == "arch_sys_counter") {
    c.found += ": read in user space without a system call";
    return c;
  }
  c.verdict = Verdict::kWarn;
  c.found += ": every clock read enters the kernel and costs microseconds";
  const bool has_tsc = (" " + available + " ").find(" tsc ") != std::string::npos;
  c.fix =
      has_tsc
          ? "`echo tsc > " + dir +
                "current_clocksource` now; for good add `clocksource=tsc` to GRUB_CMDLINE_LINUX " +
                kGrubSteps
          : "the kernel rejected the TSC (see `dmesg | grep -i tsc`): use hardware with an "
            "invariant TSC and check the firmware's power settings; in a VM, give the guest an "
            "invariant TSC (qemu: -cpu host,+invtsc with KVM)";
  return c;
}

DoctorCheck check_hres(const ProcessFacts& p) {
  DoctorCheck c{"clock.hres", "high-resolution timers", Verdict::kOk, "", ""};
  if (p.monotonic_resolution_ns <= 0) {
    c.verdict = Verdict::kWarn;
    c.found = "clock_getres(CLOCK_MONOTONIC) failed";
    c.fix = "check that the kernel has CONFIG_HIGH_RES_TIMERS=y";
    return c;
  }
  c.found = fmt::format("CLOCK_MONOTONIC resolution {} ns", p.monotonic_resolution_ns);
  if (p.monotonic_resolution_ns <= 1000) return c;
  c.verdict = Verdict::kFail;
  c.found += ": sleeps end only on a scheduler tick, periods below that are impossible";
  c.fix =
      "remove `highres=off` from the kernel command line; the kernel needs "
      "CONFIG_HIGH_RES_TIMERS=y";
  return c;
}

DoctorCheck check_cpu_count(const std::vector<unsigned>& online) {
  DoctorCheck c{"cpu.count", "CPUs online", Verdict::kOk, "", ""};
  c.found = fmt::format("{} online ({})", online.size(),
                        online.empty() ? "none found" : format_cpu_list(online));
  if (online.size() >= 2) return c;
  c.verdict = Verdict::kWarn;
  c.found += ": RT tasks, interrupts and everything else share one CPU";
  c.fix = "use a machine (or give the VM) at least 2 CPUs so one can be isolated for the tasks";
  return c;
}

DoctorCheck check_smt(const HostFiles& files) {
  DoctorCheck c{"cpu.smt", "SMT (hyper-threading)", Verdict::kOk, "", ""};
  const auto active = files.read_line("/sys/devices/system/cpu/smt/active");
  const std::string control =
      files.read_line("/sys/devices/system/cpu/smt/control").value_or("unknown");
  if (!active || *active != "1") {
    c.found = fmt::format("inactive (control: {})", control);
    return c;
  }
  c.verdict = Verdict::kWarn;
  c.found = fmt::format(
      "active (control: {}): a busy sibling thread shares the core and stretches "
      "RT execution times",
      control);
  c.fix =
      "`echo off > /sys/devices/system/cpu/smt/control` now; for good add `nosmt` to "
      "GRUB_CMDLINE_LINUX " +
      std::string(kGrubSteps) + " (or disable Hyper-Threading in the firmware)";
  return c;
}

}  // namespace

const char* verdict_name(Verdict v) noexcept {
  switch (v) {
    case Verdict::kOk:
      return "OK";
    case Verdict::kWarn:
      return "WARN";
    case Verdict::kFail:
      return "FAIL";
  }
  return "?";
}

size_t DoctorReport::count(Verdict v) const noexcept {
  return static_cast<size_t>(std::count_if(checks.begin(), checks.end(),
                                           [v](const DoctorCheck& c) { return c.verdict == v; }));
}

const DoctorCheck* DoctorReport::find(std::string_view id) const noexcept {
  for (const auto& c : checks) {
    if (c.id == id) return &c;
  }
  return nullptr;
}

DoctorReport run_doctor(const HostFiles& files, const ProcessFacts& process) {
  DoctorReport r;
  r.kernel = detect_rt_kernel(files);
  const auto online = online_cpus(files);
  r.checks.push_back(check_kernel(r.kernel));
  r.checks.push_back(check_preemption(r.kernel));
  r.checks.push_back(check_fifo(process));
  r.checks.push_back(check_rtprio(process));
  r.checks.push_back(check_memlock(process));
  r.checks.push_back(check_rt_throttling(files));
  r.checks.push_back(check_hres(process));
  r.checks.push_back(check_clocksource(files));
  r.checks.push_back(check_cpu_count(online));
  r.checks.push_back(check_isolation(files, online));
  r.checks.push_back(check_irq_affinity(files, online));
  r.checks.push_back(check_governor(files, online));
  r.checks.push_back(check_smt(files));
  r.checks.push_back(check_dma_latency(files));
  return r;
}

DoctorReport run_doctor() {
  return run_doctor(HostFiles{}, probe_process_facts());
}

}  // namespace rtplc::kernel_rt
