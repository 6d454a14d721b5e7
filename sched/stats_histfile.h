// The jitter histogram file of `rtplc stats --hist FILE`, in the spirit of cyclictest's
// --histfile, and a reader for it (spec: runtime.md, "Jitter monitor": "a histogram file a
// plot script turns into a PNG"; scripts/plot-jitter draws it).
//
// Format 1 (docs/jitter.md has an example):
//   - '#' lines are comments: a header naming the tasks and periods, then per section a
//     "# Section: <name>" line before the rows and cyclictest-style summary lines after
//     them ("# Total:", "# Min Latencies:", "# Max Latencies:", ...; values in us).
//   - Two sections, wake latency then exec time, separated by two blank lines: gnuplot
//     addresses them as `index 0` and `index 1`.
//   - A data row is the lower bound of one histogram bucket in microseconds (3 decimals, so
//     exact to the nanosecond), then one count per task, tab-separated. A row's bucket ends
//     where the next row's begins; rows run without gaps from the lowest to the highest
//     non-empty bucket of any task, with one row of zeros on either side.
// The reader also takes cyclictest's own histogram files (no sections, one row per
// microsecond), so both can be compared with the same tools.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/result.h"
#include "sched/stats_render.h"

namespace rtplc::sched {

// The file's text for `views` (what write_hist_file writes).
std::string render_hist(const std::vector<TaskStatsView>& views);

// Writes render_hist(views) to `path`, replacing it.
Result<void> write_hist_file(const std::string& path, const std::vector<TaskStatsView>& views);

// A histogram file read back.
struct HistSection {
  std::string name;               // "wake latency", "exec time"; cyclictest's has none
  std::vector<int64_t> lower_ns;  // first column, one per row
  std::vector<std::vector<uint64_t>> counts;  // [task][row]
  // Summary comment lines, "Max Latencies" -> the values in the line, one per task.
  std::vector<std::pair<std::string, std::vector<std::string>>> summary;

  // Values of a summary line by key; empty if absent.
  const std::vector<std::string>* find(std::string_view key) const;
};

struct HistFile {
  int format = 0;                  // 1 for ours, 0 for a file without our header (cyclictest)
  std::vector<std::string> tasks;  // from "# Tasks:"; empty for cyclictest files
  std::vector<HistSection> sections;
};

// Parses a histogram file's text; errors name the line ("line 12: ...").
Result<HistFile> parse_hist(std::string_view text);
// Reads and parses `path`; errors start with the path.
Result<HistFile> read_hist_file(const std::string& path);

// Folds one task's column of a section back into histogram buckets (each row's count goes
// to the bucket holding its lower bound). Exact for files we wrote; for cyclictest's 1-us
// rows, each row lands in the bucket of its lower bound.
void to_buckets(const HistSection& section, size_t task,
                std::array<uint64_t, LatencyHistogram::kBuckets>& buckets);

}  // namespace rtplc::sched
