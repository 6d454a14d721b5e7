// `rtplc trace LABEL...`: record channels of the running runtime on every cycle
// of the task that samples them, to a CSV in `rtplc sim`'s layout (and a PNG).
// The runtime selects the channels for that task's trace ring in the process
// image (io/trace_ring.h); this tool drains the ring through its read-only
// mapping, renews the selection's lease and ends it on the way out. A record
// it did not read in time is counted and marked in the CSV, never skipped
// silently. docs/runtime.md, "Tracing a running runtime".
#include <CLI/CLI.hpp>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <deque>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>
#include <thread>

#include "app/arguments.h"
#include "app/commands.h"
#include "common/files.h"
#include "io/process_image.h"
#include "io/trace_ring.h"
#include "kernel_rt/clock.h"
#include "sched/control.h"
#include "sched/stats_source.h"
#include "sim/sim_loop.h"

namespace rtplc::app {
namespace {

struct TraceArgs {
  std::vector<std::string> labels;
  double duration = 10;
  std::string csv;
  std::string plot;
  std::string trigger;
  double pre_trigger = -1;  // -1: 10% of --duration when there is a trigger
  std::string name = "rtplc";
  std::string socket;
  bool cycles = false;
  bool quiet = false;
};

struct Trigger {
  std::string label;
  char op = '>';
  double value = 0;
  size_t column = 0;  // in the selection
  bool holds(double v) const { return op == '>' ? v > value : v < value; }
};

// What the runtime answered to the trace request.
struct Selection {
  std::string token;
  std::string task;
  uint32_t task_index = 0;
  int64_t period_ns = 0;
  uint64_t first_record = 0;
  std::vector<std::string> labels;
  std::vector<bool> is_output;
};

std::atomic<bool> g_interrupted{false};
extern "C" void on_signal(int) { g_interrupted.store(true); }

[[noreturn]] void fail_trace(const std::string& msg, int code = kExitFailure) {
  fail("rtplc trace: " + msg, code);
}

Trigger parse_trigger(const std::string& text) {
  Trigger t;
  const size_t at = text.find_first_of("<>");
  if (at == std::string::npos || at == 0 || at + 1 >= text.size()) {
    fail_trace("--trigger wants LABEL>VALUE or LABEL<VALUE, e.g. 'Level>80', not '" + text + "'", kExitUsage);
  }
  t.label = text.substr(0, at);
  t.op = text[at];
  const std::string v = text.substr(at + 1);
  char* end = nullptr;
  t.value = std::strtod(v.c_str(), &end);
  if (end == v.c_str() || *end != '\0' || !std::isfinite(t.value)) {
    fail_trace("--trigger '" + text + "': '" + v + "' is not a finite number", kExitUsage);
  }
  return t;
}

// The typed answer of the operator API's `trace` (sched/operator_api.h).
Selection selection_of(const nlohmann::json& r) {
  Selection s;
  s.token = r.value("token", std::string());
  s.task = r.value("task", std::string());
  s.task_index = r.value("task_index", uint32_t{0});
  s.period_ns = r.value("period_ns", int64_t{0});
  s.first_record = r.value("first_record", uint64_t{0});
  if (r.contains("columns") && r["columns"].is_array()) {
    for (const nlohmann::json& c : r["columns"]) {
      s.labels.push_back(c.value("label", std::string()));
      s.is_output.push_back(c.value("dir", std::string()) == "output");
    }
  }
  if (s.token.empty() || s.task.empty() || s.period_ns <= 0 || s.labels.empty()) {
    fail_trace("the runtime's answer to the trace request is not understood:\n" + r.dump(2));
  }
  return s;
}

std::string fmt(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// The recording: rows in the CSV layout of `rtplc sim`, and '#' notes that
// go just before a given row (where samples are missing).
struct Recording {
  std::vector<std::vector<double>> rows;
  std::vector<std::pair<size_t, std::string>> notes;  // (row index, text)
  uint64_t lost_in_window = 0;
  bool have_last = false;
  uint64_t last_record = 0;
  uint64_t last_cycle = 0;
  uint64_t first_cycle = 0;
};

void append_row(Recording& rec, const io::TraceSample& s, int64_t t0, size_t n, bool cycles) {
  if (rec.have_last && s.record != rec.last_record + 1) {
    const uint64_t missing = s.record - rec.last_record - 1;
    rec.lost_in_window += missing;
    rec.notes.emplace_back(rec.rows.size(), "lost " + std::to_string(missing) + " samples: cycles " +
                                                std::to_string(rec.last_cycle + 1) + " to " +
                                                std::to_string(s.cycle - 1) + " (the reader fell behind)");
  } else if (rec.have_last && s.cycle != rec.last_cycle + 1) {
    rec.notes.emplace_back(rec.rows.size(), "cycles " + std::to_string(rec.last_cycle + 1) + " to " +
                                                std::to_string(s.cycle - 1) +
                                                " ran no code (the task was stopped)");
  }
  if (!rec.have_last) rec.first_cycle = s.cycle;
  rec.have_last = true;
  rec.last_record = s.record;
  rec.last_cycle = s.cycle;
  std::vector<double> row;
  row.reserve(n + 2);
  row.push_back(static_cast<double>(s.release_ns - t0) / 1e9);
  if (cycles) row.push_back(static_cast<double>(s.cycle));
  for (size_t k = 0; k < n; ++k) row.push_back(s.values[k]);
  rec.rows.push_back(std::move(row));
}

Result<void> write_recording(const Recording& rec, const std::vector<std::string>& columns,
                             const std::vector<std::string>& summary, const std::string& path) {
  const auto body = [&](const FileSink& sink) {
    if (!sink(io::csv_header_line(columns))) return false;
    size_t note = 0;
    for (size_t r = 0; r < rec.rows.size(); ++r) {
      for (; note < rec.notes.size() && rec.notes[note].first == r; ++note) {
        if (!sink("# " + rec.notes[note].second + "\n")) return false;
      }
      if (!sink(io::csv_row_line(rec.rows[r].data(), rec.rows[r].size()))) return false;
    }
    for (const std::string& s : summary) {
      if (!sink("# " + s + "\n")) return false;
    }
    return true;
  };
  if (path.empty() || path == "-") {
    const bool ok = body([](std::string_view piece) {
      return std::fwrite(piece.data(), 1, piece.size(), stdout) == piece.size();
    }) && std::fflush(stdout) == 0;
    return ok ? Result<void>{} : make_error("error writing the CSV to standard output");
  }
  // Whole or not at all, and no stray PATH.tmp when it fails.
  return write_file_atomically(path, 0644, body);
}

Result<void> plot_recording(const Recording& rec, const Selection& sel, bool cycles, const std::string& png,
                            const std::string& title) {
  io::SimTrace tr;
  tr.columns.push_back("t");
  tr.is_output.push_back(false);
  for (size_t k = 0; k < sel.labels.size(); ++k) {
    tr.columns.push_back(sel.labels[k]);
    tr.is_output.push_back(sel.is_output[k]);
  }
  for (const auto& r : rec.rows) {
    std::vector<double> row;
    row.push_back(r[0]);
    row.insert(row.end(), r.begin() + (cycles ? 2 : 1), r.end());
    tr.rows.push_back(std::move(row));
  }
  char tmpl[] = "/tmp/rtplc-trace-XXXXXX";
  const int fd = mkstemp(tmpl);
  if (fd < 0) return make_error(std::string("cannot create a temporary file: ") + std::strerror(errno));
  close(fd);
  auto w = io::write_csv(tr, tmpl);
  auto p = w ? io::write_plot(tr, tmpl, png, title) : w;
  unlink(tmpl);
  return p;
}

void run_trace(const TraceArgs& a) {
  std::optional<Trigger> trig;
  if (!a.trigger.empty()) trig = parse_trigger(a.trigger);
  if (a.pre_trigger >= 0 && !trig) fail_trace("--pre-trigger needs --trigger", kExitUsage);
  const double pre_s = trig ? (a.pre_trigger >= 0 ? a.pre_trigger : 0.1 * a.duration) : 0;
  if (!a.plot.empty() && std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    fail_trace("--plot needs gnuplot (install the gnuplot-nox package, or scripts/setup-deps)");
  }
  // Before recording: an output that cannot be written fails now, by name.
  if (!a.csv.empty() && a.csv != "-") require_output_path(a.csv, "trace", "--csv");
  if (!a.plot.empty()) require_output_path(a.plot, "trace", "--plot", {a.csv});

  auto img = io::ProcessImage::attach(a.name);
  if (!img) fail_trace(img.error());
  if (const io::Liveness live = img->liveness(); !live.alive) fail_trace(sched::not_running_text(a.name, live));

  std::vector<std::string> labels = a.labels;
  if (trig && std::find(labels.begin(), labels.end(), trig->label) == labels.end()) labels.push_back(trig->label);
  const std::string socket = sched::control_socket_of(a.name, a.socket);
  auto answer = sched::api_request(socket, {{"op", "trace"}, {"args", {{"labels", labels}}}}, "", 10000);
  if (!answer) fail_trace(answer.error());
  if (!answer->value("ok", false)) fail_trace(sched::refusal_message(*answer, "the runtime refused the trace"));
  const Selection sel = selection_of((*answer)["result"]);
  if (trig) {
    trig->column = static_cast<size_t>(std::find(sel.labels.begin(), sel.labels.end(), trig->label) - sel.labels.begin());
  }
  const io::TraceBlock* block = img->trace_block(sel.task_index);
  if (block == nullptr) fail_trace("the runtime's image has no trace ring for task " + sel.task);
  auto end_trace = [&] { (void)sched::control_request(socket, "trace-end " + sel.token, "", 2000); };

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  const size_t n = sel.labels.size();
  const int64_t duration_ns = std::llround(a.duration * 1e9);
  const auto pre_n = static_cast<size_t>(std::ceil(pre_s * 1e9 / static_cast<double>(sel.period_ns)));
  const bool progress = !a.quiet && isatty(STDERR_FILENO) && a.duration >= 2;
  if (!a.quiet) {
    std::fprintf(stderr, "rtplc trace: task %s (period %s s), %zu channel%s, %s s%s\n", sel.task.c_str(),
                 fmt(static_cast<double>(sel.period_ns) / 1e9).c_str(), n, n == 1 ? "" : "s", fmt(a.duration).c_str(),
                 trig ? (", waiting for " + a.trigger + "; Ctrl-C stops").c_str() : "; Ctrl-C stops early");
  }

  io::TraceReader reader(block, sel.first_record, static_cast<uint32_t>(n));
  Recording rec;
  std::vector<io::TraceSample> batch;
  batch.reserve(io::kTraceSlots);
  std::deque<io::TraceSample> before;  // the last pre_n samples while waiting for the trigger
  bool fired = !trig;
  bool started = false;
  int64_t t0 = 0;
  int64_t fired_wall = 0;
  bool done = false;
  std::string ended_why;
  int64_t next_renew = kernel_rt::monotonic_now_ns() + 1000000000;
  while (!done) {
    batch.clear();
    reader.drain(batch);
    for (const io::TraceSample& s : batch) {
      if (!fired) {
        if (!before.empty() && s.record != before.back().record + 1) before.clear();  // not contiguous
        before.push_back(s);
        while (before.size() > pre_n + 1) before.pop_front();
        if (!trig->holds(s.values[trig->column])) continue;
        fired = true;
        fired_wall = kernel_rt::monotonic_now_ns();
        t0 = s.release_ns;
        started = true;
        for (const io::TraceSample& b : before) append_row(rec, b, t0, n, a.cycles);
        before.clear();
        if (!a.quiet) std::fprintf(stderr, "rtplc trace: triggered at cycle %llu\n", static_cast<unsigned long long>(s.cycle));
        continue;
      }
      if (!started) {
        started = true;
        t0 = s.release_ns;
        fired_wall = kernel_rt::monotonic_now_ns();
      }
      if (s.release_ns - t0 >= duration_ns) {
        done = true;
        break;
      }
      append_row(rec, s, t0, n, a.cycles);
    }
    // Ended early: the samples drained just above were the last.
    if (done || !ended_why.empty()) break;
    if (g_interrupted.load()) {
      ended_why = "interrupted";
      continue;
    }
    const int64_t now = kernel_rt::monotonic_now_ns();
    if (now >= next_renew) {
      next_renew = now + 1000000000;
      if (const io::Liveness live = img->liveness(); !live.alive) {
        ended_why = sched::not_running_text(a.name, live);
        continue;
      }
      // api_request fails only when no whole answer came (the socket refuses,
      // the runtime died before or while answering); a live runtime that
      // refuses the renewal answers, with ok false.
      auto k = sched::api_request(socket, {{"op", "trace_keep"}, {"args", {{"token", sel.token}}}}, "", 2000);
      if (!k) {
        ended_why = "the runtime ended the trace: " + k.error();
        // A runtime that just died is told apart from one that stalled: its
        // heartbeat goes stale within 3 s.
        for (int i = 0; i < 40; ++i) {
          if (const io::Liveness live = img->liveness(); !live.alive) {
            ended_why = sched::not_running_text(a.name, live);
            break;
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
        continue;
      }
      if (!k->value("ok", false)) {
        ended_why = "the runtime ended the trace: " + sched::refusal_message(*k, "it refused the renewal");
        continue;
      }
      if (started && now - fired_wall > duration_ns + duration_ns / 2 + 2000000000) {
        ended_why = "task " + sel.task + " produced no more samples (stopped?)";
        continue;
      }
      if (progress) {
        std::fprintf(stderr, "\r  %s: %s / %s s, %zu samples, %llu lost   ", fired ? "recording" : "waiting",
                     fmt(started ? static_cast<double>(now - fired_wall) / 1e9 : 0).c_str(),
                     fmt(a.duration).c_str(), rec.rows.size(), static_cast<unsigned long long>(reader.lost()));
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (progress) std::fputc('\n', stderr);
  end_trace();
  signal(SIGINT, SIG_DFL);
  signal(SIGTERM, SIG_DFL);

  std::vector<std::string> columns{"t"};
  if (a.cycles) columns.push_back("cycle");
  columns.insert(columns.end(), sel.labels.begin(), sel.labels.end());
  std::string what = "rtplc trace: runtime " + a.name + ", task " + sel.task + " (period " +
                     fmt(static_cast<double>(sel.period_ns) / 1e9) + " s), ";
  if (rec.rows.empty()) {
    what += "no samples";
  } else {
    what += "cycles " + std::to_string(rec.first_cycle) + " to " + std::to_string(rec.last_cycle) + ", " +
            std::to_string(rec.rows.size()) + " samples, " + std::to_string(rec.lost_in_window) + " lost";
  }
  if (trig) what += fired ? ", trigger " + a.trigger + " at t = 0" : ", trigger " + a.trigger + " never held";
  std::vector<std::string> summary{what};
  if (!ended_why.empty()) summary.push_back("ended early: " + ended_why);
  if (auto w = write_recording(rec, columns, summary, a.csv); !w) fail_trace(w.error());
  if (!a.quiet) {
    std::fprintf(stderr, "%s%s\n", what.c_str(),
                 a.csv.empty() || a.csv == "-" ? "" : ("; wrote " + a.csv).c_str());
  }
  if (!a.plot.empty() && !rec.rows.empty()) {
    std::string title = "rtplc trace - runtime " + a.name + ", task " + sel.task;
    if (auto p = plot_recording(rec, sel, a.cycles, a.plot, title); !p) fail_trace(p.error());
    if (!a.quiet) std::fprintf(stderr, "wrote %s\n", a.plot.c_str());
  }
  if (!ended_why.empty() && ended_why != "interrupted") fail_trace("ended early: " + ended_why);
  if (trig && !fired) fail_trace("the trigger " + a.trigger + " never held; nothing recorded");
  if (rec.lost_in_window > 0) {
    fail_trace("INCOMPLETE: " + std::to_string(rec.lost_in_window) +
         " samples were overwritten before this tool read them (the CSV marks where); "
         "a busy machine or a slow output (a terminal) makes it fall behind");
  }
}

}  // namespace

void add_trace_command(CLI::App& app) {
  auto a = std::make_shared<TraceArgs>();
  CLI::App* tr = app.add_subcommand("trace", "Record channels of the running runtime on every cycle, to CSV (and PNG).");
  tr->footer(std::string(
      "Samples the channels on every cycle of the task that writes them (outputs) or reads them\n"
      "(inputs, set-points: the value the program used in that cycle), with no cycle left out:\n"
      "the task appends each cycle to a ring in the shared image and this tool drains it. A\n"
      "sample overwritten before it was read is counted, marked in the CSV ('# lost ...') and\n"
      "makes the exit code 1; it is never left out silently.\nOne trace covers one task and up to ") +
      std::to_string(io::kTraceChannels) +
      " channels; another task's channels need another `rtplc trace`.\n"
      "The CSV has `rtplc sim`'s layout: a column t (seconds from the first sample, or from the\n"
      "trigger; pre-trigger samples have t < 0), then one column per label; '#' lines are notes\n"
      "and the summary (gnuplot skips them; pandas: comment='#'). Messages, and progress when\n"
      "standard error is a terminal, go to standard error.\n"
      "Examples:\n"
      "  rtplc trace PV MV --duration 30 --csv run.csv --plot run.png\n"
      "  rtplc trace Level Valve --trigger 'Level>80' --duration 5 --csv fill.csv\n"
      "  rtplc trace F1 --duration 2 --cycles | head");
  tr->add_option("labels", a->labels, "channel labels (inputs, outputs, set-points of one task)")->required();
  tr->add_option("--duration", a->duration, "seconds to record (default 10; from the trigger with --trigger)")
      ->check(seconds_between(1e-3, 1e6));
  tr->add_option("--csv", a->csv, "write the CSV here (default: standard output)");
  tr->add_option("--plot", a->plot, "also draw the trace into this PNG (needs gnuplot)");
  tr->add_option("--trigger", a->trigger,
                 "start recording when LABEL>VALUE (or LABEL<VALUE) first holds; LABEL is traced too");
  tr->add_option("--pre-trigger", a->pre_trigger, "seconds kept before the trigger (default 10% of --duration)")
      ->check(CLI::Range(0.0, 1e6));
  tr->add_flag("--cycles", a->cycles, "add a column `cycle` (the task's cycle number) after t");
  tr->add_option("--name", a->name, "runtime name (runtime.name in the config; default rtplc)")->check(runtime_name());
  tr->add_option("--socket", a->socket, "control socket path (default from the name)");
  tr->add_flag("-q,--quiet", a->quiet, "print nothing but the CSV and errors");
  tr->callback([a] { run_trace(*a); });
}

}  // namespace rtplc::app
