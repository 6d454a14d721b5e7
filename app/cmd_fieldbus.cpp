// `rtplc fieldbus plan FILE`: the fieldbus bandwidth planner and its bus
// simulation (spec io-links.md, "Fieldbus bandwidth allocation"; docs/fieldbus.md).
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "app/arguments.h"
#include "app/commands.h"
#include "fieldbus/plan_file.h"
#include "fieldbus/plan_report.h"
#include "fieldbus/planner.h"
#include "fieldbus/sim_report.h"
#include "fieldbus/simulation.h"

namespace rtplc::app {
namespace {

// A design that cannot work is not a broken file: scripts tell them apart.
constexpr int kExitInfeasible = 3;

struct FieldbusArgs {
  std::string file;
  bool json = false;
  bool simulate = false;
  double duration = 60;
  uint64_t seed = 1;
  std::string plot;
  std::string nonrt_packet;
  std::vector<std::string> add_loops;
};

fieldbus::Nanos time_arg(const char* flag, const std::string& text) {
  auto v = fieldbus::parse_time(text);
  if (!v || *v <= 0) {
    std::fprintf(stderr, "rtplc fieldbus plan: %s wants a time such as 800us or 2ms, not '%s'\n",
                 flag, text.c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  return *v;
}

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
  fieldbus::Design d = *pf.design;
  // What-ifs from the command line, so a user sees a plan break without editing it.
  if (!a.nonrt_packet.empty()) d.nonrt_packet = time_arg("--nonrt-packet", a.nonrt_packet);
  for (size_t i = 0; i < a.add_loops.size(); ++i) {
    fieldbus::LoopSpec l;
    l.name = "added" + std::to_string(i + 1);
    l.period = time_arg("--add-loop", a.add_loops[i]);
    d.loops.push_back(l);
  }
  const fieldbus::Plan p = fieldbus::plan(d);
  std::string sim_json;
  std::string sim_text;
  bool sim_ok = true;
  if (a.simulate) {
    fieldbus::SimOptions opt;
    opt.duration = static_cast<fieldbus::Nanos>(std::llround(a.duration * 1e9));
    opt.seed = a.seed;
    opt.keep_samples = !a.plot.empty();
    auto r = fieldbus::simulate(d, p, opt);
    if (!r) {
      std::fprintf(stderr, "rtplc fieldbus plan: cannot simulate: %s\n", r.error().c_str());
      sim_ok = false;
    } else {
      sim_json = fieldbus::render_sim_json(p, *r, a.seed);
      sim_text = fieldbus::render_sim_text(d, p, *r, a.seed);
      if (!a.plot.empty()) {
        auto w = fieldbus::write_delay_plot(p, *r, a.plot, "rtplc fieldbus plan " + a.file);
        if (!w) {
          std::fprintf(stderr, "rtplc fieldbus plan: %s\n", w.error().c_str());
          sim_ok = false;
        } else if (!a.json) {
          sim_text += "wrote " + a.plot + "\n";
        }
      }
    }
  }
  const std::string out = a.json ? fieldbus::render_plan_json(d, p, sim_json)
                                 : fieldbus::render_plan_text(d, p, a.file) + sim_text;
  std::fputs(out.c_str(), stdout);
  if (!p.feasible) throw CLI::RuntimeError(kExitInfeasible);
  if (!sim_ok) throw CLI::RuntimeError(kExitFailure);
}

}  // namespace

void add_fieldbus_command(CLI::App& app) {
  CLI::App* fb = app.add_subcommand(
      "fieldbus", "Plan the bandwidth of a cyclic fieldbus (periodic, real-time, non-RT traffic).");
  fb->require_subcommand(1);
  auto a = std::make_shared<FieldbusArgs>();
  CLI::App* plan = fb->add_subcommand(
      "plan",
      "Choose T_1, the sampling periods and frame offsets; check the bandwidth conditions.");
  plan->footer(
      "Exit codes: 0 the design works, 1 the file has errors, 3 the design cannot work\n"
      "(the report says which condition fails and by how much). See docs/fieldbus.md.\n"
      "Examples:\n"
      "  rtplc fieldbus plan examples/fieldbus.yaml\n"
      "  rtplc fieldbus plan examples/fieldbus-can.yaml --json\n"
      "  rtplc fieldbus plan examples/fieldbus.yaml --simulate --duration 60 --plot delays.png\n"
      "  rtplc fieldbus plan examples/fieldbus.yaml --simulate --nonrt-packet 5ms   # breaks");
  plan->add_option("file", a->file, "plan file (.yaml)")->required();
  plan->add_flag("--json", a->json, "print the plan as JSON (times in seconds)");
  plan->add_flag("--simulate", a->simulate, "simulate the planned bus and print per-class delays");
  plan->add_option("--duration", a->duration, "simulated seconds of bus time (default 60)")
      ->check(seconds_between(1e-3, 1e6));
  plan->add_option("--seed", a->seed, "seed of the random arrivals (default 1)");
  plan->add_option("--plot", a->plot,
                   "draw the simulated delay distributions into a PNG (gnuplot)");
  plan->add_option("--nonrt-packet", a->nonrt_packet, "what if: non-RT packets of this length");
  plan->add_option("--add-loop", a->add_loops, "what if: one more loop with this fixed period")
      ->take_all();
  plan->callback([a] { run_plan(*a); });
}

}  // namespace rtplc::app
