// `rtplc stats` and `rtplc monitor`: read-only views of a running runtime, taken
// straight from its shared process image (no socket, no effect on the tasks).
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <memory>
#include <thread>

#include "app/arguments.h"
#include "app/commands.h"
#include "common/text.h"
#include "config/config.h"
#include "io/process_image.h"
#include "kernel_rt/rt_kernel.h"
#include "sched/control.h"
#include "sched/stats_histfile.h"
#include "sched/stats_render.h"
#include "sched/stats_source.h"

namespace rtplc::app {
namespace {

// An output's on_bad policy, beside its writer: what its drivers send while
// it is not good (config::OnBad).
std::string on_bad_text(const io::ChannelDesc& d) {
  if (d.dir != static_cast<uint8_t>(io::ChannelDir::kOutput)) return "";
  const auto p = static_cast<config::OnBad>(d.on_bad);
  std::string t = std::string(", on bad: ") + config::on_bad_name(p);
  if (p == config::OnBad::kSafe) t += " " + format_number(d.safe_value);
  return t;
}

// Faster refreshes only burn a CPU the tasks may need (and flood a terminal).
constexpr double kMinRefresh_s = 0.05;

struct ViewArgs {
  std::string name = "rtplc";
  bool json = false;
  std::string hist;
  bool once = false;
  double interval = 1.0;
  std::string filter;
  double watch = 0;
  std::string variables;  // monitor: also this task's program variables (its watch)
};

io::ProcessImage attach_or_fail(const std::string& name, const char* cmd) {
  auto img = io::ProcessImage::attach(name);
  if (!img) {
    std::fprintf(stderr, "rtplc %s: %s\n", cmd, img.error().c_str());
    throw CLI::RuntimeError(kExitFailure);
  }
  return std::move(img).value();
}

std::string not_running(const io::ProcessImage& img, const io::Liveness& l) {
  return sched::not_running_text(img.header().name, l);
}

// The operator API's own answer (`values`, `stats`) when the runtime answers
// and lets us ask; "" otherwise (a dead runtime, a monitor_group member
// without a role): the caller reads the same document out of the image.
std::string api_json(const ViewArgs& a, const char* op, const char* key) {
  nlohmann::json req = {{"op", op}, {"args", nlohmann::json::object()}};
  if (!a.filter.empty()) req["args"]["filter"] = a.filter;
  auto answer = sched::api_request(sched::control_socket_of(a.name, ""), req, "", 5000);
  if (!answer || !answer->value("ok", false) || !(*answer)["result"].contains(key)) return "";
  // The answer's text is the document as the runtime rendered it (its object
  // beside it is the same, parsed): printed as is, the layout of the image's.
  return (*answer)["result"].value("text", std::string());
}

void run_stats(const ViewArgs& a) {
  io::ProcessImage img = attach_or_fail(a.name, "stats");
  for (;;) {
    auto views = sched::read_task_stats(img);
    auto summary = sched::summary_of(img, views);
    if (!a.hist.empty()) {
      if (auto r = sched::write_hist_file(a.hist, views); !r) {
        std::fprintf(stderr, "rtplc stats: %s\n", r.error().c_str());
        throw CLI::RuntimeError(kExitFailure);
      }
    }
    const io::Liveness live = img.liveness();
    std::string via_api = a.json && live.alive ? api_json(a, "stats", "stats") : "";
    std::string text = a.json ? (via_api.empty() ? sched::stats_json(img) : via_api)
                              : sched::render_table(views, summary) + sched::render_links_table(img) +
                                    sched::render_forced(img);
    if (a.watch > 0 && !a.json && isatty(STDOUT_FILENO)) std::fputs("\x1b[H\x1b[2J", stdout);
    if (!live.alive && !a.json) text = "# " + not_running(img, live) + "; these are its last figures\n" + text;
    std::fputs(text.c_str(), stdout);
    if (!live.alive) {
      std::fflush(stdout);
      std::fprintf(stderr, "rtplc stats: %s\n", not_running(img, live).c_str());
      throw CLI::RuntimeError(kExitFailure);
    }
    if (!a.hist.empty() && a.watch <= 0) {
      std::printf("# histogram written to %s (scripts/plot-jitter %s draws it)\n", a.hist.c_str(),
                  a.hist.c_str());
    }
    std::fflush(stdout);
    if (a.watch <= 0) return;
    std::this_thread::sleep_for(std::chrono::duration<double>(a.watch));

  }
}

std::string fmt_value(double v, uint8_t kind) {
  char b[32];
  if (kind == 1) std::snprintf(b, sizeof b, "%d", v != 0 ? 1 : 0);
  else std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

// The program variables of task `a.variables` as the task's watch has them
// (Runtime::watch): the blocks named as the source names its variables
// ("Main.level", "Main.fb1.count"), strings as their text. The first request
// starts the task copying; a short wait for its first copy.
std::string render_variables(const ViewArgs& a) {
  nlohmann::json req = {{"op", "watch"}, {"args", {{"task", a.variables}}}};
  const std::string sock = sched::control_socket_of(a.name, "");
  for (int tries = 0;; ++tries) {
    auto answer = sched::api_request(sock, req, "", 5000);
    if (!answer) return "\n  variables of task " + a.variables + ": " + answer.error() + "\n";
    if (!answer->value("ok", false)) {
      return "\n  variables of task " + a.variables + ": " + sched::refusal_message(*answer, "refused") + "\n";
    }
    const nlohmann::json& r = (*answer)["result"];
    if (r.value("pending", true) && tries < 40) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    std::string out = fmt::format("\n  variables of task {} (cycle {})\n  {:<32} {:>20}  {}\n", a.variables,
                                  r.value("cycle", uint64_t{0}), "variable", "value", "quality");
    for (const auto& b : r["blocks"]) {
      const std::string name = b.value("name", "");
      // Temporaries ("sCONCAT.$4", "Main.$7"), shared constants ("k:1", "plcopen.true") and output
      // blocks ("dao@...") are the compiler's, not the program's.
      if (name.find('$') != std::string::npos || name.rfind("plcopen.", 0) == 0 || name.find_first_of("@:") != std::string::npos) {
        continue;
      }
      if (!a.filter.empty() && name.find(a.filter) == std::string::npos) continue;
      const nlohmann::json& v = b["value"];
      const std::string value = v.is_string() ? "'" + v.get<std::string>() + "'" : fmt::format("{:.6g}", v.get<double>());
      out += fmt::format("  {:<32} {:>20}  {}\n", name, value, b.value("quality", ""));
    }
    return out;
  }
}

void run_monitor(const ViewArgs& a) {
  io::ProcessImage img = attach_or_fail(a.name, "monitor");
  if (a.json) {
    const io::Liveness live = img.liveness();
    const std::string via_api = live.alive ? api_json(a, "values", "monitor") : "";
    std::fputs((via_api.empty() ? sched::monitor_json(img, live, a.filter) : via_api).c_str(), stdout);
    std::fflush(stdout);
    if (!live.alive) {
      std::fprintf(stderr, "rtplc monitor: %s\n", not_running(img, live).c_str());
      throw CLI::RuntimeError(kExitFailure);
    }
    return;
  }
  const bool tty = isatty(STDOUT_FILENO) != 0 && !a.once;
  for (;;) {
    std::string out;
    char line[256];
    const io::ImageHeader& h = img.header();
    const io::Liveness live = img.liveness();
    if (live.alive) {
      std::snprintf(line, sizeof line, "runtime %s (pid %d), %u channels, %u tasks\n", h.name, h.pid,
                    img.channel_count(), h.n_tasks);
      out += line;
      out += sched::render_forced(img);
    } else {
      // Nothing here is current any more: every value is shown stale.
      out += "NOT RUNNING: " + not_running(img, live) + "\n";
    }
    for (uint32_t t = 0; t < h.n_tasks; ++t) {
      const io::TaskInfo& ti = img.task_info(t);
      std::snprintf(line, sizeof line, "  task %-12s %-20s swaps %llu, block errors %llu, input misses %llu\n",
                    ti.name, live.alive ? io::task_state_name(static_cast<io::TaskState>(ti.state.load())) : "not running",
                    static_cast<unsigned long long>(ti.swaps.load()),
                    static_cast<unsigned long long>(ti.block_errors.load()),
                    static_cast<unsigned long long>(ti.input_misses.load()));
      out += line;
    }
    if (img.link_count() > 0) {
      std::snprintf(line, sizeof line, "\n  %-14s %-6s %-22s %-10s %9s %9s %6s %6s %6s  %s\n", "link", "kind",
                    "peer", "state", "rtt p50", "rtt p99", "recon", "tmout", "errors", "writes acked/failed/pending");
      out += line;
    }
    for (uint32_t l = 0; l < img.link_count(); ++l) {
      const sched::LinkSnapshot ls = sched::link_snapshot(img.link(l));
      std::snprintf(line, sizeof line, "  %-14s %-6s %-22s %-10s %7uus %7uus %6llu %6llu %6llu  %llu/%llu/%llu\n",
                    ls.name.c_str(), ls.kind.c_str(), ls.peer.c_str(), live.alive ? ls.state.c_str() : "unknown",
                    ls.rtt_p50_us, ls.rtt_p99_us, ls.reconnects, ls.timeouts, ls.errors, ls.writes_acked,
                    ls.writes_failed, ls.writes_pending);
      out += line;
      if (!ls.gauges.empty() || !ls.last_error.empty()) out += "    " + sched::gauges_text(ls).substr(2) + "\n";  // the kind's own figures
      out += sched::render_link_classes(ls);  // a planned link's classes; "" otherwise
    }
    std::snprintf(line, sizeof line, "\n  %-20s %-9s %-24s %14s  %-7s %8s  %s\n", "label", "dir", "channel",
                  "value", "quality", "age", "writer");
    out += line;
    for (uint32_t c = 0; c < img.channel_count(); ++c) {
      const io::ChannelDesc& d = img.channel(c);
      if (!sched::channel_shown(d, a.filter)) continue;
      const io::ChannelValue v = img.read_channel(c);
      const io::RegionDesc& r = img.region(d.region);
      const char* dir = d.dir == 0 ? "input" : d.dir == 1 ? "output" : "setpoint";
      char age[32] = "-";
      if (v.timestamp_ns != 0) std::snprintf(age, sizeof age, "%.3fs", io::age_s(v.timestamp_ns));
      const bool unwired = r.kind == static_cast<uint8_t>(io::RegionKind::kUnwired);
      // An output no driver sends reaches nothing: computed, but not good to
      // anyone looking at the plant (a driver that sends it reports delivery).
      // An HMI variable's output is for the console and `monitor` themselves:
      // it shows its value's own quality (docs/st.md, "HMI variables").
      const bool unsent = d.dir == static_cast<uint8_t>(io::ChannelDir::kOutput) && d.has_delivery == 0 && d.hmi == 0;
      // A forced value says so in capitals; a forced output its driver cannot
      // deliver shows the delivery's quality, and FORCED beside the writer.
      const char* quality = !live.alive ? "stale"
                            : unwired   ? "bad"
                            : !v.fresh  ? "-"
                            : v.forced && v.quality == Quality::kForced ? "FORCED"
                            : unsent                                     ? "unsent"
                                                                         : quality_name(v.quality);
      const std::string writer = std::string(unwired ? "(no driver)" : r.name) +
                                 (v.forced && v.quality != Quality::kForced ? " (FORCED)" : "") +
                                 (unsent ? " (no driver sends it)" : "") + (d.hmi != 0 ? " (HMI)" : "") +
                                 on_bad_text(d);
      std::snprintf(line, sizeof line, "  %-20s %-9s %-24s %14s  %-7s %8s  %s\n", d.label, dir, d.key,
                    fmt_value(v.value, d.kind).c_str(), quality, age, writer.c_str());
      out += line;
    }
    if (!a.variables.empty() && live.alive) out += render_variables(a);
    if (tty) std::fputs("\x1b[H\x1b[2J", stdout);
    std::fputs(out.c_str(), stdout);
    std::fflush(stdout);
    if (!live.alive) {
      std::fprintf(stderr, "rtplc monitor: %s\n", not_running(img, live).c_str());
      throw CLI::RuntimeError(kExitFailure);
    }
    if (a.once) return;
    std::this_thread::sleep_for(std::chrono::duration<double>(a.interval));
  }
}

}  // namespace

void add_stats_commands(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  CLI::App* stats = app.add_subcommand("stats", "Per-task wake latency and execution time, like cyclictest.");
  stats->footer(
      "Reads the running runtime's shared memory (read-only). Wake latency is the time from a\n"
      "task's release to its thread running; exec is the cycle's run time. Lines starting with\n"
      "T: read like cyclictest's (microseconds). docs/jitter.md explains every column.\n"
      "L: lines are the drivers' links; a link that runs on a fieldbus plan adds, per traffic\n"
      "class (periodic, urgent, non-RT), its measured delays beside the plan's bounds\n"
      "(docs/fieldbus.md, \"Running a link on a plan\").\n"
      "Examples:\n  rtplc stats\n  rtplc stats --json\n  rtplc stats --hist jitter.hist && scripts/plot-jitter jitter.hist");
  stats->add_option("--name", a->name, "runtime name (default rtplc)")->check(runtime_name());
  stats->add_flag("--json", a->json, "machine-readable output");
  stats->add_option("--hist", a->hist, "also write the latency histograms to this file");
  stats->add_option("--watch", a->watch, "refresh every this many seconds (at least 0.05)")
      ->check(seconds_at_least(kMinRefresh_s));
  stats->callback([a] { run_stats(*a); });

  CLI::App* mon = app.add_subcommand("monitor", "Live values, quality and age of every channel.");
  mon->footer("Attaches read-only to the running runtime's process image. Each output shows\n"
              "its on_bad policy (what its drivers send while it is not good) beside its writer.\n"
              "--variables TASK adds that task's program variables (ST, PLCopen), strings as text.\n"
              "Examples:\n  rtplc monitor\n  rtplc monitor --once --filter SV_\n  rtplc monitor --once --variables plant\n  rtplc monitor --json | jq '.channels[]'");
  mon->add_option("--name", a->name, "runtime name (default rtplc)")->check(runtime_name());
  mon->add_flag("--once", a->once, "print once and exit");
  mon->add_option("--interval", a->interval, "refresh period in seconds (default 1, at least 0.05)")
      ->check(seconds_at_least(kMinRefresh_s));
  mon->add_option("--filter", a->filter, "only channels whose label or address contains this");
  mon->add_flag("--json", a->json, "print once, machine-readable (tasks, channels, links, forced)");
  mon->add_option("--variables", a->variables,
                  "also the program variables of this task, strings as text (the task's watch; --filter applies)");
  mon->callback([a] { run_monitor(*a); });
}

}  // namespace rtplc::app
