// Is this a PREEMPT_RT kernel, and which preemption model is in force? (spec: runtime.md,
// "Tasks and the scheduler": `/sys/kernel/realtime`, `uname -v`; issue: /proc/config.gz).
//
// Three independent witnesses are consulted and each one that speaks is kept as evidence, so
// `doctor` can say *why* it believes what it reports:
//   /sys/kernel/realtime      "1" on kernels built with the RT patch set
//   uname -v                  contains "PREEMPT_RT" (or "PREEMPT RT" on old RT kernels)
//   kernel config             CONFIG_PREEMPT_RT=y (/proc/config.gz or /boot/config-<release>)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "kernel_rt/host_files.h"

namespace rtplc::kernel_rt {

enum class PreemptModel : uint8_t {
  kUnknown,
  kNone,       // server: preempts only at explicit points, latencies of milliseconds
  kVoluntary,  // desktop default of many distributions: extra preemption points
  kFull,       // CONFIG_PREEMPT / preempt=full: preemptible except in spinlocks/irq-off code
  kLazy,       // preempt=lazy (6.13+): full for RT tasks, batched for normal ones
  kRt,         // PREEMPT_RT: spinlocks sleep, interrupts in threads; bounded latency
};

const char* preempt_model_name(PreemptModel m) noexcept;

struct RtKernelInfo {
  bool realtime = false;
  std::string release;  // uname -r
  std::string version;  // uname -v
  PreemptModel model = PreemptModel::kUnknown;
  bool dynamic = false;               // PREEMPT_DYNAMIC: the model is chosen at boot with preempt=
  std::string model_source;           // where `model` was read
  std::vector<std::string> evidence;  // one line per witness that spoke, for or against
};

// Reads the witnesses below `files`' root. For the live system (root "/"), uname(2) stands in
// when /proc/sys/kernel/version is unreadable.
RtKernelInfo detect_rt_kernel(const HostFiles& files);

// Live shortcut for callers that only need the yes/no (e.g. to say once at start-up that
// timing will not be deterministic). Reads the files each time; call it once.
bool running_on_rt_kernel();

}  // namespace rtplc::kernel_rt
