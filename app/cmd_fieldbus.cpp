// `rtplc fieldbus plan FILE`: the fieldbus bandwidth planner and its bus
// simulation (spec io-links.md, "Fieldbus bandwidth allocation"; docs/fieldbus.md).
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>

#include "app/commands.h"
#include "fieldbus/plan_file.h"
#include "fieldbus/plan_report.h"
#include "fieldbus/planner.h"

namespace rtplc::app {
namespace {

// A design that cannot work is not a broken file: scripts tell them apart.
constexpr int kExitInfeasible = 3;

struct FieldbusArgs {
  std::string file;
  bool json = false;
};

void run_plan(const FieldbusArgs& a) {
  fieldbus::PlanFile pf = fieldbus::load_plan_file(a.file);
  if (!pf.diags.items().empty()) {
    std::fputs(pf.render(isatty(STDERR_FILENO) != 0).c_str(), stderr);
  }
  if (!pf.design) {
    std::fprintf(stderr, "%s: %zu error(s); nothing planned\n", a.file.c_str(),
                 pf.diags.error_count());
    throw CLI::RuntimeError(kExitFailure);
  }
  const fieldbus::Design& d = *pf.design;
  const fieldbus::Plan p = fieldbus::plan(d);
  const std::string out =
      a.json ? fieldbus::render_plan_json(d, p) : fieldbus::render_plan_text(d, p, a.file);
  std::fputs(out.c_str(), stdout);
  if (!p.feasible) throw CLI::RuntimeError(kExitInfeasible);
}

}  // namespace

void add_fieldbus_command(CLI::App& app) {
  CLI::App* fb = app.add_subcommand(
      "fieldbus", "Plan the bandwidth of a cyclic fieldbus (periodic, real-time, non-RT traffic).");
  fb->require_subcommand(1);
  auto a = std::make_shared<FieldbusArgs>();
  CLI::App* plan = fb->add_subcommand(
      "plan", "Choose T_1, the sampling periods and frame offsets; check the bandwidth conditions.");
  plan->footer(
      "Exit codes: 0 the design works, 1 the file has errors, 3 the design cannot work\n"
      "(the report says which condition fails and by how much). See docs/fieldbus.md.\n"
      "Examples:\n"
      "  rtplc fieldbus plan examples/fieldbus.yaml\n"
      "  rtplc fieldbus plan examples/fieldbus-can.yaml --json");
  plan->add_option("file", a->file, "plan file (.yaml)")->required();
  plan->add_flag("--json", a->json, "print the plan as JSON (times in seconds)");
  plan->callback([a] { run_plan(*a); });
}

}  // namespace rtplc::app
