// `rtplc doctor`: is this machine ready for real time, and what to change if not
// (spec: runtime.md, "Tasks and the scheduler": doctor reports the kernel, rt throttling,
// isolated CPUs, governor, memlock limit; issue 3 scope 1).
//
// Each check reads files below a HostFiles root plus the live ProcessFacts, and gives a
// verdict, what it found and, unless OK, the exact command or file to change. It is a pure
// function of those two inputs so tests can feed fake /proc and /sys trees.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "kernel_rt/host_files.h"
#include "kernel_rt/process_limits.h"
#include "kernel_rt/rt_kernel.h"

namespace rtplc::kernel_rt {

enum class Verdict : uint8_t {
  kOk,    // ready as it is
  kWarn,  // works, but latency will be worse than it could be
  kFail,  // real-time guarantees do not hold until this is fixed
};

const char* verdict_name(Verdict v) noexcept;  // "OK", "WARN", "FAIL"

struct DoctorCheck {
  std::string id;     // stable key for scripts, e.g. "kernel.realtime"
  std::string title;  // what a person reads in the table
  Verdict verdict = Verdict::kOk;
  std::string found;  // what was seen, with the file it came from
  std::string fix;    // what to change and how (empty when OK)
};

struct DoctorReport {
  RtKernelInfo kernel;
  std::vector<DoctorCheck> checks;

  size_t count(Verdict v) const noexcept;
  // Ready = no FAIL. WARNs cost latency but do not break the guarantees.
  bool ready() const noexcept { return count(Verdict::kFail) == 0; }
  const DoctorCheck* find(std::string_view id) const noexcept;
};

// Runs every check. `files` selects the /proc and /sys tree, `process` the permissions.
DoctorReport run_doctor(const HostFiles& files, const ProcessFacts& process);

// The live machine and this process.
DoctorReport run_doctor();

// RLIMIT_MEMLOCK below this fails the memlock check for an unprivileged process: the
// process image, the heap reserve and 16 task stacks do not fit.
inline constexpr uint64_t kMinMemlockBytes = 256u * 1024u * 1024u;

}  // namespace rtplc::kernel_rt
