// The `rtplc stats` table, the scheduling summary under it, and the same as JSON (spec:
// runtime.md, "Jitter monitor": printed like cyclictest so the two can be compared side by
// side). The layout is described with examples in docs/jitter.md; tests/jitter holds golden
// copies of both.
#include "sched/stats_render.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "kernel_rt/doctor_render.h"

namespace rtplc::sched {

namespace {

// cyclictest reports whole microseconds, rounded down; so do the "T:" lines, so a user
// comparing the two compares like with like.
int64_t us_floor(int64_t ns) { return ns / 1000; }
// Exec times are often below a microsecond: one decimal.
double us(int64_t ns) { return static_cast<double>(ns) / 1000.0; }

std::string uptime_text(int64_t ns) {
  const int64_t s = std::max<int64_t>(ns, 0) / 1'000'000'000;
  const int64_t days = s / 86'400;
  const int64_t h = s / 3600 % 24;
  const int64_t m = s / 60 % 60;
  const int64_t sec = s % 60;
  if (days > 0) return fmt::format("{}d {:02}:{:02}:{:02}", days, h, m, sec);
  return fmt::format("{}:{:02}:{:02}", h, m, sec);
}

// The interval the way cyclictest's I: prints it, in microseconds; a period that is not a
// whole number of microseconds keeps its fraction.
std::string interval_text(int64_t period_ns) {
  if (period_ns % 1000 == 0) return fmt::format("{}", period_ns / 1000);
  return fmt::format("{:.3f}", us(period_ns));
}

std::string cpu_text(int cpu) { return cpu < 0 ? std::string("any") : fmt::format("{}", cpu); }

double percent(double fraction) { return fraction * 100.0; }

// The state column ends the line; an empty one must not leave padding behind.
void end_line(std::string& out) {
  while (!out.empty() && out.back() == ' ') out.pop_back();
  out += '\n';
}

// One sentence on what the utilisation means for rate-monotonic scheduling.
std::string schedulability_verdict(const RuntimeSummary& s) {
  if (s.tasks == 0) return "no tasks";
  if (s.utilisation > 1.0) return "overloaded: more work than CPU time";
  if (s.utilisation > s.liu_layland_bound) return "above it: deadlines not guaranteed";
  if (s.utilisation_worst > s.liu_layland_bound) return "average within, max exec not";
  return "within it, even at max exec";
}

}  // namespace

void take_snapshots(TaskStatsView& view, const CycleStats& stats) noexcept {
  view.wake = snapshot(stats, Series::kWake);
  view.exec = snapshot(stats, Series::kExec);
}

double liu_layland_bound(size_t n) noexcept {
  if (n == 0) return 0.0;
  const auto dn = static_cast<double>(n);
  return dn * (std::exp2(1.0 / dn) - 1.0);
}

namespace {
double utilisation_by(const std::vector<TaskStatsView>& views, int64_t StatsSnapshot::*field) {
  double u = 0.0;
  for (const auto& v : views) {
    if (v.period_ns <= 0 || v.exec.count == 0) continue;
    u += static_cast<double>(v.exec.*field) / static_cast<double>(v.period_ns);
  }
  return u;
}
}  // namespace

double utilisation(const std::vector<TaskStatsView>& views) noexcept {
  return utilisation_by(views, &StatsSnapshot::avg_ns);
}

double worst_case_utilisation(const std::vector<TaskStatsView>& views) noexcept {
  return utilisation_by(views, &StatsSnapshot::max_ns);
}

RuntimeSummary summarise(const std::vector<TaskStatsView>& views, int64_t uptime_ns, bool rt_kernel,
                         std::string kernel, std::string note) {
  RuntimeSummary s;
  s.uptime_ns = uptime_ns;
  s.rt_kernel = rt_kernel;
  s.kernel = std::move(kernel);
  s.note = std::move(note);
  s.tasks = views.size();
  s.liu_layland_bound = liu_layland_bound(views.size());
  s.utilisation = utilisation(views);
  s.utilisation_worst = worst_case_utilisation(views);
  return s;
}

std::string render_table(const std::vector<TaskStatsView>& views, const RuntimeSummary& summary) {
  std::string out;
  out += fmt::format("# rtplc stats: {} task{}, up {}", views.size(), views.size() == 1 ? "" : "s",
                     uptime_text(summary.uptime_ns));
  if (!summary.kernel.empty()) out += fmt::format(", kernel {}", summary.kernel);
  out += fmt::format(", PREEMPT_RT: {}\n", summary.rt_kernel ? "yes" : "no");
  if (views.empty()) {
    out += "# no tasks\n";
    return out;
  }

  // Pad after the closing parenthesis, never inside it: "(loop1)" stays one field for
  // scripts that split cyclictest lines on blanks, and the columns still line up.
  size_t name_width = 0;
  size_t interval_width = 0;
  size_t index_width = 2;  // cyclictest's "T:%2d"
  for (const auto& v : views) {
    name_width = std::max(name_width, v.name.size() + 2);
    interval_width = std::max(interval_width, interval_text(v.period_ns).size());
  }
  index_width = std::max(index_width, fmt::format("{}", views.size() - 1).size());
  auto head = [&](char tag, size_t i, const TaskStatsView& v) {
    return fmt::format("{}:{:>{}} {:<{}}", tag, i, index_width, "(" + v.name + ")", name_width);
  };

  out += "# wake latency = wake - release, in us; P99/P99.9 from the histogram; Ovr = overruns\n";
  for (size_t i = 0; i < views.size(); ++i) {
    const TaskStatsView& v = views[i];
    const StatsSnapshot& w = v.wake;
    // cyclictest: "T:%2d (%5d) P:%2d I:%ld C:%7lu Min:%7ld Act:%5ld Avg:%5ld Max:%8ld"
    out += fmt::format(
        "{} P:{:>2} I:{:<{}} C:{:>7} Min:{:>7} Act:{:>5} Avg:{:>5} Max:{:>8} P99:{:>6} P99.9:{:>6} "
        "Ovr:{:>4}\n",
        head('T', i, v), v.priority, interval_text(v.period_ns), interval_width, w.count,
        us_floor(w.min_ns), us_floor(w.last_ns), us_floor(w.avg_ns), us_floor(w.max_ns),
        us_floor(w.p99_ns), us_floor(w.p999_ns), w.overruns);
  }

  out += "# exec time = end - wake, in us; U = avg exec / period; Skip = releases skipped; "
         "Run = overruns in a row now/longest\n";
  size_t policy_width = 0;
  for (const auto& v : views) policy_width = std::max(policy_width, v.policy.size());
  for (size_t i = 0; i < views.size(); ++i) {
    const TaskStatsView& v = views[i];
    const StatsSnapshot& e = v.exec;
    const double u = v.period_ns > 0 && e.count > 0
                         ? static_cast<double>(e.avg_ns) / static_cast<double>(v.period_ns)
                         : 0.0;
    out += fmt::format(
        "{} Avg: {:>6.1f} Max: {:>6.1f} P99: {:>6.1f} P99.9: {:>6.1f} U:{:>6.2f}% Skip:{:>4} "
        "Run:{}/{} {:<{}} cpu:{:<3} {}",
        head('E', i, v), us(e.avg_ns), us(e.max_ns), us(e.p99_ns), us(e.p999_ns), percent(u),
        v.wake.skipped_releases, v.wake.consecutive_overruns, v.wake.max_consecutive_overruns,
        v.policy, policy_width, cpu_text(v.cpu), v.state);
    end_line(out);
  }

  out += fmt::format(
      "# utilisation {:.2f}% avg, {:.2f}% at max exec; Liu-Layland bound {:.1f}% ({} task{}): {}\n",
      percent(summary.utilisation), percent(summary.utilisation_worst),
      percent(summary.liu_layland_bound), summary.tasks, summary.tasks == 1 ? "" : "s",
      schedulability_verdict(summary));
  if (!summary.note.empty()) out += fmt::format("# note: {}\n", summary.note);
  return out;
}

// --- JSON ---------------------------------------------------------------------------------
// Keys are part of the interface (docs/jitter.md lists them; scripts rely on them): add keys,
// never rename or remove one. All times are exact nanoseconds.
namespace {

using kernel_rt::json_quote;

// Fractions with six decimals: enough for a utilisation of one part per million, and a
// fixed notation that every JSON reader accepts (no "1e-07").
std::string fraction(double v) { return fmt::format("{:.6f}", v); }

std::string series_object(const StatsSnapshot& s) {
  return fmt::format(
      "{{\"min\": {}, \"avg\": {}, \"max\": {}, \"last\": {}, \"p50\": {}, \"p90\": {}, "
      "\"p99\": {}, \"p99_9\": {}}}",
      s.min_ns, s.avg_ns, s.max_ns, s.last_ns, s.p50_ns, s.p90_ns, s.p99_ns, s.p999_ns);
}

std::string task_object(size_t index, const TaskStatsView& v) {
  const StatsSnapshot& w = v.wake;  // the overrun counters are the same in both snapshots
  const double u = v.period_ns > 0 && v.exec.count > 0
                       ? static_cast<double>(v.exec.avg_ns) / static_cast<double>(v.period_ns)
                       : 0.0;
  std::string out = "    {";
  out += fmt::format("\"index\": {}, \"name\": {}, \"period_ns\": {}, \"priority\": {}, ", index,
                     json_quote(v.name), v.period_ns, v.priority);
  out += fmt::format("\"policy\": {}, \"cpu\": {}, \"state\": {},\n", json_quote(v.policy), v.cpu,
                     json_quote(v.state));
  out += fmt::format(
      "     \"cycles\": {}, \"overruns\": {}, \"skipped_releases\": {}, "
      "\"consecutive_overruns\": {}, \"max_consecutive_overruns\": {}, \"utilisation\": {},\n",
      w.count, w.overruns, w.skipped_releases, w.consecutive_overruns, w.max_consecutive_overruns,
      fraction(u));
  out += fmt::format("     \"wake_ns\": {},\n", series_object(v.wake));
  out += fmt::format("     \"exec_ns\": {}}}", series_object(v.exec));
  return out;
}

}  // namespace

std::string render_json(const std::vector<TaskStatsView>& views, const RuntimeSummary& summary) {
  std::string out = "{\n  \"format\": 1,\n";
  out += fmt::format(
      "  \"runtime\": {{\"uptime_ns\": {}, \"rt_kernel\": {}, \"kernel\": {}, \"tasks\": {}, "
      "\"liu_layland_bound\": {}, \"utilisation\": {}, \"utilisation_worst\": {}, \"note\": {}}},\n",
      summary.uptime_ns, summary.rt_kernel ? "true" : "false", json_quote(summary.kernel),
      summary.tasks, fraction(summary.liu_layland_bound), fraction(summary.utilisation),
      fraction(summary.utilisation_worst), json_quote(summary.note));
  out += "  \"tasks\": [";
  for (size_t i = 0; i < views.size(); ++i) {
    out += i == 0 ? "\n" : ",\n";
    out += task_object(i, views[i]);
  }
  out += views.empty() ? "]\n}\n" : "\n  ]\n}\n";
  return out;
}

}  // namespace rtplc::sched
