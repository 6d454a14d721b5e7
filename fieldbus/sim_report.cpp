// Text, JSON and gnuplot renderings of a simulation (see sim_report.h).
#include "fieldbus/sim_report.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "common/text.h"
#include "fieldbus/plan_report.h"

namespace rtplc::fieldbus {
namespace {

std::string stats_row(const char* name, const DelaySummary& s, const std::string& bound) {
  if (s.count == 0)
    return pad_right(name, 12) + pad_right("0", 10) + pad_right("-", 12) + pad_right("-", 12) + pad_right("-", 12) + bound + "\n";
  return pad_right(name, 12) + pad_right(std::to_string(s.count), 10) + pad_right(format_time(s.p50), 12) + pad_right(format_time(s.p99), 12) +
         pad_right(format_time(s.max), 12) + bound + "\n";
}

std::string stats_json(const DelaySummary& s) {
  return "{\"count\": " + std::to_string(s.count) + ", \"p50\": " + json_seconds(s.p50) +
         ", \"p99\": " + json_seconds(s.p99) + ", \"max\": " + json_seconds(s.max) + "}";
}

std::string format_rate(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string gp_quote(const std::string& s) {
  std::string out = "'";
  for (char ch : s) out += ch == '\'' ? std::string("''") : std::string(1, ch);
  return out + "'";
}

}  // namespace

bool simulation_holds(const Plan& p, const SimResult& r) {
  if (r.periodic.max > p.transfer_bound || r.lost_samples || r.vacant_samplings) return false;
  for (size_t i = 0; i < r.loops.size() && i < p.loops.size(); ++i) {
    if (r.loops[i].worst_delay > p.loops[i].delay_bound) return false;
  }
  return true;
}

std::string render_sim_text(const Design& d, const Plan& p, const SimResult& r, uint64_t seed) {
  std::string s = "\nsimulation  " + format_time(r.duration) + " of bus time, seed " + std::to_string(seed) +
                  ", " + (d.access == Access::kTokenPassing ? "token passing" : "polling") +
                  ", non-RT packets " + format_time(p.nonrt_packet) +
                  (r.nonrt_saturated ? " (every node always has some)"
                                     : ", " + format_rate(d.nonrt_rate) + "/s per node") +
                  ", real-time " + format_rate(d.rt_rate) + "/s per queue\n";
  s += pad_right("class", 12) + pad_right("count", 10) + pad_right("p50", 12) + pad_right("p99", 12) + pad_right("max", 12) +
       "plan's bound\n";
  s += stats_row("periodic", r.periodic, "W = " + format_time(p.transfer_bound));
  s += stats_row("loop delay", r.loop_delay, "T_i + W per loop (below)");
  s += stats_row("real-time", r.realtime, "-");
  if (r.nonrt_saturated) {
    s += pad_right("non-RT", 12) + "saturated: " + std::to_string(r.nonrt_packets) + " packets\n";
  } else {
    s += stats_row("non-RT", r.nonrt, "-");
  }
  char buf[160];
  std::snprintf(buf, sizeof buf, "non-RT throughput %.1f packets/s, %.1f%% of the bus\n",
                r.nonrt_per_second, 100 * r.nonrt_bus_share);
  s += buf;
  s += "samples " + std::to_string(r.samples) + ", lost " + std::to_string(r.lost_samples) +
       ", vacant samplings " + std::to_string(r.vacant_samplings) +
       ", periodic packets later than T_1 " + std::to_string(r.late_packets) + "\n";
  s += pad_right("loop", 14) + pad_right("worst D", 14) + pad_right("bound", 14) + "lost  vacant\n";
  const size_t shown = std::min<size_t>(r.loops.size(), 20);
  for (size_t i = 0; i < shown; ++i) {
    const LoopSimStats& l = r.loops[i];
    s += pad_right(l.name, 14) + pad_right(format_time(l.worst_delay), 14) + pad_right(format_time(p.loops[i].delay_bound), 14) +
         pad_right(std::to_string(l.lost), 6) + std::to_string(l.vacant) +
         (l.worst_delay > p.loops[i].delay_bound ? "  EXCEEDS" : "") + "\n";
  }
  if (shown < r.loops.size())
    s += "... " + std::to_string(r.loops.size() - shown) + " more loops\n";
  s += simulation_holds(p, r)
           ? "verdict     the plan holds: every delay within its bound, nothing lost, no vacant "
             "sampling\n"
           : "verdict     the plan does NOT hold in this run\n";
  return s;
}

std::string render_sim_json(const Plan& p, const SimResult& r, uint64_t seed) {
  std::string s = "{\"duration\": " + json_seconds(r.duration) +
                  ", \"seed\": " + std::to_string(seed) +
                  ", \"holds\": " + (simulation_holds(p, r) ? "true" : "false");
  s +=
      ", \"periodic\": " + stats_json(r.periodic) + ", \"loop_delay\": " + stats_json(r.loop_delay);
  s += ", \"realtime\": " + stats_json(r.realtime) + ", \"nonrt\": " + stats_json(r.nonrt);
  s += ", \"samples\": " + std::to_string(r.samples) +
       ", \"lost_samples\": " + std::to_string(r.lost_samples) +
       ", \"vacant_samplings\": " + std::to_string(r.vacant_samplings) +
       ", \"late_packets\": " + std::to_string(r.late_packets) +
       ", \"nonrt_packets\": " + std::to_string(r.nonrt_packets);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", r.nonrt_per_second);
  s += std::string(", \"nonrt_per_second\": ") + buf;
  std::snprintf(buf, sizeof buf, "%.6g", r.nonrt_bus_share);
  s += std::string(", \"nonrt_bus_share\": ") + buf + "}";
  return s;
}

Result<void> write_delay_plot(const Plan& p, const SimResult& r, const std::string& png_path,
                              const std::string& title) {
  char tmpl[] = "/tmp/rtplc-fieldbus-XXXXXX";
  const int fd = mkstemp(tmpl);
  if (fd < 0) return make_error("cannot create a temporary file for the plot data");
  FILE* f = fdopen(fd, "w");
  if (!f) {
    close(fd);
    unlink(tmpl);
    return make_error("cannot write the plot data");
  }
  // One block per class: delay in ms and the fraction of packets at most that late.
  struct Series {
    const char* name;
    std::vector<Nanos> v;
  };
  Series series[] = {{"periodic", r.periodic_samples},
                     {"loop delay", r.loop_samples},
                     {"real-time", r.realtime_samples},
                     {"non-RT", r.nonrt_samples}};
  std::string plot;
  int block = 0;
  for (Series& se : series) {
    if (se.v.empty()) continue;
    std::sort(se.v.begin(), se.v.end());
    const size_t n = se.v.size();
    const size_t step = std::max<size_t>(1, n / 2000);
    for (size_t i = 0; i < n; i += step) {
      std::fprintf(f, "%.9g %.9g\n", to_seconds(se.v[i]) * 1e3,
                   static_cast<double>(i + 1) / static_cast<double>(n));
    }
    std::fprintf(f, "%.9g 1\n\n\n", to_seconds(se.v.back()) * 1e3);
    plot += std::string(plot.empty() ? "" : ", ") + gp_quote(tmpl) + " index " +
            std::to_string(block++) + " using 1:2 with lines lw 2 title " + gp_quote(se.name);
  }
  std::fclose(f);
  if (plot.empty()) {
    unlink(tmpl);
    return make_error("the simulation recorded no delays to plot");
  }
  std::string script = "set terminal pngcairo size 1000,600 font 'Sans,10'\n";
  script += "set output " + gp_quote(png_path) + "\n";
  script += "set title " + gp_quote(title) + " noenhanced\n";
  script += "set xlabel 'delay (ms)'\nset ylabel 'fraction of packets'\nset grid\n";
  script += "set key bottom right\nset yrange [0:1.02]\n";
  script += "set arrow from " + std::to_string(to_seconds(p.transfer_bound) * 1e3) +
            ", graph 0 to " + std::to_string(to_seconds(p.transfer_bound) * 1e3) +
            ", graph 1 nohead dt 2 lc 'red'\n";
  script += "set label 'W' at " + std::to_string(to_seconds(p.transfer_bound) * 1e3) +
            ", graph 0.95 offset 0.5,0 tc 'red'\n";
  script += "set arrow from " + std::to_string(to_seconds(p.t1) * 1e3) + ", graph 0 to " +
            std::to_string(to_seconds(p.t1) * 1e3) + ", graph 1 nohead dt 3 lc 'black'\n";
  script += "set label 'T_1' at " + std::to_string(to_seconds(p.t1) * 1e3) +
            ", graph 0.90 offset 0.5,0 noenhanced\n";
  script += "plot " + plot + "\n";
  FILE* gp = popen("gnuplot 2>&1", "w");
  if (!gp) {
    unlink(tmpl);
    return make_error("cannot start gnuplot (install the gnuplot-nox package)");
  }
  std::fputs(script.c_str(), gp);
  const int rc = pclose(gp);
  unlink(tmpl);
  if (rc != 0) {
    return make_error("gnuplot failed (exit " + std::to_string(rc) +
                      "); is gnuplot installed? scripts/setup-deps installs it");
  }
  return {};
}

}  // namespace rtplc::fieldbus
