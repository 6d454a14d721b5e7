// Tests of the `rtplc stats` presentation (spec: runtime.md, "Jitter monitor"): the table
// and JSON against golden strings on fixed inputs, the Liu-Layland and utilisation
// arithmetic, and the histogram file written, read back and folded into the same buckets.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "sched/jitter.h"
#include "sched/stats_histfile.h"
#include "sched/stats_render.h"

namespace rtplc::sched {
namespace {

// Three tasks with fixed, hand-checkable statistics.
std::vector<TaskStatsView> fixed_views() {
  std::vector<TaskStatsView> views(3);
  auto stats = std::make_unique<CycleStats>();

  // loop1: 1000 cycles at 1 ms; wake 3.0..7.5 us with one 45.3 us outlier; exec 0.4..0.8 us.
  for (int i = 0; i < 1000; ++i) {
    stats->record(i == 500 ? 45'300 : 3000 + (i % 10) * 500, 400 + (i % 5) * 100);
  }
  views[0] = {"loop1", 1'000'000, 80, "FIFO", 1, "running", {}, {}};
  take_snapshots(views[0], *stats);

  // slow_loop: 100 cycles at 10 ms, exec around 2.5 ms, two overruns in a row.
  stats->reset();
  for (int i = 0; i < 100; ++i) {
    stats->record(12'000 + i * 10, i == 50 || i == 51 ? 10'400'000 : 2'500'000 + i * 1000);
    if (i == 50 || i == 51) stats->record_overrun(1);
  }
  views[1] = {"slow_loop", 10'000'000, 79, "FIFO", -1, "running", {}, {}};
  take_snapshots(views[1], *stats);

  // t3: SCHED_OTHER, stopped by the watchdog after 3 overruns in a row.
  stats->reset();
  for (int i = 0; i < 10; ++i) {
    stats->record(150'000, i < 7 ? 500'000 : 3'000'000);
    if (i >= 7) stats->record_overrun(0);
  }
  views[2] = {"t3", 2'500'000, 0, "OTHER", -1, "stopped (watchdog)", {}, {}};
  take_snapshots(views[2], *stats);
  return views;
}

constexpr int64_t kUptime = (3600 + 2 * 60 + 5) * int64_t{1'000'000'000};

const char* const kGoldenTable =
    "# rtplc stats: 3 tasks, up 1:02:05, kernel 6.1.0-18-rt-amd64, PREEMPT_RT: yes\n"
    "# wake latency = wake - release, in us; P99/P99.9 from the histogram; Ovr = overruns\n"
    "T: 0 (loop1)     P:80 I:1000  C:   1000 Min:      3 Act:    7 Avg:    5 Max:      45 P99:     7 P99.9:     7 Ovr:   0\n"
    "T: 1 (slow_loop) P:79 I:10000 C:    100 Min:     12 Act:   12 Avg:   12 Max:      12 P99:    12 P99.9:    12 Ovr:   2\n"
    "T: 2 (t3)        P: 0 I:2500  C:     10 Min:    150 Act:  150 Avg:  150 Max:     150 P99:   150 P99.9:   150 Ovr:   3\n"
    "# exec time = end - wake, in us; U = avg exec / period; Skip = releases skipped; Run = overruns in a row now/longest\n"
    "E: 0 (loop1)     Avg:    0.6 Max:    0.8 P99:    0.8 P99.9:    0.8 U:  0.06% Skip:   0 Run:0/0 FIFO  cpu:1   running\n"
    "E: 1 (slow_loop) Avg: 2706.5 Max: 10400.0 P99: 10400.0 P99.9: 10400.0 U: 27.06% Skip:   2 Run:0/2 FIFO  cpu:any running\n"
    "E: 2 (t3)        Avg: 1250.0 Max: 3000.0 P99: 3000.0 P99.9: 3000.0 U: 50.00% Skip:   0 Run:3/3 OTHER cpu:any stopped (watchdog)\n"
    "# utilisation 77.12% avg, 224.08% at max exec; Liu-Layland bound 78.0% (3 tasks): average within, max exec not\n";

const char* const kGoldenJson =
    "{\n"
    "  \"format\": 1,\n"
    "  \"runtime\": {\"uptime_ns\": 3725000000000, \"rt_kernel\": true, \"kernel\": \"6.1.0-18-rt-amd64\", \"tasks\": 3, \"liu_layland_bound\": 0.779763, \"utilisation\": 0.771249, \"utilisation_worst\": 2.240800, \"note\": \"a \\\"quoted\\\" note\"},\n"
    "  \"tasks\": [\n"
    "    {\"index\": 0, \"name\": \"loop1\", \"period_ns\": 1000000, \"priority\": 80, \"policy\": \"FIFO\", \"cpu\": 1, \"state\": \"running\",\n"
    "     \"cycles\": 1000, \"overruns\": 0, \"skipped_releases\": 0, \"consecutive_overruns\": 0, \"max_consecutive_overruns\": 0, \"utilisation\": 0.000600,\n"
    "     \"wake_ns\": {\"min\": 3000, \"avg\": 5292, \"max\": 45300, \"last\": 7500, \"p50\": 5631, \"p90\": 7679, \"p99\": 7679, \"p99_9\": 7679},\n"
    "     \"exec_ns\": {\"min\": 400, \"avg\": 600, \"max\": 800, \"last\": 800, \"p50\": 607, \"p90\": 800, \"p99\": 800, \"p99_9\": 800}},\n"
    "    {\"index\": 1, \"name\": \"slow_loop\", \"period_ns\": 10000000, \"priority\": 79, \"policy\": \"FIFO\", \"cpu\": -1, \"state\": \"running\",\n"
    "     \"cycles\": 100, \"overruns\": 2, \"skipped_releases\": 2, \"consecutive_overruns\": 0, \"max_consecutive_overruns\": 2, \"utilisation\": 0.270649,\n"
    "     \"wake_ns\": {\"min\": 12000, \"avg\": 12495, \"max\": 12990, \"last\": 12990, \"p50\": 12799, \"p90\": 12990, \"p99\": 12990, \"p99_9\": 12990},\n"
    "     \"exec_ns\": {\"min\": 2500000, \"avg\": 2706490, \"max\": 10400000, \"last\": 2599000, \"p50\": 2621439, \"p90\": 2621439, \"p99\": 10400000, \"p99_9\": 10400000}},\n"
    "    {\"index\": 2, \"name\": \"t3\", \"period_ns\": 2500000, \"priority\": 0, \"policy\": \"OTHER\", \"cpu\": -1, \"state\": \"stopped (watchdog)\",\n"
    "     \"cycles\": 10, \"overruns\": 3, \"skipped_releases\": 0, \"consecutive_overruns\": 3, \"max_consecutive_overruns\": 3, \"utilisation\": 0.500000,\n"
    "     \"wake_ns\": {\"min\": 150000, \"avg\": 150000, \"max\": 150000, \"last\": 150000, \"p50\": 150000, \"p90\": 150000, \"p99\": 150000, \"p99_9\": 150000},\n"
    "     \"exec_ns\": {\"min\": 500000, \"avg\": 1250000, \"max\": 3000000, \"last\": 3000000, \"p50\": 507903, \"p90\": 3000000, \"p99\": 3000000, \"p99_9\": 3000000}}\n"
    "  ]\n"
    "}\n";

TEST(StatsRender, table_matches_the_golden_text) {
  const auto views = fixed_views();
  const auto summary = summarise(views, kUptime, true, "6.1.0-18-rt-amd64");
  EXPECT_EQ(render_table(views, summary), kGoldenTable);
}

TEST(StatsRender, table_lines_stay_within_120_columns_for_12_character_names) {
  // Only exec times of 10 ms and more, and a state other than "running" (the last field),
  // may push a line past column 120.
  auto views = fixed_views();
  views[1].name = "twelve_chars";
  views[2].name = "twelve_char2";
  views[2].state = "running";
  for (auto* t : {&views[1].exec.max_ns, &views[1].exec.p99_ns, &views[1].exec.p999_ns}) *t = 9'999'000;
  const std::string t = render_table(views, summarise(views, kUptime, false));
  size_t start = 0;
  while (start < t.size()) {
    const size_t nl = t.find('\n', start);
    const std::string line = t.substr(start, nl - start);
    EXPECT_LE(line.size(), 120u) << line;
    start = nl + 1;
  }
}

TEST(StatsRender, t_lines_split_into_cyclictest_fields) {
  const auto views = fixed_views();
  const std::string t = render_table(views, summarise(views, kUptime, true));
  const size_t at = t.find("T: 1 ");
  ASSERT_NE(at, std::string::npos);
  const std::string line = t.substr(at, t.find('\n', at) - at);
  // What scripts written for cyclictest do: split on blanks, read fields by position.
  std::vector<std::string> f;
  for (size_t i = 0; i < line.size();) {
    const size_t j = line.find(' ', i);
    const std::string w = line.substr(i, j == std::string::npos ? std::string::npos : j - i);
    if (!w.empty()) f.push_back(w);
    if (j == std::string::npos) break;
    i = j + 1;
  }
  ASSERT_GE(f.size(), 15u);
  EXPECT_EQ(f[0], "T:");
  EXPECT_EQ(f[2], "(slow_loop)");
  EXPECT_EQ(f[3], "P:79");
  EXPECT_EQ(f[4], "I:10000");
  EXPECT_EQ(f[5], "C:");
  EXPECT_EQ(f[6], "100");
  EXPECT_EQ(f[7], "Min:");
  EXPECT_EQ(f[8], "12");
  EXPECT_EQ(f[13], "Max:");
  EXPECT_EQ(f[14], "12");
}

TEST(StatsRender, empty_task_list_says_so) {
  const std::string t = render_table({}, summarise({}, 0, false));
  EXPECT_EQ(t, "# rtplc stats: 0 tasks, up 0:00:00, PREEMPT_RT: no\n# no tasks\n");
  EXPECT_EQ(render_json({}, summarise({}, 0, false)),
            "{\n  \"format\": 1,\n  \"runtime\": {\"uptime_ns\": 0, \"rt_kernel\": false, "
            "\"kernel\": \"\", \"tasks\": 0, \"liu_layland_bound\": 0.000000, \"utilisation\": "
            "0.000000, \"utilisation_worst\": 0.000000, \"note\": \"\"},\n  \"tasks\": []\n}\n");
}

TEST(StatsRender, json_matches_the_golden_text) {
  const auto views = fixed_views();
  const auto summary = summarise(views, kUptime, true, "6.1.0-18-rt-amd64", "a \"quoted\" note");
  EXPECT_EQ(render_json(views, summary), kGoldenJson);
}

TEST(StatsRender, liu_layland_bound_known_values) {
  EXPECT_DOUBLE_EQ(liu_layland_bound(0), 0.0);
  EXPECT_DOUBLE_EQ(liu_layland_bound(1), 1.0);
  EXPECT_NEAR(liu_layland_bound(2), 0.828427, 1e-6);
  EXPECT_NEAR(liu_layland_bound(3), 0.779763, 1e-6);
  EXPECT_NEAR(liu_layland_bound(16), 0.708381, 1e-6);
  EXPECT_NEAR(liu_layland_bound(1'000'000), std::log(2.0), 1e-6);
}

TEST(StatsRender, utilisation_sums_avg_and_max_exec_over_period) {
  std::vector<TaskStatsView> v(3);
  v[0].period_ns = 1'000'000;
  v[0].exec.count = 10;
  v[0].exec.avg_ns = 100'000;  // 0.1
  v[0].exec.max_ns = 250'000;  // 0.25
  v[1].period_ns = 4'000'000;
  v[1].exec.count = 10;
  v[1].exec.avg_ns = 1'000'000;  // 0.25
  v[1].exec.max_ns = 2'000'000;  // 0.5
  v[2].period_ns = 0;            // no period, no share
  v[2].exec.count = 10;
  v[2].exec.avg_ns = 5;
  EXPECT_DOUBLE_EQ(utilisation(v), 0.35);
  EXPECT_DOUBLE_EQ(worst_case_utilisation(v), 0.75);
}

// --- histogram file -----------------------------------------------------------------------

void expect_same_buckets(const HistSection& section, size_t task, const StatsSnapshot& s) {
  std::array<uint64_t, LatencyHistogram::kBuckets> back{};
  to_buckets(section, task, back);
  for (uint32_t b = 0; b < LatencyHistogram::kBuckets; ++b) {
    ASSERT_EQ(back[b], s.buckets[b]) << "task " << task << " bucket " << b;
  }
}

TEST(HistFile, written_file_reads_back_into_the_same_buckets) {
  const auto views = fixed_views();
  const std::string path = ::testing::TempDir() + "jitter_hist_" + std::to_string(getpid());
  ASSERT_TRUE(write_hist_file(path, views).ok());
  const auto file = read_hist_file(path);
  std::remove(path.c_str());
  ASSERT_TRUE(file.ok()) << file.error();
  EXPECT_EQ(file->format, 1);
  EXPECT_EQ(file->tasks, (std::vector<std::string>{"loop1", "slow_loop", "t3"}));
  ASSERT_EQ(file->sections.size(), 2u);
  EXPECT_EQ(file->sections[0].name, "wake latency");
  EXPECT_EQ(file->sections[1].name, "exec time");
  for (size_t t = 0; t < views.size(); ++t) {
    expect_same_buckets(file->sections[0], t, views[t].wake);
    expect_same_buckets(file->sections[1], t, views[t].exec);
  }
  const auto* max = file->sections[0].find("Max Latencies");
  ASSERT_NE(max, nullptr);
  EXPECT_EQ(*max, (std::vector<std::string>{"00045.300", "00012.990", "00150.000"}));
  const auto* total = file->sections[1].find("Total");
  ASSERT_NE(total, nullptr);
  EXPECT_EQ((*total)[1], "000000100");
  ASSERT_NE(file->sections[1].find("P99 Exec Times"), nullptr);
  EXPECT_EQ(file->sections[1].find("Overruns"), nullptr);  // only in the wake section
}

TEST(HistFile, rows_are_contiguous_with_an_empty_row_on_either_side) {
  std::vector<TaskStatsView> v(1);
  v[0].name = "a";
  v[0].wake.buckets[LatencyHistogram::bucket_of(3000)] = 2;
  v[0].wake.buckets[LatencyHistogram::bucket_of(4000)] = 1;
  const auto file = parse_hist(render_hist(v));
  ASSERT_TRUE(file.ok()) << file.error();
  const HistSection& s = file->sections[0];
  const uint32_t first = LatencyHistogram::bucket_of(3000) - 1;
  const uint32_t last = LatencyHistogram::bucket_of(4000) + 1;
  ASSERT_EQ(s.lower_ns.size(), last - first + 1);
  for (size_t r = 0; r < s.lower_ns.size(); ++r) {
    EXPECT_EQ(s.lower_ns[r], LatencyHistogram::bucket_lower(first + static_cast<uint32_t>(r)));
  }
  EXPECT_EQ(s.counts[0][0], 0u);
  EXPECT_EQ(s.counts[0][1], 2u);
  EXPECT_EQ(s.counts[0].back(), 0u);
  EXPECT_TRUE(file->sections[1].lower_ns.empty());  // no exec samples, no rows
}

TEST(HistFile, a_sample_at_zero_gets_no_row_below_it) {
  std::vector<TaskStatsView> v(1);
  v[0].exec.buckets[0] = 5;
  const auto file = parse_hist(render_hist(v));
  ASSERT_TRUE(file.ok()) << file.error();
  EXPECT_EQ(file->sections[1].lower_ns, (std::vector<int64_t>{0, 1}));
  EXPECT_EQ(file->sections[1].counts[0], (std::vector<uint64_t>{5, 0}));
  EXPECT_EQ(file->tasks, (std::vector<std::string>{"task0"}));
}

TEST(HistFile, golden_text_of_a_tiny_histogram) {
  std::vector<TaskStatsView> v(2);
  v[0].name = "fast";
  v[0].period_ns = 500'000;
  v[0].wake.count = 3;
  v[0].wake.min_ns = 20;
  v[0].wake.avg_ns = 20;
  v[0].wake.max_ns = 21;
  v[0].wake.buckets[20] = 2;
  v[0].wake.buckets[21] = 1;
  v[1].name = "has space";
  v[1].period_ns = 1'000'500;
  v[1].wake.buckets[22] = 4;
  fill_percentiles(v[0].wake);
  EXPECT_EQ(render_hist(v),
            "# rtplc jitter histogram, format 1\n"
            "# Rows: lower bound of a bucket in us, then one count per task; a bucket ends where the next row begins.\n"
            "# Buckets: 16 per power of two of nanoseconds (width <= 1/16 of the bound). Sections, two blank lines apart: wake latency (gnuplot index 0), exec time (index 1).\n"
            "# Tasks: fast has_space\n"
            "# Periods (us): 500.000 1000.500\n"
            "# Section: wake latency\n"
            "000000.019\t000000\t000000\n"
            "000000.020\t000002\t000000\n"
            "000000.021\t000001\t000000\n"
            "000000.022\t000000\t000004\n"
            "000000.023\t000000\t000000\n"
            "# Total: 000000003 000000000\n"
            "# Min Latencies: 00000.020 00000.000\n"
            "# Avg Latencies: 00000.020 00000.000\n"
            "# Max Latencies: 00000.021 00000.000\n"
            "# P50 Latencies: 00000.020 00000.000\n"
            "# P90 Latencies: 00000.021 00000.000\n"
            "# P99 Latencies: 00000.021 00000.000\n"
            "# P99.9 Latencies: 00000.021 00000.000\n"
            "# Overruns: 00000 00000\n"
            "# Skipped Releases: 00000 00000\n"
            "\n"
            "\n"
            "# Section: exec time\n"
            "# Total: 000000000 000000000\n"
            "# Min Exec Times: 00000.000 00000.000\n"
            "# Avg Exec Times: 00000.000 00000.000\n"
            "# Max Exec Times: 00000.000 00000.000\n"
            "# P50 Exec Times: 00000.000 00000.000\n"
            "# P90 Exec Times: 00000.000 00000.000\n"
            "# P99 Exec Times: 00000.000 00000.000\n"
            "# P99.9 Exec Times: 00000.000 00000.000\n");
}

TEST(HistFile, reads_a_cyclictest_histogram_file) {
  const char* text =
      "# Histogram\n"
      "000000 000000\t000000\n"
      "000001 000003\t000000\n"
      "000002 000005\t000002\n"
      "# Total: 000000008 000000002\n"
      "# Min Latencies: 00001 00002\n"
      "# Max Latencies: 00002 00002\n"
      "# Histogram Overflows: 00000 00000\n";
  const auto file = parse_hist(text);
  ASSERT_TRUE(file.ok()) << file.error();
  EXPECT_EQ(file->format, 0);
  ASSERT_EQ(file->sections.size(), 1u);
  const HistSection& s = file->sections[0];
  EXPECT_EQ(s.lower_ns, (std::vector<int64_t>{0, 1000, 2000}));
  EXPECT_EQ(s.counts[1], (std::vector<uint64_t>{0, 0, 2}));
  ASSERT_NE(s.find("Max Latencies"), nullptr);
  EXPECT_EQ((*s.find("Max Latencies"))[0], "00002");
}

TEST(HistFile, malformed_files_are_errors_that_name_the_line) {
  struct Case {
    const char* text;
    const char* error;
  };
  const Case cases[] = {
      {"", "no histogram in the file"},
      {"# only a comment\n", "no histogram in the file"},
      {"1.5 3\nabc 4\n", "line 2: 'abc' is not a latency in us"},
      {"1 3 4\n2 5\n", "line 2: 1 counts, the rows above have 2"},
      {"1 3\n2 x\n", "line 2: 'x' is not a count"},
      {"2 3\n1 3\n", "line 2: bounds must increase (1 after 2.000 us)"},
      {"-1 3\n", "line 1: '-1' is not a latency in us"},
      {"5\n", "line 1: a row without counts"},
      {"# Tasks: a b\n1 3\n", "section '' has 1 count columns for 2 tasks"},
  };
  for (const auto& c : cases) {
    const auto r = parse_hist(c.text);
    ASSERT_FALSE(r.ok()) << c.text;
    EXPECT_EQ(r.error(), c.error) << c.text;
  }
}

TEST(HistFile, unwritable_and_missing_paths_are_errors_with_the_path) {
  const auto w = write_hist_file("/nonexistent-dir/h.txt", {});
  ASSERT_FALSE(w.ok());
  EXPECT_EQ(w.error().rfind("/nonexistent-dir/h.txt: cannot write:", 0), 0u) << w.error();
  const auto r = read_hist_file("/nonexistent-dir/h.txt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().rfind("/nonexistent-dir/h.txt: cannot read:", 0), 0u) << r.error();
}

}  // namespace
}  // namespace rtplc::sched
