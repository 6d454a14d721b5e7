// Every rtplc subcommand registers itself on the CLI11 app through one of these
// functions (one cmd_<name>.cpp each). main.cpp calls them in the order --help lists them.
#pragma once

namespace CLI {
class App;
}

namespace rtplc::app {

// Exit codes shared by every subcommand.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // the work failed (compile errors, peer refused, ...)
inline constexpr int kExitUsage = 2;    // bad command line

void add_check_commands(CLI::App& app);  // check, compile
void add_sim_command(CLI::App& app);
void add_run_commands(CLI::App& app);    // run, set, swap, status, stop
void add_stats_commands(CLI::App& app);  // stats, monitor
void add_doctor_command(CLI::App& app);
void add_s7_command(CLI::App& app);
void add_analyze_command(CLI::App& app);

}  // namespace rtplc::app
