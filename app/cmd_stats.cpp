// `rtplc stats` and `rtplc monitor`: read-only views of a running runtime, taken
// straight from its shared process image (no socket, no effect on the tasks).
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <thread>

#include "app/commands.h"
#include "io/process_image.h"
#include "io/s7/engine.h"
#include "kernel_rt/rt_kernel.h"
#include "sched/stats_histfile.h"
#include "sched/stats_render.h"
#include "sched/stats_source.h"

namespace rtplc::app {
namespace {

struct ViewArgs {
  std::string name = "rtplc";
  bool json = false;
  std::string hist;
  bool once = false;
  double interval = 1.0;
  std::string filter;
  double watch = 0;
};

io::ProcessImage attach_or_fail(const std::string& name, const char* cmd) {
  auto img = io::ProcessImage::attach(name);
  if (!img) {
    std::fprintf(stderr, "rtplc %s: %s\n", cmd, img.error().c_str());
    throw CLI::RuntimeError(kExitFailure);
  }
  return std::move(img).value();
}

// Per-PLC link lines under the task table: "L:" lines, like the task's "T:".
std::string links_table(const io::ProcessImage& img) {
  if (img.link_count() == 0) return "";
  std::string out = "# S7 links: round-trip time p50/p99 in us; polls done/missed/offline; writes acked/failed/pending\n";
  char line[320];
  for (uint32_t l = 0; l < img.link_count(); ++l) {
    const sched::LinkSnapshot s = sched::link_snapshot(img.link(l));
    std::snprintf(line, sizeof line,
                  "L:%2u (%s) %s %s RTT: %u/%u Polls: %llu/%llu/%llu Recon: %llu Tmout: %llu Err: %llu "
                  "Writes: %llu/%llu/%llu\n",
                  l, s.name.c_str(), s.address.c_str(), s.state.c_str(), s.rtt_p50_us, s.rtt_p99_us,
                  s.polls_completed, s.polls_missed, s.polls_offline, s.reconnects, s.timeouts, s.errors,
                  s.writes_acked, s.writes_failed, s.writes_pending);
    out += line;
  }
  return out;
}

// The same as a "links" array appended to the stats JSON object.
std::string with_links_json(const io::ProcessImage& img, const std::string& json) {
  const size_t close = json.find_last_of('}');
  if (close == std::string::npos) return json;
  std::string links = ",\n  \"links\": [";
  char item[512];
  for (uint32_t l = 0; l < img.link_count(); ++l) {
    const sched::LinkSnapshot s = sched::link_snapshot(img.link(l));
    std::snprintf(item, sizeof item,
                  "%s\n    {\"name\": \"%s\", \"driver\": \"%s\", \"address\": \"%s\", \"state\": \"%s\", "
                  "\"rtt_p50_us\": %u, \"rtt_p99_us\": %u, \"polls_completed\": %llu, \"polls_missed\": %llu, "
                  "\"polls_offline\": %llu, \"reconnects\": %llu, \"timeouts\": %llu, \"errors\": %llu, "
                  "\"writes_acked\": %llu, \"writes_failed\": %llu, \"writes_pending\": %llu}",
                  l ? "," : "", s.name.c_str(), s.driver.c_str(), s.address.c_str(), s.state.c_str(),
                  s.rtt_p50_us, s.rtt_p99_us, s.polls_completed, s.polls_missed, s.polls_offline,
                  s.reconnects, s.timeouts, s.errors, s.writes_acked, s.writes_failed, s.writes_pending);
    links += item;
  }
  links += img.link_count() ? "\n  ]\n" : "]\n";
  std::string out = json.substr(0, close);
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out + links + "}\n";
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
    std::string text = a.json ? sched::render_json(views, summary) : sched::render_table(views, summary);
    text = a.json ? with_links_json(img, text) : text + links_table(img);
    if (a.watch > 0 && !a.json) std::fputs("\x1b[H\x1b[2J", stdout);
    std::fputs(text.c_str(), stdout);
    if (!a.hist.empty() && a.watch <= 0) {
      std::printf("# histogram written to %s (scripts/plot-jitter %s draws it)\n", a.hist.c_str(),
                  a.hist.c_str());
    }
    std::fflush(stdout);
    if (a.watch <= 0) return;
    std::this_thread::sleep_for(std::chrono::duration<double>(a.watch));
    if (img.header().state.load() == 2) return;
  }
}

std::string fmt_value(double v, uint8_t kind) {
  char b[32];
  if (kind == 1) std::snprintf(b, sizeof b, "%d", v != 0 ? 1 : 0);
  else std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

void run_monitor(const ViewArgs& a) {
  io::ProcessImage img = attach_or_fail(a.name, "monitor");
  const bool tty = isatty(STDOUT_FILENO) != 0 && !a.once;
  for (;;) {
    std::string out;
    char line[256];
    const io::ImageHeader& h = img.header();
    std::snprintf(line, sizeof line, "runtime %s (pid %d), %u channels, %u tasks%s\n", h.name, h.pid,
                  h.n_channels, h.n_tasks, h.state.load() == 2 ? ", STOPPED" : "");
    out += line;
    for (uint32_t t = 0; t < h.n_tasks; ++t) {
      const io::TaskInfo& ti = img.task_info(t);
      std::snprintf(line, sizeof line, "  task %-12s %-20s swaps %llu, block errors %llu, input misses %llu\n",
                    ti.name, io::task_state_name(static_cast<io::TaskState>(ti.state.load())),
                    static_cast<unsigned long long>(ti.swaps.load()),
                    static_cast<unsigned long long>(ti.block_errors.load()),
                    static_cast<unsigned long long>(ti.input_misses.load()));
      out += line;
    }
    if (img.link_count() > 0) {
      std::snprintf(line, sizeof line, "\n  %-14s %-22s %-10s %9s %9s %6s %6s %6s  %s\n", "plc", "address", "state",
                    "rtt p50", "rtt p99", "recon", "tmout", "errors", "writes acked/failed/pending");
      out += line;
    }
    for (uint32_t l = 0; l < img.link_count(); ++l) {
      const sched::LinkSnapshot ls = sched::link_snapshot(img.link(l));
      std::snprintf(line, sizeof line, "  %-14s %-22s %-10s %7uus %7uus %6llu %6llu %6llu  %llu/%llu/%llu\n",
                    ls.name.c_str(), ls.address.c_str(), ls.state.c_str(), ls.rtt_p50_us, ls.rtt_p99_us,
                    ls.reconnects, ls.timeouts, ls.errors, ls.writes_acked, ls.writes_failed, ls.writes_pending);
      out += line;
    }
    std::snprintf(line, sizeof line, "\n  %-20s %-9s %-24s %14s  %-7s %8s  %s\n", "label", "dir", "channel",
                  "value", "quality", "age", "writer");
    out += line;
    for (uint32_t c = 0; c < img.channel_count(); ++c) {
      const io::ChannelDesc& d = img.channel(c);
      if (!a.filter.empty() && !std::strstr(d.label, a.filter.c_str()) && !std::strstr(d.key, a.filter.c_str())) {
        continue;
      }
      const io::ChannelValue v = img.read_channel(c);
      const io::RegionDesc& r = img.region(d.region);
      const char* dir = d.dir == 0 ? "input" : d.dir == 1 ? "output" : "setpoint";
      char age[32] = "-";
      if (v.timestamp_ns != 0) std::snprintf(age, sizeof age, "%.3fs", io::age_s(v.timestamp_ns));
      const bool unwired = r.kind == static_cast<uint8_t>(io::RegionKind::kUnwired);
      std::snprintf(line, sizeof line, "  %-20s %-9s %-24s %14s  %-7s %8s  %s\n", d.label, dir, d.key,
                    fmt_value(v.value, d.kind).c_str(),
                    unwired ? "bad" : v.fresh ? io::quality_name(v.quality) : "-", age,
                    unwired ? "(no driver)" : r.name);
      out += line;
    }
    if (tty) std::fputs("\x1b[H\x1b[2J", stdout);
    std::fputs(out.c_str(), stdout);
    std::fflush(stdout);
    if (a.once || h.state.load() == 2) return;
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
      "Examples:\n  rtplc stats\n  rtplc stats --json\n  rtplc stats --hist jitter.hist && scripts/plot-jitter jitter.hist");
  stats->add_option("--name", a->name, "runtime name (default rtplc)");
  stats->add_flag("--json", a->json, "machine-readable output");
  stats->add_option("--hist", a->hist, "also write the latency histograms to this file");
  stats->add_option("--watch", a->watch, "refresh every this many seconds");
  stats->callback([a] { run_stats(*a); });

  CLI::App* mon = app.add_subcommand("monitor", "Live values, quality and age of every channel.");
  mon->footer("Attaches read-only to the running runtime's process image.\n"
              "Examples:\n  rtplc monitor\n  rtplc monitor --once --filter SV_");
  mon->add_option("--name", a->name, "runtime name (default rtplc)");
  mon->add_flag("--once", a->once, "print once and exit");
  mon->add_option("--interval", a->interval, "refresh period in seconds (default 1)");
  mon->add_option("--filter", a->filter, "only channels whose label or address contains this");
  mon->callback([a] { run_monitor(*a); });
}

}  // namespace rtplc::app
