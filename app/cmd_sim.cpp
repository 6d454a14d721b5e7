// `rtplc sim`: run one FBD or SFC program in closed loop against a simulated plant, in
// virtual time (or paced to the wall clock), and show / save / plot the response.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "app/arguments.h"
#include "app/commands.h"
#include "blocks/native.h"
#include "io/drivers/sim/plant.h"
#include "sim/sim_loop.h"
#include "lang/compiler.h"

namespace rtplc::app {
namespace {

struct SimArgs {
  std::string file;
  double duration = 30;
  std::string plant = io::kDefaultPlant;
  std::string csv;
  std::string plot;
  std::string plant_input = "p0.d0.c0";
  std::string plant_output = "p0.d0.c0";
  std::vector<std::string> steps;
  double period = 0;
  std::string entry;
  std::string semantics = "auto";
  bool realtime = false;
  bool quiet = false;
  bool allow_unstable = false;
  bool plant_given = false;  // --plant, --plant-input or --plant-output on the command line
  bool native = false;
};

io::SetpointStep parse_step(const std::string& s, double duration) {
  // LABEL=VALUE@TIME
  const size_t eq = s.find('='), at = s.find('@');
  if (eq == std::string::npos || at == std::string::npos || at < eq) {
    std::fprintf(stderr, "rtplc sim: --step wants LABEL=VALUE@SECONDS, e.g. Setpoint=60@15, not '%s'\n",
                 s.c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  io::SetpointStep st;
  st.label = s.substr(0, eq);
  try {
    size_t used = 0;
    std::string v = s.substr(eq + 1, at - eq - 1), t = s.substr(at + 1);
    st.value = std::stod(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
    st.at = std::stod(t, &used);
    if (used != t.size()) throw std::invalid_argument(t);
  } catch (const std::exception&) {
    std::fprintf(stderr, "rtplc sim: --step '%s': VALUE and SECONDS must be numbers\n", s.c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  if (!std::isfinite(st.value)) {
    std::fprintf(stderr, "rtplc sim: --step '%s': VALUE must be a finite number\n", s.c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  if (!std::isfinite(st.at) || st.at < 0 || st.at > duration) {
    std::fprintf(stderr,
                 "rtplc sim: --step '%s': SECONDS must be within the run, 0 to %g s (--duration)\n",
                 s.c_str(), duration);
    throw CLI::RuntimeError(kExitUsage);
  }
  return st;
}

void run_sim(const SimArgs& a) {
  require_program(a.file, "sim");
  // Outputs are checked before the run: a path that cannot be written fails
  // now, naming it, not after a long simulation.
  if (!a.csv.empty()) require_output_path(a.csv, "sim", "--csv", {a.file});
  if (!a.plot.empty()) require_output_path(a.plot, "sim", "--plot", {a.file, a.csv});
  lang::CompileOptions copt;
  if (a.period > 0) copt.period_override = a.period;
  copt.entry = a.entry;
  copt.semantics = *lang::parse_editor_semantics(a.semantics);
  lang::CompileResult r = lang::compile_file(a.file, copt);
  if (!r.diags.items().empty()) {
    std::string err;
    auto text = lang::read_text_file(a.file, &err);
    std::fputs(r.diags.render(a.file, text ? *text : "", isatty(STDERR_FILENO) != 0).c_str(), stderr);
  }
  if (!r.ok()) {
    std::fprintf(stderr, "%s: %zu error(s); nothing simulated\n", a.file.c_str(), r.diags.error_count());
    throw CLI::RuntimeError(kExitFailure);
  }
  auto plant = io::make_plant(a.plant);
  if (!plant) {
    std::fprintf(stderr, "rtplc sim: --plant %s: %s\n", a.plant.c_str(), plant.error().c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  io::SimOptions opt;
  opt.duration = a.duration;
  opt.plant_input = a.plant_input;
  opt.plant_output = a.plant_output;
  opt.realtime = a.realtime;
  // Asked for a plant by name: a program that cannot take it is an error, not a logic test.
  opt.open_loop_if_unwired = !a.plant_given;
  opt.probes = r.program.variables;
  opt.file = a.file;  // PLCopen: every variable of the program instances
  for (const std::string& s : a.steps) opt.steps.push_back(parse_step(s, a.duration));
  std::shared_ptr<const NativeCode> native;
  if (a.native) {
    auto n = compile_native(*r.image);
    if (!n) {
      std::fprintf(stderr, "rtplc sim: --native: %s\n", n.error().c_str());
      throw CLI::RuntimeError(kExitFailure);
    }
    native = *n;
    opt.native = native->entry();
    if (!a.quiet) {
      const NativeStats& st = native->stats();
      std::printf("native code: %u runs compiled, %u left to the interpreter, %.0f ms to compile\n",
                  st.native_runs, st.interpreted_runs, st.compile_ms);
    }
  }

  const bool open_loop = io::runs_open_loop(*r.image, opt);
  if (!a.quiet && open_loop) {
    std::printf("rtplc sim: %s, period %g s, no plant (open loop), %g s%s\n", a.file.c_str(),
                r.image->period_s(), a.duration, a.realtime ? ", real time" : " of simulated time");
    const bool has_dao = io::has_plant_input(*r.image, opt);
    const std::string why = has_dao ? "no dai at " + a.plant_output + " to measure the plant"
                                    : "no dao at " + a.plant_input + " to drive a plant";
    std::printf("open loop: the program has %s, so no plant is attached;\n"
                "  inputs stay at 0, set-points follow --step (--plant-input/--plant-output wire a plant)\n",
                why.c_str());
  } else if (!a.quiet) {
    std::printf("rtplc sim: %s, period %g s, plant %s (RK4, step %g s), %g s%s\n", a.file.c_str(),
                r.image->period_s(), (*plant)->describe().c_str(),
                io::plant_step_for(r.image->period_s()), a.duration,
                a.realtime ? ", real time" : " of simulated time");
  }
  auto trace = io::run_closed_loop(*r.image, **plant, opt);
  if (!trace) {
    std::fprintf(stderr, "rtplc sim: %s\n", trace.error().c_str());
    throw CLI::RuntimeError(kExitFailure);
  }

  const std::vector<io::StepMetrics> m = io::step_metrics(*trace);
  if (!a.quiet) {
    std::printf("%zu cycles", trace->rows.size());
    if (trace->block_errors) std::printf(", %llu block errors (outputs held)", static_cast<unsigned long long>(trace->block_errors));
    if (trace->diverged_at < 0) std::printf("\n%s", io::format_metrics(*trace, m).c_str());
    else std::printf("\n");
  }
  // A diverging loop has no step response worth reporting: say it, and fail.
  const bool diverged = trace->diverged_at >= 0;
  if (diverged) {
    std::fflush(stdout);
    std::fprintf(stderr,
                 "rtplc sim: UNSTABLE: the measurement diverged (%g at t = %g s, beyond %g times the "
                 "largest set-point)%s\n",
                 trace->diverged_value, trace->diverged_at, io::kDivergenceFactor,
                 a.allow_unstable ? "; --allow-unstable: not an error" : "; --allow-unstable accepts it");
  }
  std::string csv = a.csv;
  std::string tmp_csv;
  if (csv.empty() && !a.plot.empty()) {
    char tmpl[] = "/tmp/rtplc-sim-XXXXXX";
    int fd = mkstemp(tmpl);
    if (fd >= 0) close(fd);
    tmp_csv = csv = tmpl;
  }
  if (!csv.empty()) {
    if (auto w = io::write_csv(*trace, csv); !w) {
      std::fprintf(stderr, "rtplc sim: %s\n", w.error().c_str());
      throw CLI::RuntimeError(kExitFailure);
    }
    if (tmp_csv.empty() && !a.quiet) std::printf("wrote %s (%zu rows)\n", csv.c_str(), trace->rows.size());
  }
  if (!a.plot.empty()) {
    std::string title = "rtplc sim " + a.file + " - plant " + (*plant)->describe();
    auto p = io::write_plot(*trace, csv, a.plot, title);
    if (!tmp_csv.empty()) unlink(tmp_csv.c_str());
    if (!p) {
      std::fprintf(stderr, "rtplc sim: %s\n", p.error().c_str());
      throw CLI::RuntimeError(kExitFailure);
    }
    if (!a.quiet) std::printf("wrote %s\n", a.plot.c_str());
  }
  if (diverged && !a.allow_unstable) throw CLI::RuntimeError(kExitFailure);
}

}  // namespace

void add_sim_command(CLI::App& app) {
  auto a = std::make_shared<SimArgs>();
  CLI::App* sim = app.add_subcommand(
      "sim", "Run an FBD or SFC program in closed loop against a simulated plant (no hardware needed).");
  sim->footer(std::string(
      "The plant's input is the program's dao at --plant-input and its measurement goes to the\n"
      "dai at --plant-output (both p0.d0.c0 by default, as in the seed's example). A program\n"
      "without either runs open loop, without a plant (a logic test), and says so. A loop whose\n"
      "measurement diverges is reported UNSTABLE with exit code 1 (--allow-unstable: 0). Set-points\n"
      "start at their init value; --step changes one during the run. The CSV has a column t and\n"
      "one per input, set-point and output block (its label), one row per task cycle.\n"
      "Plants (--plant):\n") + io::plant_help() +
      "Examples:\n"
      "  rtplc sim examples/seed_pid.fbd --duration 30 --csv run.csv --plot run.png\n"
      "  rtplc sim examples/seed_pid.fbd --plant fopdt:K=2,T=4,L=0.5 --step Setpoint=60@20\n"
      "  rtplc sim examples/tank.sfc --plant measuring-tank --duration 40 --csv tank.csv\n"
      "  rtplc sim examples/plcopen_tank.xml --duration 5 --csv tank.csv   (a column per variable)");
  sim->add_option("file", a->file, "control algorithm file (.fbd), SFC program (.sfc) or PLCopen XML project (.xml)")->required();
  sim->add_option("--entry", a->entry, "PLCopen XML: the task, program instance or program to simulate (default: the project's only one)");
  sim->add_option("--semantics", a->semantics, "PLCopen XML and ST: whose behaviour where the editors differ (SFC order, TIME conversions): auto (the file header's editor: CODESYS for a CODESYS export, else MatIEC as Beremiz and OpenPLC), matiec or codesys (docs/plcopen.md)")
      ->check(CLI::IsMember({"auto", "matiec", "codesys"}));
  sim->add_option("--duration", a->duration, "simulated seconds (default 30)")
      ->check(seconds_between(1e-3, 1e7));
  sim->add_option("--plant", a->plant, "plant model (default second-order = 1/(s^2+s+1))")
      ->each([a](const std::string&) { a->plant_given = true; });
  sim->add_option("--csv", a->csv, "write the trace as CSV");
  sim->add_option("--plot", a->plot, "draw the trace into a PNG (needs gnuplot)");
  sim->add_option("--plant-input", a->plant_input, "dao channel pN.dN.cN that drives the plant")
      ->each([a](const std::string&) { a->plant_given = true; });
  sim->add_option("--plant-output", a->plant_output, "dai channel pN.dN.cN that measures the plant")
      ->each([a](const std::string&) { a->plant_given = true; });
  sim->add_option("--step", a->steps, "set-point change LABEL=VALUE@SECONDS (repeatable)");
  sim->add_option("--period", a->period, "override stime: task period in seconds")
      ->check(positive_seconds());
  sim->add_flag("--allow-unstable", a->allow_unstable,
                "a diverging loop is reported but is not an error (exit 0)");
  sim->add_flag("--realtime", a->realtime, "pace cycles to the wall clock");
  sim->add_flag("--native", a->native,
                "run the program as native code, compiled with the machine's C++ compiler, as a task\n"
                "with `native: true` runs (docs/st.md, \"Native code\")");
  sim->add_flag("-q,--quiet", a->quiet, "print nothing but errors");
  sim->callback([a] { run_sim(*a); });
}

}  // namespace rtplc::app
