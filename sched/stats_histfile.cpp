// Writes and reads the jitter histogram file (spec: runtime.md, "Jitter monitor"). The
// format is described in sched/stats_histfile.h and, for users, in docs/jitter.md.
#include "sched/stats_histfile.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <optional>

namespace rtplc::sched {

namespace {

constexpr int kFormat = 1;
constexpr std::string_view kTitle = "rtplc jitter histogram, format ";

// Microseconds with three decimals from integer nanoseconds: exact, no floating point.
// Zero-padded like cyclictest's columns so the rows line up and sort as text.
std::string us_text(int64_t ns, int width = 6) {
  const int64_t v = std::max<int64_t>(ns, 0);
  return fmt::format("{:0{}}.{:03}", v / 1000, width, v % 1000);
}

std::string task_label(const TaskStatsView& v, size_t i) {
  // The "# Tasks:" line is split on blanks, so a name must be one word.
  if (v.name.empty()) return fmt::format("task{}", i);
  std::string s = v.name;
  std::replace_if(s.begin(), s.end(), [](char c) { return c == ' ' || c == '\t'; }, '_');
  return s;
}

void render_section(std::string& out, const std::vector<TaskStatsView>& views, Series series) {
  const bool wake = series == Series::kWake;
  auto snap = [wake](const TaskStatsView& v) -> const StatsSnapshot& { return wake ? v.wake : v.exec; };
  out += wake ? "# Section: wake latency\n" : "# Section: exec time\n";

  // Rows from the lowest to the highest bucket any task used, without gaps, so each row's
  // bucket ends at the next row's bound; an empty row on either side gives the first bucket
  // its rise and the last one its end, so a plotted curve starts and ends on the axis.
  uint32_t first = LatencyHistogram::kBuckets;
  uint32_t last = 0;
  for (const auto& v : views) {
    const auto& b = snap(v).buckets;
    for (uint32_t i = 0; i < LatencyHistogram::kBuckets; ++i) {
      if (b[i] == 0) continue;
      first = std::min(first, i);
      last = std::max(last, i);
    }
  }
  if (first < LatencyHistogram::kBuckets) {
    const uint32_t begin = first == 0 ? 0 : first - 1;
    const uint32_t end = std::min(last + 1, LatencyHistogram::kBuckets - 1);
    for (uint32_t i = begin; i <= end; ++i) {
      out += us_text(LatencyHistogram::bucket_lower(i));
      for (const auto& v : views) {
        out += fmt::format("\t{:06}", i >= first && i <= last ? snap(v).buckets[i] : uint64_t{0});
      }
      out += '\n';
    }
  }

  // The summary, cyclictest's key names for the wake section so existing habits
  // (grep "Max Latencies") keep working.
  const char* noun = wake ? "Latencies" : "Exec Times";
  auto line = [&](std::string key, auto value_of) {
    out += "# " + key + ":";
    for (const auto& v : views) out += " " + value_of(snap(v));
    out += '\n';
  };
  line("Total", [](const StatsSnapshot& s) { return fmt::format("{:09}", s.count); });
  line(fmt::format("Min {}", noun), [](const StatsSnapshot& s) { return us_text(s.min_ns, 5); });
  line(fmt::format("Avg {}", noun), [](const StatsSnapshot& s) { return us_text(s.avg_ns, 5); });
  line(fmt::format("Max {}", noun), [](const StatsSnapshot& s) { return us_text(s.max_ns, 5); });
  line(fmt::format("P50 {}", noun), [](const StatsSnapshot& s) { return us_text(s.p50_ns, 5); });
  line(fmt::format("P90 {}", noun), [](const StatsSnapshot& s) { return us_text(s.p90_ns, 5); });
  line(fmt::format("P99 {}", noun), [](const StatsSnapshot& s) { return us_text(s.p99_ns, 5); });
  line(fmt::format("P99.9 {}", noun), [](const StatsSnapshot& s) { return us_text(s.p999_ns, 5); });
  if (wake) {
    line("Overruns", [](const StatsSnapshot& s) { return fmt::format("{:05}", s.overruns); });
    line("Skipped Releases",
         [](const StatsSnapshot& s) { return fmt::format("{:05}", s.skipped_releases); });
  }
}

std::string_view trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string_view> split_blanks(std::string_view s) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    size_t j = i;
    while (j < s.size() && s[j] != ' ' && s[j] != '\t') ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

// "15", "000015.250" -> nanoseconds. Digits beyond the nanosecond are dropped.
std::optional<int64_t> parse_us(std::string_view s) {
  const auto dot = s.find('.');
  const std::string_view whole = s.substr(0, dot);
  const std::string_view frac = dot == std::string_view::npos ? std::string_view{} : s.substr(dot + 1);
  if (whole.empty() && frac.empty()) return std::nullopt;
  int64_t us = 0;
  if (!whole.empty()) {
    auto [p, ec] = std::from_chars(whole.data(), whole.data() + whole.size(), us);
    if (ec != std::errc{} || p != whole.data() + whole.size() || us < 0) return std::nullopt;
  }
  if (us > INT64_MAX / 1000 - 1) return std::nullopt;
  int64_t ns = 0;
  int64_t scale = 100;
  for (char c : frac) {
    if (c < '0' || c > '9') return std::nullopt;
    ns += (c - '0') * scale;
    scale /= 10;
  }
  return us * 1000 + ns;
}

std::optional<uint64_t> parse_count(std::string_view s) {
  uint64_t v = 0;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || p != s.data() + s.size()) return std::nullopt;
  return v;
}

}  // namespace

std::string render_hist(const std::vector<TaskStatsView>& views) {
  std::string out = fmt::format("# {}{}\n", kTitle, kFormat);
  out += "# Rows: lower bound of a bucket in us, then one count per task; a bucket ends where the "
         "next row begins.\n";
  out += "# Buckets: 16 per power of two of nanoseconds (width <= 1/16 of the bound). Sections, "
         "two blank lines apart: wake latency (gnuplot index 0), exec time (index 1).\n";
  out += "# Tasks:";
  for (size_t i = 0; i < views.size(); ++i) out += " " + task_label(views[i], i);
  out += "\n# Periods (us):";
  for (const auto& v : views) out += " " + us_text(v.period_ns, 1);
  out += '\n';
  render_section(out, views, Series::kWake);
  out += "\n\n";
  render_section(out, views, Series::kExec);
  return out;
}

Result<void> write_hist_file(const std::string& path, const std::vector<TaskStatsView>& views) {
  const std::string text = render_hist(views);
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return make_error(fmt::format("{}: cannot write: {}", path, std::strerror(errno)));
  const size_t written = std::fwrite(text.data(), 1, text.size(), f);
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (written != text.size()) {
    return make_error(fmt::format("{}: write failed: {}", path, std::strerror(write_errno)));
  }
  if (!closed) return make_error(fmt::format("{}: write failed: {}", path, std::strerror(errno)));
  return {};
}

const std::vector<std::string>* HistSection::find(std::string_view key) const {
  for (const auto& [k, values] : summary) {
    if (k == key) return &values;
  }
  return nullptr;
}

Result<HistFile> parse_hist(std::string_view text) {
  HistFile file;
  HistSection* current = nullptr;  // the section rows and summary lines go to
  bool closed = true;              // two blank lines ended the current section
  std::string pending_name;        // from a "# Section:" line before the section's rows
  int blank_run = 0;
  size_t line_no = 0;

  auto open_section = [&]() {
    file.sections.emplace_back();
    current = &file.sections.back();
    current->name = std::move(pending_name);
    pending_name.clear();
    closed = false;
  };

  size_t pos = 0;
  while (pos <= text.size()) {
    const size_t nl = text.find('\n', pos);
    const std::string_view raw = text.substr(pos, nl == std::string_view::npos ? text.size() - pos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
    ++line_no;
    const std::string_view line = trim(raw);

    if (line.empty()) {
      if (++blank_run >= 2) closed = true;
      continue;
    }
    blank_run = 0;

    if (line.front() == '#') {
      const std::string_view body = trim(line.substr(1));
      if (body.starts_with(kTitle)) {
        const std::string_view n = body.substr(kTitle.size());
        std::from_chars(n.data(), n.data() + n.size(), file.format);
        continue;
      }
      if (body.starts_with("Tasks:")) {
        for (auto t : split_blanks(body.substr(6))) file.tasks.emplace_back(t);
        continue;
      }
      if (body.starts_with("Section:")) {
        pending_name = std::string(trim(body.substr(8)));
        open_section();
        continue;
      }
      const auto colon = body.find(':');
      if (current != nullptr && !closed && colon != std::string_view::npos) {
        std::vector<std::string> values;
        for (auto v : split_blanks(body.substr(colon + 1))) values.emplace_back(v);
        current->summary.emplace_back(std::string(body.substr(0, colon)), std::move(values));
      }
      continue;  // any other comment: header prose, cyclictest's "# Histogram"
    }

    // A data row.
    const auto fields = split_blanks(line);
    const auto bound = parse_us(fields[0]);
    if (!bound) {
      return make_error(fmt::format("line {}: '{}' is not a latency in us", line_no, fields[0]));
    }
    if (current == nullptr || closed) open_section();
    const size_t columns = fields.size() - 1;
    if (columns == 0) return make_error(fmt::format("line {}: a row without counts", line_no));
    if (current->lower_ns.empty()) {
      current->counts.assign(columns, {});
    } else if (columns != current->counts.size()) {
      return make_error(fmt::format("line {}: {} counts, the rows above have {}", line_no, columns,
                                    current->counts.size()));
    } else if (*bound <= current->lower_ns.back()) {
      return make_error(fmt::format("line {}: bounds must increase ({} after {} us)", line_no,
                                    fields[0], us_text(current->lower_ns.back(), 1)));
    }
    current->lower_ns.push_back(*bound);
    for (size_t c = 0; c < columns; ++c) {
      const auto n = parse_count(fields[c + 1]);
      if (!n) return make_error(fmt::format("line {}: '{}' is not a count", line_no, fields[c + 1]));
      current->counts[c].push_back(*n);
    }
  }

  if (file.sections.empty()) return make_error("no histogram in the file");
  if (!file.tasks.empty()) {
    for (const auto& s : file.sections) {
      if (!s.counts.empty() && s.counts.size() != file.tasks.size()) {
        return make_error(fmt::format("section '{}' has {} count columns for {} tasks", s.name,
                                      s.counts.size(), file.tasks.size()));
      }
    }
  }
  return file;
}

Result<HistFile> read_hist_file(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "r");
  if (f == nullptr) return make_error(fmt::format("{}: cannot read: {}", path, std::strerror(errno)));
  std::string text;
  char buf[8192];
  size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return make_error(fmt::format("{}: read failed", path));
  auto parsed = parse_hist(text);
  if (!parsed) return make_error(fmt::format("{}: {}", path, parsed.error()));
  return parsed;
}

void to_buckets(const HistSection& section, size_t task,
                std::array<uint64_t, LatencyHistogram::kBuckets>& buckets) {
  buckets.fill(0);
  if (task >= section.counts.size()) return;
  for (size_t r = 0; r < section.lower_ns.size(); ++r) {
    buckets[LatencyHistogram::bucket_of(section.lower_ns[r])] += section.counts[task][r];
  }
}

}  // namespace rtplc::sched
