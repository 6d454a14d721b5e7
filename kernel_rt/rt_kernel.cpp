// PREEMPT_RT detection and preemption model (spec: runtime.md, "Tasks and the scheduler").
#include "kernel_rt/rt_kernel.h"

#include <sys/utsname.h>

#include <optional>
#include <sstream>

namespace rtplc::kernel_rt {
namespace {

bool has_token(const std::string& text, std::string_view token) {
  std::istringstream words(text);
  std::string w;
  while (words >> w) {
    if (w == token) return true;
  }
  return false;
}

bool version_says_rt(const std::string& version) {
  // Current RT kernels print "PREEMPT_RT"; the RT patch set before 5.x printed "PREEMPT RT".
  return has_token(version, "PREEMPT_RT") || version.find("PREEMPT RT") != std::string::npos;
}

std::optional<PreemptModel> model_from_word(std::string_view w) {
  if (w == "none") return PreemptModel::kNone;
  if (w == "voluntary") return PreemptModel::kVoluntary;
  if (w == "full") return PreemptModel::kFull;
  if (w == "lazy") return PreemptModel::kLazy;
  return std::nullopt;
}

// The boot-time default of a PREEMPT_DYNAMIC kernel, or the fixed model of another one.
std::optional<PreemptModel> model_from_config(const std::string& config) {
  // The Kconfig choice is exclusive except that RT kernels also select PREEMPT_LAZY,
  // so PREEMPT_RT is asked first.
  if (config_value(config, "PREEMPT_RT") == "y") return PreemptModel::kRt;
  if (config_value(config, "PREEMPT_NONE") == "y") return PreemptModel::kNone;
  if (config_value(config, "PREEMPT_VOLUNTARY") == "y") return PreemptModel::kVoluntary;
  if (config_value(config, "PREEMPT") == "y") return PreemptModel::kFull;
  if (config_value(config, "PREEMPT_LAZY") == "y") return PreemptModel::kLazy;
  return std::nullopt;
}

// debugfs shows the dynamic model as "none voluntary (full) lazy": the chosen one in brackets.
std::optional<PreemptModel> model_from_debugfs(const std::string& line) {
  const size_t open = line.find('(');
  const size_t close = line.find(')', open);
  if (open == std::string::npos || close == std::string::npos) return std::nullopt;
  return model_from_word(std::string_view(line).substr(open + 1, close - open - 1));
}

}  // namespace

const char* preempt_model_name(PreemptModel m) noexcept {
  switch (m) {
    case PreemptModel::kNone:
      return "none";
    case PreemptModel::kVoluntary:
      return "voluntary";
    case PreemptModel::kFull:
      return "full";
    case PreemptModel::kLazy:
      return "lazy";
    case PreemptModel::kRt:
      return "PREEMPT_RT";
    case PreemptModel::kUnknown:
      break;
  }
  return "unknown";
}

RtKernelInfo detect_rt_kernel(const HostFiles& files) {
  RtKernelInfo info;
  info.release = files.read_line("/proc/sys/kernel/osrelease").value_or("");
  info.version = files.read_line("/proc/sys/kernel/version").value_or("");
  if (files.is_live() && (info.version.empty() || info.release.empty())) {
    utsname u{};
    if (uname(&u) == 0) {
      if (info.version.empty()) info.version = u.version;
      if (info.release.empty()) info.release = u.release;
    }
  }

  bool rt = false;
  if (auto flag = files.read_line("/sys/kernel/realtime")) {
    const bool on = *flag == "1";
    info.evidence.push_back("/sys/kernel/realtime is " + *flag);
    rt = rt || on;
  } else {
    info.evidence.emplace_back("no /sys/kernel/realtime");
  }
  if (!info.version.empty()) {
    const bool says = version_says_rt(info.version);
    info.evidence.push_back("uname -v \"" + info.version + "\"");
    rt = rt || says;
  }
  const auto config = files.kernel_config();
  if (config) {
    const bool cfg_rt = config_value(config->first, "PREEMPT_RT") == "y";
    info.evidence.push_back(
        std::string(cfg_rt ? "CONFIG_PREEMPT_RT=y" : "CONFIG_PREEMPT_RT not set") + " (" +
        config->second + ")");
    rt = rt || cfg_rt;
    info.dynamic = config_value(config->first, "PREEMPT_DYNAMIC") == "y";
  }
  info.dynamic = info.dynamic || has_token(info.version, "PREEMPT_DYNAMIC");
  info.realtime = rt;

  if (rt) {
    info.model = PreemptModel::kRt;
    info.model_source = "PREEMPT_RT kernel";
    return info;
  }
  if (auto dbg = files.read_line("/sys/kernel/debug/sched/preempt")) {
    if (auto m = model_from_debugfs(*dbg)) {
      info.model = *m;
      info.model_source = "/sys/kernel/debug/sched/preempt";
      return info;
    }
  }
  if (info.dynamic) {
    const auto cmdline = files.read_line("/proc/cmdline");
    if (cmdline) {
      if (auto v = cmdline_value(*cmdline, "preempt")) {
        if (auto m = model_from_word(*v)) {
          info.model = *m;
          info.model_source = "preempt=" + *v + " on the kernel command line";
          return info;
        }
      }
    }
    if (config) {
      if (auto m = model_from_config(config->first)) {
        info.model = *m;
        info.model_source =
            "build default in " + config->second + ", no preempt= on the command line";
      }
    }
    return info;
  }
  if (config) {
    if (auto m = model_from_config(config->first)) {
      info.model = *m;
      info.model_source = config->second;
      return info;
    }
  }
  if (has_token(info.version, "PREEMPT")) {
    info.model = PreemptModel::kFull;
    info.model_source = "uname -v";
  }
  return info;
}

bool running_on_rt_kernel() {
  return detect_rt_kernel(HostFiles{}).realtime;
}

}  // namespace rtplc::kernel_rt
