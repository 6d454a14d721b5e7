// Task statistics views from a process image (see stats_source.h).
#include "sched/stats_source.h"
#include "kernel_rt/clock.h"

#include <algorithm>

#include <dirent.h>

#include <sys/utsname.h>
#include <time.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>

#include <fmt/format.h>

#include "common/text.h"
#include "config/config.h"
#include "kernel_rt/rt_kernel.h"
#include "sched/jitter.h"

namespace rtplc::sched {

std::vector<TaskStatsView> read_task_stats(const io::ProcessImage& image) {
  std::vector<TaskStatsView> views;
  const io::ImageHeader& h = image.header();
  if (h.task_stats_size != sizeof(CycleStats)) return views;  // another rtplc build's layout
  for (uint32_t t = 0; t < h.n_tasks; ++t) {
    const io::TaskInfo& ti = image.task_info(t);
    TaskStatsView v;
    v.name = std::string(ti.name, strnlen(ti.name, sizeof ti.name));
    v.period_ns = ti.period_ns;
    v.priority = ti.fifo ? ti.priority : 0;
    v.policy = ti.fifo ? "FIFO" : "OTHER";
    v.cpu = ti.cpu;
    v.state = io::task_state_name(static_cast<io::TaskState>(ti.state.load(std::memory_order_relaxed)));
    take_snapshots(v, *static_cast<const CycleStats*>(image.task_stats(t)));
    views.push_back(std::move(v));
  }
  return views;
}

int64_t runtime_uptime_ns(const io::ProcessImage& image) {
  return kernel_rt::realtime_now_ns() - image.header().started_realtime_ns;
}

RuntimeSummary summary_of(const io::ProcessImage& image, const std::vector<TaskStatsView>& views) {
  std::string note;
  for (const TaskStatsView& v : views) {
    if (v.policy != "FIFO") note = "tasks run SCHED_OTHER (no SCHED_FIFO privilege): latencies are not real-time";
  }
  utsname u{};
  uname(&u);
  return summarise(views, runtime_uptime_ns(image), kernel_rt::running_on_rt_kernel(), u.release, note);
}

std::string not_running_text(const std::string& name, const io::Liveness& l) {
  std::string when = "an unknown time";
  if (l.last_heartbeat_realtime_ns > 0) {
    const time_t t = static_cast<time_t>(l.last_heartbeat_realtime_ns / 1000000000);
    tm local{};
    localtime_r(&t, &local);
    char buf[64];
    std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", &local);
    when = buf;
  }
  return "runtime " + name + " is not running (died at " + when + ": " + l.why + ")";
}

std::vector<RuntimeSeen> runtimes_on_this_machine() {
  std::vector<RuntimeSeen> out;
  DIR* d = opendir("/dev/shm");
  if (d == nullptr) return out;
  const std::string prefix = "rtplc-";
  while (const dirent* e = readdir(d)) {
    const std::string f = e->d_name;
    if (f.rfind(prefix, 0) != 0 || f.size() == prefix.size()) continue;
    RuntimeSeen r;
    r.name = f.substr(prefix.size());
    auto img = io::ProcessImage::attach(r.name);
    if (!img) continue;  // not ours to read, or not an image
    const io::Liveness live = img->liveness();
    r.alive = live.alive;
    if (!live.alive) r.why = not_running_text(r.name, live);
    const io::ImageHeader& h = img->header();
    r.socket = std::string(h.socket_path, strnlen(h.socket_path, sizeof h.socket_path));
    out.push_back(std::move(r));
  }
  closedir(d);
  std::sort(out.begin(), out.end(), [](const RuntimeSeen& a, const RuntimeSeen& b) { return a.name < b.name; });
  return out;
}

std::string running_runtimes_hint() {
  std::string names;
  for (const RuntimeSeen& r : runtimes_on_this_machine()) {
    if (r.alive) names += (names.empty() ? "" : ", ") + r.name;
  }
  return names.empty() ? std::string("; no runtime is running here (`rtplc run CONFIG` starts one)")
                       : "; running here: " + names + " (choose one with --name; `rtplc list` shows them)";
}

LinkSnapshot link_snapshot(const io::LinkStatus& ls) {
  const auto r = std::memory_order_relaxed;
  LinkSnapshot s;
  s.name = std::string(ls.name, strnlen(ls.name, sizeof ls.name));
  s.driver = std::string(ls.driver, strnlen(ls.driver, sizeof ls.driver));
  s.kind = std::string(ls.kind, strnlen(ls.kind, sizeof ls.kind));
  s.peer = std::string(ls.peer, strnlen(ls.peer, sizeof ls.peer));
  s.state = io::link_state_name(static_cast<io::LinkState>(ls.state.load(r)));
  s.quality = quality_name(static_cast<Quality>(ls.quality.load(r)));
  s.rtt_p50_us = ls.rtt_p50_us.load(r);
  s.rtt_p99_us = ls.rtt_p99_us.load(r);
  s.rtt_max_us = ls.rtt_max_us.load(r);
  s.polls_completed = ls.polls_completed.load(r);
  s.polls_missed = ls.polls_missed.load(r);
  s.polls_offline = ls.polls_offline.load(r);
  s.connects = ls.connects.load(r);
  s.reconnects = ls.reconnects.load(r);
  s.timeouts = ls.timeouts.load(r);
  s.errors = ls.errors.load(r);
  s.writes_acked = ls.writes_acked.load(r);
  s.writes_failed = ls.writes_failed.load(r);
  s.writes_pending = ls.writes_pending.load(r);
  s.writes_rejected = ls.writes_rejected.load(r);
  for (size_t b = 0; b < io::kLinkLatencyBuckets; ++b) s.latency.push_back(ls.latency[b].load(r));
  s.plan = std::string(ls.plan, strnlen(ls.plan, sizeof ls.plan));
  io::LinkError e{};
  if (ls.last_error.try_load(e) && e.at_ns > 0) {
    s.last_error = std::string(e.text, strnlen(e.text, sizeof e.text));
    s.last_error_age_s = static_cast<double>(kernel_rt::monotonic_now_ns() - e.at_ns) / 1e9;
  }
  for (size_t g = 0; g < io::kLinkGauges; ++g) {
    if (ls.gauge_names[g][0] == '\0') continue;
    s.gauges.emplace_back(std::string(ls.gauge_names[g], strnlen(ls.gauge_names[g], sizeof ls.gauge_names[g])),
                          ls.gauges[g].load(r));
  }
  for (const io::LinkClassStatus& c : ls.classes) {
    if (c.name[0] == '\0') continue;
    LinkSnapshot::TrafficClass t;
    t.name = std::string(c.name, strnlen(c.name, sizeof c.name));
    t.count = c.count.load(r);
    t.missed = c.missed.load(r);
    t.delay_p99_ns = c.delay_p99_ns.load(r);
    t.delay_max_ns = c.delay_max_ns.load(r);
    t.delay_bound_ns = c.delay_bound_ns.load(r);
    t.packet_max_ns = c.packet_max_ns.load(r);
    t.packet_bound_ns = c.packet_bound_ns.load(r);
    s.classes.push_back(std::move(t));
  }
  return s;
}

namespace {

std::string us_text(long long ns) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", static_cast<double>(ns) / 1e3);
  return b;
}

// A class holds its design when nothing missed its window and no measured
// figure passes its bound.
bool class_holds(const LinkSnapshot::TrafficClass& c) {
  return c.missed == 0 && (c.delay_bound_ns == 0 || c.delay_max_ns <= c.delay_bound_ns) &&
         (c.packet_bound_ns == 0 || c.packet_max_ns <= c.packet_bound_ns);
}

}  // namespace

std::string render_link_classes(const LinkSnapshot& s) {
  if (s.plan.empty()) return "";
  std::string out = "    plan " + s.plan + "\n";
  for (const LinkSnapshot::TrafficClass& c : s.classes) {
    out += "    " + c.name + ": " + std::to_string(c.count) + " sent, delay p99/max " + us_text(c.delay_p99_ns) +
           "/" + us_text(c.delay_max_ns) + " us (bound " +
           (c.delay_bound_ns ? us_text(c.delay_bound_ns) + " us" : std::string("none")) + "), " +
           std::to_string(c.missed) + " missed, packet max " + us_text(c.packet_max_ns) + " us (bound " +
           us_text(c.packet_bound_ns) + " us)" + (class_holds(c) ? "" : "  EXCEEDS THE PLAN") + "\n";
  }
  return out;
}

// ", births 1, seq 17, bdSeq 3": the kind's own figures ("" when it has none).
std::string gauges_text(const LinkSnapshot& s) {
  std::string out;
  for (const auto& [name, value] : s.gauges) out += ", " + name + " " + std::to_string(value);
  if (!s.last_error.empty()) {
    char age[32];
    std::snprintf(age, sizeof age, "%.0f s ago", s.last_error_age_s);
    out += ", last error " + std::string(age) + ": " + s.last_error;
  }
  return out;
}

std::string link_status_line(const LinkSnapshot& s) {
  return "link " + s.name + " (" + s.kind + " driver " + s.driver + ", " + s.peer + "): " + s.state +
         ", rtt p50/p99 " + std::to_string(s.rtt_p50_us) + "/" + std::to_string(s.rtt_p99_us) + " us, " +
         std::to_string(s.reconnects) + " reconnects, " + std::to_string(s.timeouts) + " timeouts, " +
         std::to_string(s.errors) + " errors, writes " + std::to_string(s.writes_acked) + " acked / " +
         std::to_string(s.writes_failed) + " failed / " + std::to_string(s.writes_pending) + " pending" +
         gauges_text(s);
}

std::string render_links_table(const io::ProcessImage& img) {
  if (img.link_count() == 0) return "";
  std::string out =
      "# links: round-trip time p50/p99 in us; polls done/missed/offline; writes acked/failed/pending\n";
  char line[400];
  for (uint32_t l = 0; l < img.link_count(); ++l) {
    const LinkSnapshot s = link_snapshot(img.link(l));
    std::snprintf(line, sizeof line,
                  "L:%2u (%s) %s %s %s RTT: %u/%u Polls: %llu/%llu/%llu Recon: %llu Tmout: %llu Err: %llu "
                  "Writes: %llu/%llu/%llu\n",
                  l, s.name.c_str(), s.kind.c_str(), s.peer.c_str(), s.state.c_str(), s.rtt_p50_us,
                  s.rtt_p99_us, s.polls_completed, s.polls_missed, s.polls_offline, s.reconnects, s.timeouts,
                  s.errors, s.writes_acked, s.writes_failed, s.writes_pending);
    out += line;
    if (!s.gauges.empty() || !s.last_error.empty()) out += "      " + gauges_text(s).substr(2) + "\n";
    out += render_link_classes(s);
  }
  return out;
}

std::string with_links_json(const io::ProcessImage& img, const std::string& json) {
  const size_t close = json.find_last_of('}');
  if (close == std::string::npos) return json;
  std::string links = ",\n  \"links\": [";
  char item[768];
  for (uint32_t l = 0; l < img.link_count(); ++l) {
    const LinkSnapshot s = link_snapshot(img.link(l));
    std::string hist;
    for (size_t b = 0; b < s.latency.size(); ++b) hist += (b ? ", " : "") + std::to_string(s.latency[b]);
    std::snprintf(item, sizeof item,
                  "%s\n    {\"name\": \"%s\", \"driver\": \"%s\", \"kind\": \"%s\", \"peer\": \"%s\", "
                  "\"state\": \"%s\", \"quality\": \"%s\", \"rtt_p50_us\": %u, \"rtt_p99_us\": %u, "
                  "\"rtt_max_us\": %u, \"polls_completed\": %llu, \"polls_missed\": %llu, "
                  "\"polls_offline\": %llu, \"connects\": %llu, \"reconnects\": %llu, \"timeouts\": %llu, "
                  "\"errors\": %llu, \"writes_acked\": %llu, \"writes_failed\": %llu, "
                  "\"writes_pending\": %llu, \"writes_rejected\": %llu, \"latency_histogram\": [%s]}",
                  l ? "," : "", s.name.c_str(), s.driver.c_str(), s.kind.c_str(), s.peer.c_str(),
                  s.state.c_str(), s.quality.c_str(), s.rtt_p50_us, s.rtt_p99_us, s.rtt_max_us,
                  s.polls_completed, s.polls_missed, s.polls_offline, s.connects, s.reconnects, s.timeouts,
                  s.errors, s.writes_acked, s.writes_failed, s.writes_pending, s.writes_rejected, hist.c_str());
    links += item;
    if (!s.gauges.empty() || !s.last_error.empty()) {
      links.pop_back();  // the item's closing brace
      links += ", \"gauges\": {";
      for (size_t g = 0; g < s.gauges.size(); ++g) {
        links += (g ? ", \"" : "\"") + s.gauges[g].first + "\": " + std::to_string(s.gauges[g].second);
      }
      links += "}";
      if (!s.last_error.empty()) {
        std::string text;
        for (char ch : s.last_error) {
          if (ch == '"' || ch == '\\') text += '\\';
          if (static_cast<unsigned char>(ch) >= 0x20) text += ch;
        }
        char age[32];
        std::snprintf(age, sizeof age, "%.3f", s.last_error_age_s);
        links += ", \"last_error\": \"" + text + "\", \"last_error_age_s\": " + age;
      }
      links += "}";
    }
    if (!s.plan.empty()) {
      // Planned link: the plan and its classes, times in seconds like the planner's JSON.
      links.pop_back();  // the item's closing brace
      std::string plan_text;
      for (char ch : s.plan) {
        if (ch == '"' || ch == '\\') plan_text += '\\';
        if (static_cast<unsigned char>(ch) >= 0x20) plan_text += ch;
      }
      links += ", \"plan\": \"" + plan_text + "\", \"classes\": [";
      for (size_t c = 0; c < s.classes.size(); ++c) {
        const LinkSnapshot::TrafficClass& t = s.classes[c];
        char bound[32] = "null";
        if (t.delay_bound_ns) std::snprintf(bound, sizeof bound, "%.9g", static_cast<double>(t.delay_bound_ns) / 1e9);
        std::snprintf(item, sizeof item,
                      "%s{\"name\": \"%s\", \"count\": %llu, \"missed\": %llu, \"delay_p99\": %.9g, "
                      "\"delay_max\": %.9g, \"delay_bound\": %s, \"packet_max\": %.9g, \"packet_bound\": %.9g, "
                      "\"holds\": %s}",
                      c ? ", " : "", t.name.c_str(), t.count, t.missed, static_cast<double>(t.delay_p99_ns) / 1e9,
                      static_cast<double>(t.delay_max_ns) / 1e9,
                      bound,
                      static_cast<double>(t.packet_max_ns) / 1e9, static_cast<double>(t.packet_bound_ns) / 1e9,
                      class_holds(t) ? "true" : "false");
        links += item;
      }
      links += "]}";
    }
  }
  links += img.link_count() ? "\n  ]\n" : "]\n";
  std::string out = json.substr(0, close);
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out + links + "}\n";
}

std::vector<ForcedChannel> forced_channels(const io::ProcessImage& img) {
  std::vector<ForcedChannel> out;
  for (uint32_t c = 0; c < img.channel_count(); ++c) {
    const io::ChannelDesc& d = img.channel(c);
    const io::ForcedValue f = img.forced(d.region, d.index);
    if (!f.forced) continue;
    out.push_back({std::string(d.label, strnlen(d.label, sizeof d.label)),
                   d.dir == static_cast<uint8_t>(io::ChannelDir::kInput) ? "input" : "output", f.value});
  }
  return out;
}

std::string render_forced(const io::ProcessImage& img) {
  const std::vector<ForcedChannel> f = forced_channels(img);
  if (f.empty()) return "";
  std::string out = "FORCED: " + std::to_string(f.size()) + (f.size() == 1 ? " channel:" : " channels:");
  for (size_t i = 0; i < f.size(); ++i) {
    out += (i ? ", " : " ") + f[i].label + " (" + f[i].dir + ") = " + format_number(f[i].value);
  }
  return out + "  (rtplc unforce LABEL | --all)\n";
}

std::string with_forced_json(const io::ProcessImage& img, const std::string& json) {
  const size_t close = json.find_last_of('}');
  if (close == std::string::npos) return json;
  const std::vector<ForcedChannel> f = forced_channels(img);
  std::string items = ",\n  \"forced\": [";
  char item[160];
  for (size_t i = 0; i < f.size(); ++i) {
    // Labels are letters, digits, '_', '-' and '.': nothing to escape.
    std::snprintf(item, sizeof item, "%s\n    {\"label\": \"%s\", \"dir\": \"%s\", \"value\": %.17g}",
                  i ? "," : "", f[i].label.c_str(), f[i].dir.c_str(), f[i].value);
    items += item;
  }
  items += f.empty() ? "]\n" : "\n  ]\n";
  std::string out = json.substr(0, close);
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out + items + "}\n";
}

// Whether `--filter` keeps a channel: its label or its address contains it.
const char* shown_quality(const io::ProcessImage& img, uint32_t c, const io::ChannelValue& v, const io::Liveness& live) {
  const io::RegionDesc& r = img.region(img.channel(c).region);
  const bool unwired = r.kind == static_cast<uint8_t>(io::RegionKind::kUnwired);
  return !live.alive ? "stale" : unwired || !v.fresh ? "bad" : quality_name(v.quality);
}

bool channel_shown(const io::ChannelDesc& d, const std::string& filter) {
  return filter.empty() || std::strstr(d.label, filter.c_str()) || std::strstr(d.key, filter.c_str());
}

// Labels and keys are letters, digits, '_', '-', '.', '/' (nothing to escape).
std::string monitor_json(const io::ProcessImage& img, const io::Liveness& live, const std::string& filter) {
  const io::ImageHeader& h = img.header();
  std::string out = fmt::format("{{\n  \"runtime\": \"{}\", \"pid\": {}, \"alive\": {},\n  \"tasks\": [", h.name,
                                h.pid, live.alive ? "true" : "false");
  for (uint32_t t = 0; t < h.n_tasks; ++t) {
    const io::TaskInfo& ti = img.task_info(t);
    out += fmt::format("{}\n    {{\"name\": \"{}\", \"state\": \"{}\", \"swaps\": {}, \"block_errors\": {}, "
                       "\"input_misses\": {}}}",
                       t ? "," : "", ti.name,
                       live.alive ? io::task_state_name(static_cast<io::TaskState>(ti.state.load())) : "not running",
                       ti.swaps.load(), ti.block_errors.load(), ti.input_misses.load());
  }
  out += h.n_tasks ? "\n  ],\n  \"channels\": [" : "],\n  \"channels\": [";
  bool first = true;
  for (uint32_t c = 0; c < img.channel_count(); ++c) {
    const io::ChannelDesc& d = img.channel(c);
    if (!channel_shown(d, filter)) continue;
    const io::ChannelValue v = img.read_channel(c);
    const io::RegionDesc& r = img.region(d.region);
    const bool unwired = r.kind == static_cast<uint8_t>(io::RegionKind::kUnwired);
    const bool output = d.dir == static_cast<uint8_t>(io::ChannelDir::kOutput);
    const bool unsent = output && d.has_delivery == 0;
    const char* quality = shown_quality(img, c, v, live);
    const std::string value = std::isfinite(v.value) ? fmt::format("{}", v.value) : "null";
    const std::string age = v.timestamp_ns != 0 ? fmt::format("{:.3f}", io::age_s(v.timestamp_ns)) : "null";
    out += fmt::format("{}\n    {{\"label\": \"{}\", \"dir\": \"{}\", \"channel\": \"{}\", \"value\": {}, "
                       "\"quality\": \"{}\", \"age_s\": {}, \"writer\": \"{}\", \"forced\": {}",
                       first ? "" : ",", d.label, d.dir == 0 ? "input" : output ? "output" : "setpoint", d.key, value,
                       quality, age, unwired ? "" : r.name, v.forced ? "true" : "false");
    if (d.hmi != 0) out += ", \"hmi\": true";  // an HMI variable's channel (docs/st.md)
    if (output) {
      const auto p = static_cast<config::OnBad>(d.on_bad);
      out += fmt::format(", \"sent_by_a_driver\": {}, \"on_bad\": \"{}\"", unsent ? "false" : "true",
                         config::on_bad_name(p));
      if (p == config::OnBad::kSafe) out += fmt::format(", \"safe_value\": {}", d.safe_value);
    }
    out += "}";
    first = false;
  }
  out += first ? "]\n}\n" : "\n  ]\n}\n";
  return with_forced_json(img, with_links_json(img, out));
}

std::string stats_json(const io::ProcessImage& img) {
  const auto views = read_task_stats(img);
  return with_forced_json(img, with_links_json(img, render_json(views, summary_of(img, views))));
}

}  // namespace rtplc::sched
