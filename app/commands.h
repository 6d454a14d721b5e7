// Every rtplc subcommand registers itself on the CLI11 app through one of these
// functions (one cmd_<name>.cpp each). main.cpp calls them in the order --help lists them.
#pragma once

#include "common/exit_codes.h"

namespace CLI {
class App;
}

namespace rtplc::app {

using rtplc::kExitFailure;
using rtplc::kExitOk;
using rtplc::kExitUsage;

void add_check_commands(CLI::App& app);  // check, compile
void add_sim_command(CLI::App& app);
void add_run_commands(CLI::App& app);    // run, set, force, unforce, swap, status, stop
void add_stats_commands(CLI::App& app);  // stats, monitor
void add_trace_command(CLI::App& app);
void add_doctor_command(CLI::App& app);
void add_fieldbus_command(CLI::App& app);  // fieldbus plan
void add_analyze_command(CLI::App& app);   // analyze (Petri nets)
void add_web_command(CLI::App& app);       // web, web user
// Driver kinds add their own commissioning commands (io/drivers/driver.h).
void add_driver_commands(CLI::App& app);

}  // namespace rtplc::app
