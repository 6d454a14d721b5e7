// `rtplc doctor [--json] [--strict]`: is this machine ready for real time, and what to change
// (spec: runtime.md, "Tasks and the scheduler" and "The command line"; docs/rt-tuning.md).
#include <sys/ioctl.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "app/commands.h"
#include "kernel_rt/doctor.h"
#include "kernel_rt/doctor_render.h"

namespace rtplc::app {
namespace {

struct DoctorOptions {
  bool json = false;
  bool strict = false;
};

size_t terminal_width() {
  winsize ws{};
  if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col >= 60) return ws.ws_col;
  if (const char* cols = std::getenv("COLUMNS")) {
    const long v = std::strtol(cols, nullptr, 10);
    if (v >= 60 && v < 1000) return static_cast<size_t>(v);
  }
  return 100;
}

int run_doctor_command(const DoctorOptions& opt) {
  const kernel_rt::DoctorReport report = kernel_rt::run_doctor();
  if (opt.json) {
    std::fputs(kernel_rt::render_doctor_json(report).c_str(), stdout);
  } else {
    kernel_rt::TableStyle style;
    style.width = terminal_width();
    style.color = isatty(STDOUT_FILENO) != 0 && std::getenv("NO_COLOR") == nullptr;
    std::fputs(kernel_rt::render_doctor_table(report, style).c_str(), stdout);
  }
  std::fflush(stdout);
  const bool ready = report.ready() && !(opt.strict && report.count(kernel_rt::Verdict::kWarn) > 0);
  return ready ? kExitOk : kExitFailure;
}

}  // namespace

void add_doctor_command(CLI::App& app) {
  auto opt = std::make_shared<DoctorOptions>();
  CLI::App* cmd = app.add_subcommand(
      "doctor", "Check whether this machine is ready for real time and say what to change.");
  cmd->add_flag("--json", opt->json,
                "Print the report as JSON (ready, kernel, summary, checks[]) for scripts");
  cmd->add_flag("--strict", opt->strict,
                "Treat WARN as not ready too (for acceptance checks of a tuned box)");
  cmd->footer(
      "Looks at the kernel (PREEMPT_RT or not, preemption model), RT throttling,\n"
      "high-resolution timers, the clock source, CPU isolation (isolcpus, nohz_full, rcu_nocbs),\n"
      "interrupt affinity, the frequency governor, SMT, /dev/cpu_dma_latency, and what this\n"
      "process may do: RLIMIT_MEMLOCK, RLIMIT_RTPRIO, and whether a thread really gets\n"
      "SCHED_FIFO. Each line is OK, WARN (works, costs latency) or FAIL (no real-time\n"
      "guarantee), with the exact command or file that fixes it. Run it as the user the\n"
      "runtime will run as: root's limits differ from a service user's.\n"
      "\n"
      "Exit status:\n"
      "  0  ready: no FAIL (WARNs allowed unless --strict)\n"
      "  1  not ready: at least one FAIL (or a WARN with --strict)\n"
      "  2  bad command line\n"
      "\n"
      "Examples:\n"
      "  rtplc doctor                      # table for people\n"
      "  rtplc doctor --json | jq '.checks[] | select(.verdict != \"ok\")'\n"
      "  sudo -u plc rtplc doctor          # as the service user\n"
      "\n"
      "On a kernel that is not PREEMPT_RT the runtime still runs (SCHED_OTHER or FIFO without\n"
      "bounded latency); doctor says so on its first line. docs/rt-tuning.md explains each check.");
  cmd->callback([opt] {
    const int rc = run_doctor_command(*opt);
    if (rc != kExitOk) throw CLI::RuntimeError(rc);
  });
}

}  // namespace rtplc::app
