// Reading every task's timing statistics out of a process image — the runtime's
// own mapping or a tool's read-only one (`rtplc stats`, `rtplc monitor`).
#pragma once

#include <string>
#include <vector>

#include "io/process_image.h"
#include "sched/stats_render.h"

namespace rtplc::sched {

std::vector<TaskStatsView> read_task_stats(const io::ProcessImage& image);

// Uptime of the runtime that owns the image, from its start time.
int64_t runtime_uptime_ns(const io::ProcessImage& image);

// The summary under the stats table for this box and image: uptime, RT kernel,
// kernel release, and a note when tasks could not get SCHED_FIFO.
RuntimeSummary summary_of(const io::ProcessImage& image, const std::vector<TaskStatsView>& views);

// "runtime plant is not running (died at 2026-12-01 16:40:12: process 1234 is
// gone)": what every tool says of an image whose runtime is dead.
std::string not_running_text(const std::string& name, const io::Liveness& l);

// The runtimes this user can see on this machine: every process image
// (/dev/shm/rtplc-NAME) that attaches, alive or left behind by a dead one.
struct RuntimeSeen {
  std::string name;
  bool alive = false;
  std::string socket;  // its control socket, as its image says
  std::string why;     // when dead: since when and why
};
std::vector<RuntimeSeen> runtimes_on_this_machine();
// "; running here: a, b (give --name)" or "; no runtime is running here".
std::string running_runtimes_hint();

// One link's status as plain values, whatever the driver's kind.
struct LinkSnapshot {
  std::string name, driver, kind, peer, state, quality;
  unsigned rtt_p50_us = 0, rtt_p99_us = 0, rtt_max_us = 0;
  unsigned long long polls_completed = 0, polls_missed = 0, polls_offline = 0;
  unsigned long long connects = 0, reconnects = 0, timeouts = 0, errors = 0;
  unsigned long long writes_acked = 0, writes_failed = 0, writes_pending = 0, writes_rejected = 0;
  std::vector<unsigned long long> latency;  // io::kLinkLatencyBuckets counts
  // A link that runs on a fieldbus plan: the plan and, per traffic class, the
  // measured delays beside the plan's bounds (io/drivers/planned_link.h).
  std::string plan;  // "" = not planned
  struct TrafficClass {
    std::string name;
    unsigned long long count = 0, missed = 0;
    long long delay_p99_ns = 0, delay_max_ns = 0, delay_bound_ns = 0;  // bound 0: none claimed
    long long packet_max_ns = 0, packet_bound_ns = 0;
  };
  std::vector<TrafficClass> classes;
  std::vector<std::pair<std::string, unsigned long long>> gauges;  // the kind's own figures, by name
  std::string last_error;       // "" when none
  double last_error_age_s = 0;  // how long ago
};
LinkSnapshot link_snapshot(const io::LinkStatus& ls);

// ", births 1, seq 17, bdSeq 3": the kind's own figures ("" when it has none).
std::string gauges_text(const LinkSnapshot& s);
// "plc f01 (s7 driver plc, 10.0.0.11:102): up, rtt p50/p99 ..." for `status`.
std::string link_status_line(const LinkSnapshot& s);
// "    periodic: 812 sent, delay p99/max 41/97 us (bound 1486 us), 0 missed,
// packet max 270 us (bound 270 us)": one line per class of a planned link; "" when not planned.
std::string render_link_classes(const LinkSnapshot& s);
// The "L:" lines under the stats table (like the tasks' "T:" lines); "" without links.
std::string render_links_table(const io::ProcessImage& image);
// The stats JSON object with a "links" array added.
std::string with_links_json(const io::ProcessImage& image, const std::string& json);

// The channels an operator forced, read from the image's force table.
struct ForcedChannel {
  std::string label;
  std::string dir;  // "input", "output"
  double value = 0;
};
std::vector<ForcedChannel> forced_channels(const io::ProcessImage& image);
// "FORCED: 2 channels: ProcVal (input) = 12, Valve (output) = 0\n" under the
// stats table; "" when nothing is forced.
std::string render_forced(const io::ProcessImage& image);
// The stats JSON object with a "forced" array added.
std::string with_forced_json(const io::ProcessImage& image, const std::string& json);

// The status a viewer is shown for channel `c` read as `v`: "stale" for every
// value of a runtime that is not running, "bad" for an input no driver
// provides or a reading that was not consistent, else the value's own
// (good, bad, uncertain, forced; common/quality.h).
const char* shown_quality(const io::ProcessImage& img, uint32_t c, const io::ChannelValue& v, const io::Liveness& live);
// Whether a `--filter` keeps a channel: its label or its address contains it.
bool channel_shown(const io::ChannelDesc& d, const std::string& filter);
// `rtplc monitor --json` and the operator API's `values`: the same facts as the
// monitor's table (tasks, channels with value, quality, age, forced and an
// output's on_bad policy, links, forced), one JSON object. Labels and keys are
// letters, digits, '_', '-', '.', '/': nothing to escape.
std::string monitor_json(const io::ProcessImage& img, const io::Liveness& live, const std::string& filter);
// `rtplc stats --json` and the operator API's `stats`: the tasks' timing
// statistics, links and forced channels as one JSON object.
std::string stats_json(const io::ProcessImage& img);

}  // namespace rtplc::sched
