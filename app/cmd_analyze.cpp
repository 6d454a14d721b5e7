// `rtplc analyze`: the Petri-net analyser (issue item 3; spec petri-sfc.md).
// Reads a PNML P/T net or an SFC program (built into a hierarchical net by the
// paper's rules 1-4, lang/sfc/net_builder.h), or generates an MCC model; computes B, the
// reachability graph, dead markings with their shortest firing sequences, bounds, dead transitions
// and P-invariants, and prints them as text or JSON; optionally draws the net (and a small
// reachability graph) for Graphviz and writes the net as PNML.
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "app/commands.h"
#include "common/files.h"
#include "lang/petri/dot.h"
#include "lang/petri/generators.h"
#include "lang/petri/pnml.h"
#include "lang/petri/report.h"
#include "lang/plcopen/import.h"
#include "lang/plcopen/sfc_chart.h"
#include "lang/st/st_file.h"
#include "lang/sfc/lexer.h"
#include "lang/sfc/net_builder.h"

namespace rtplc::app {
namespace {

// The search stopped before it saw every marking: the figures are lower bounds.
constexpr int kExitIncomplete = 3;
constexpr size_t kMaxFileBytes = size_t{512} << 20;
constexpr size_t kDotGraphLimit = 100;  // markings drawn at most

struct AnalyzeArgs {
  std::string file;
  std::string generate;
  bool json = false;
  std::string dot;
  std::string write_pnml;
  uint64_t limit = 50'000'000;
  unsigned threads = 0;  // 0 = every CPU this process may use
  bool quiet = false;
  std::string pou;      // PLCopen: the POU whose SFC body is analysed
  std::string preface;  // an SFC's main loop and sub-PNs, printed before the report
};

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
  f.close();
  if (!f) {
    std::fprintf(stderr, "rtplc analyze: cannot write %s\n", path.c_str());
    return false;
  }
  return true;
}

petri::Net load_net(AnalyzeArgs& a) {
  if (!a.generate.empty()) {
    auto net = petri::generate(a.generate);
    if (!net) {
      std::fprintf(stderr, "rtplc analyze: --generate %s\n", net.error().c_str());
      throw CLI::RuntimeError(kExitUsage);
    }
    return std::move(net.value());
  }
  if (a.file.empty()) {
    std::fprintf(stderr, "rtplc analyze: give a PNML file or --generate MODEL-N\n");
    throw CLI::RuntimeError(kExitUsage);
  }
  Result<std::string> read = read_file_bounded(a.file, kMaxFileBytes);
  if (!read) {
    std::fprintf(stderr, "rtplc analyze: %s\n", read.error().c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  std::string text = std::move(read).value();
  const size_t first = text.find_first_not_of(" \t\r\n\xEF\xBB\xBF");
  const bool color = isatty(STDERR_FILENO) != 0;
  const bool st_file = lang::st::is_st_source(text);
  if (!a.pou.empty() && !lang::plcopen::is_plcopen_source(text) && !st_file) {
    std::fprintf(stderr, "rtplc analyze: --pou is for a PLCopen project or a .st file; %s is neither\n",
                 a.file.c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  const bool sfc_file = a.file.ends_with(".sfc") || lang::sfc::starts_with_sfc_keyword(text);
  if (sfc_file || st_file || lang::plcopen::is_plcopen_source(text)) {
    DiagnosticList diags;
    std::optional<lang::sfc::SfcNet> sfc;
    std::optional<lang::plcopen::Project> st_project;
    if (st_file && !sfc_file) st_project = lang::st::read_st_file(text, diags);
    std::optional<lang::sfc::Chart> chart;
    if (st_project) {
      chart = lang::plcopen::read_sfc_pou(*st_project, a.pou, diags);
    } else if (!st_file && !sfc_file) {
      chart = lang::plcopen::read_sfc_pou(text, a.pou, diags);
    }
    if (sfc_file) {
      sfc = lang::sfc::sfc_source_to_net(text, diags);
    } else if (chart) {
      // The chart the PLCopen importer compiles (a .st file's textual SFC
      // is read into the same), through the same net builder.
      const lang::sfc::ChartIndex index = lang::sfc::check_chart(*chart, diags);
      if (!diags.has_errors()) sfc = lang::sfc::build_net(*chart, index, diags);
    }
    const std::string rendered = diags.render(a.file, text, color);
    if (!rendered.empty()) std::fputs(rendered.c_str(), stderr);
    if (!sfc) {
      std::fprintf(stderr, "%s: %s; nothing analysed\n", a.file.c_str(),
                   sfc_file ? "the SFC program has errors" : "no SFC chart to analyse");
      throw CLI::RuntimeError(kExitFailure);
    }
    if (!a.json) a.preface = lang::sfc::render_hierarchy(*sfc);
    return sfc->flat();
  }
  if (!a.file.ends_with(".pnml") && !a.file.ends_with(".xml") &&
      (first == std::string::npos || text[first] != '<')) {
    std::fprintf(
        stderr,
        "rtplc analyze: %s is neither PNML nor an SFC program (which starts with 'SFC name');\n"
        "give a P/T net in PNML (.pnml), an SFC program (.sfc) or --generate MODEL-N.\n",
        a.file.c_str());
    throw CLI::RuntimeError(kExitFailure);
  }
  petri::PnmlReadResult r = petri::read_pnml(text);
  const std::string rendered = r.diags.render(a.file, text, color);
  if (!rendered.empty()) std::fputs(rendered.c_str(), stderr);
  if (!r.net) {
    std::fprintf(stderr, "%s: not a P/T net rtplc can read; nothing analysed\n", a.file.c_str());
    throw CLI::RuntimeError(kExitFailure);
  }
  return std::move(*r.net);
}

// Progress on stderr: a rewritten line on a terminal, else a line every 5 s.
class ProgressLine {
 public:
  explicit ProgressLine(bool quiet) : tty_(isatty(STDERR_FILENO) != 0), quiet_(quiet) {}
  void operator()(const petri::ExploreProgress& p) {
    if (quiet_) return;
    const double every = tty_ ? 0.5 : 5.0;
    if (p.seconds < next_) return;
    next_ = p.seconds + every;
    std::fprintf(
        stderr, "%s  %.1f s: %llu markings, %llu explored, %llu edges, %.2f M markings/s%s",
        tty_ ? "\r" : "", p.seconds, static_cast<unsigned long long>(p.markings),
        static_cast<unsigned long long>(p.explored), static_cast<unsigned long long>(p.edges),
        p.seconds > 0 ? static_cast<double>(p.markings) / p.seconds / 1e6 : 0.0,
        tty_ ? "   " : "\n");
    shown_ = true;
  }
  void done() {
    if (shown_ && tty_) std::fputc('\n', stderr);
  }

 private:
  bool tty_;
  bool quiet_;
  bool shown_ = false;
  double next_ = 2.0;  // say nothing for short runs
};

void run_analyze(AnalyzeArgs& a) {
  petri::Net net = load_net(a);
  if (!a.write_pnml.empty() && !write_file(a.write_pnml, petri::write_pnml(net))) {
    throw CLI::RuntimeError(kExitFailure);
  }
  auto progress = std::make_shared<ProgressLine>(a.quiet);
  petri::AnalysisOptions opt;
  opt.max_markings = a.limit;
  opt.graph_limit = a.dot.empty() ? 0 : kDotGraphLimit;
  opt.threads = a.threads;
  opt.progress = [progress](const petri::ExploreProgress& p) { (*progress)(p); };
  const petri::Analysis an = petri::analyze(net, opt);
  progress->done();
  if (!a.dot.empty()) {
    const petri::ReachabilityGraph* g = an.reach.graph ? &*an.reach.graph : nullptr;
    if (!write_file(a.dot, petri::write_dot(net, g))) throw CLI::RuntimeError(kExitFailure);
    if (!g && !a.json) {
      std::fprintf(stderr,
                   "rtplc analyze: %s has the net only (the reachability graph has more than %zu "
                   "markings)\n",
                   a.dot.c_str(), kDotGraphLimit);
    }
  }
  const std::string out =
      a.json ? petri::render_json(net, an) : a.preface + petri::render_text(net, an);
  std::fputs(out.c_str(), stdout);
  if (an.reach.status == petri::ExploreStatus::kLimit) {
    std::fprintf(stderr,
                 "rtplc analyze: stopped after %llu markings (--limit %llu); raise --limit for "
                 "exact figures\n",
                 static_cast<unsigned long long>(an.reach.markings),
                 static_cast<unsigned long long>(a.limit));
    throw CLI::RuntimeError(kExitIncomplete);
  }
  if (an.reach.status == petri::ExploreStatus::kTooManyTokens) {
    std::fprintf(stderr,
                 "rtplc analyze: place %s outgrew its storage; the figures are incomplete\n",
                 an.reach.overflow_place.c_str());
    throw CLI::RuntimeError(kExitIncomplete);
  }
}

}  // namespace

void add_analyze_command(CLI::App& app) {
  auto args = std::make_shared<AnalyzeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "analyze",
      "Analyse a Petri net (PNML or an SFC program): reachability, deadlocks, bounds, invariants.");
  cmd->footer(
      "Prints the places, transitions and incidence matrix B, then the reachability graph's size,\n"
      "every dead marking (deadlock) with a shortest firing sequence reaching it, the bound (most\n"
      "tokens in one place) and safeness, dead transitions and P-invariants. An unbounded net is\n"
      "reported with the firing sequence that pumps tokens into it (an omega marking).\n"
      "Exit code: 0 analysed, 1 unreadable input, 2 bad command line, 3 stopped by --limit.\n"
      "An SFC program (.sfc) is first built into a hierarchical net (steps = main loop, plant\n"
      "modules = sub-PNs; docs/sfc.md) and its sub-PN matrices are printed before the report.\n"
      "A PLCopen project (.xml) is analysed the same way: the SFC body of its POU (--pou when\n"
      "it has several), as the importer compiles it; its ST conditions count as always able\n"
      "to fire (docs/plcopen.md, \"SFC\").\n"
      "Examples:\n  rtplc analyze examples/petri/mutex.pnml\n  rtplc analyze examples/tank.sfc\n"
      "  rtplc analyze tests/plcopen/data/beremiz_sfc.xml\n"
      "  rtplc analyze examples/petri/deadlock.pnml --json --dot deadlock.dot\n"
      "  rtplc analyze --generate philosophers-10 --write-pnml phil10.pnml\n"
      "  rtplc analyze --generate kanban-5 --threads 1   (the sequential search, to compare)");
  cmd->add_option("file", args->file,
                  "P/T net in PNML (ISO/IEC 15909-2), an SFC program (.sfc) or a PLCopen project "
                  "with an SFC POU (.xml)");
  cmd->add_option("--pou", args->pou, "PLCopen: the POU whose SFC body is analysed");
  cmd->add_option("--generate", args->generate,
                  "analyse a generated MCC model instead: philosophers-N, kanban-N");
  cmd->add_flag("--json", args->json, "print the results as JSON");
  cmd->add_option("--dot", args->dot,
                  "write a Graphviz drawing of the net (and of the reachability graph when small)");
  cmd->add_option("--write-pnml", args->write_pnml,
                  "write the net as PNML (e.g. a generated model, for other tools)");
  cmd->add_option("--limit", args->limit, "explore at most this many markings (default 50,000,000)")
      ->check(CLI::Range(uint64_t{1}, uint64_t{4'000'000'000}));
  cmd->add_option("--threads", args->threads,
                  "threads of the reachability search (default: every CPU this process may use; "
                  "1 = sequential). More than one is used for bounded nets whose markings fit 64 "
                  "bits, from 100,000 markings on; the counts are the same either way")
      ->check(CLI::Range(1u, 256u));
  cmd->add_flag("-q,--quiet", args->quiet, "no progress lines on stderr");
  cmd->callback([args] { run_analyze(*args); });
}

}  // namespace rtplc::app
