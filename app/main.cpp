// rtplc — the single command-line entry point (spec: runtime.md, "The command line").
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>

#include "app/commands.h"

int main(int argc, char** argv) {
  CLI::App app{
      "rtplc — real-time soft-PLC for Linux PREEMPT_RT.\n"
      "Compile FBD control programs, simulate them in closed loop, run them as periodic\n"
      "SCHED_FIFO tasks, watch their timing and replace their code while the plant runs.\n"
      "Run `rtplc <command> --help` for the details of each command."};
  app.require_subcommand(1);
  app.fallthrough(false);
  app.set_version_flag("--version", "rtplc 0.1.0");

  rtplc::app::add_check_commands(app);
  rtplc::app::add_sim_command(app);
  rtplc::app::add_run_commands(app);
  rtplc::app::add_stats_commands(app);
  rtplc::app::add_doctor_command(app);
  rtplc::app::add_analyze_command(app);
  rtplc::app::add_driver_commands(app);
  rtplc::app::add_fieldbus_command(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    // A subcommand's callback failed and already said why; carry its exit code.
    return e.get_exit_code();
  } catch (const CLI::ParseError& e) {
    int rc = app.exit(e);
    return rc == 0 ? rtplc::app::kExitOk : rtplc::app::kExitUsage;
  }
  return rtplc::app::kExitOk;
}
