// rtplc — the single command-line entry point (spec: runtime.md, "The command line").
#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "app/commands.h"
#include "common/diagnostic.h"
#include "common/version.h"

namespace {

std::string version_text() {
  return std::string("rtplc ") + rtplc::kVersion + " (commit " + rtplc::kGitCommit + ", " +
         rtplc::kBuildType + " build)";
}

// CLI11 reports a mistyped command as "A subcommand is required": name it, and
// the nearest command, instead.
bool unknown_command(CLI::App& app, const char* word) {
  if (word[0] == '-') return false;
  std::string best;
  size_t best_d = 3;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    if (sub->get_name() == word) return false;
    const size_t d = rtplc::edit_distance(sub->get_name(), word);
    if (d < best_d) {
      best_d = d;
      best = sub->get_name();
    }
  }
  std::fprintf(stderr, "rtplc: unknown command '%s'%s; `rtplc --help` lists the commands\n", word,
               best.empty() ? "" : (" (did you mean '" + best + "'?)").c_str());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "rtplc — real-time soft-PLC for Linux PREEMPT_RT.\n"
      "Compile FBD control programs, simulate them in closed loop, run them as periodic\n"
      "SCHED_FIFO tasks, watch their timing and replace their code while the plant runs.\n"
      "Run `rtplc <command> --help` for the details of each command."};
  app.require_subcommand(1);
  app.fallthrough(false);
  app.set_version_flag("--version", version_text());
  CLI::App* version = app.add_subcommand("version", "Print the version, git commit and build type.");
  version->callback([] { std::printf("%s\n", version_text().c_str()); });

  rtplc::app::add_check_commands(app);
  rtplc::app::add_sim_command(app);
  rtplc::app::add_run_commands(app);
  rtplc::app::add_stats_commands(app);
  rtplc::app::add_trace_command(app);
  rtplc::app::add_doctor_command(app);
  rtplc::app::add_analyze_command(app);
  rtplc::app::add_driver_commands(app);
  rtplc::app::add_fieldbus_command(app);
  rtplc::app::add_web_command(app);

  if (argc > 1 && unknown_command(app, argv[1])) return rtplc::app::kExitUsage;
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
