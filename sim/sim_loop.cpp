// Closed-loop simulation in virtual time (see sim_loop.h).
#include "sim/sim_loop.h"

#include "blocks/string_ops.h"

#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "blocks/executor.h"
#include "common/files.h"
#include "common/text.h"
#include "kernel_rt/clock.h"

namespace rtplc::io {
namespace {

std::string address(const Binding& b) {
  return "p" + std::to_string(b.p) + ".d" + std::to_string(b.d) + ".c" + std::to_string(b.c);
}

std::string list_channels(const TaskImage& img, BindingDir dir, const char* block) {
  std::string s;
  for (const Binding& b : img.bindings()) {
    if (b.dir != dir || b.group != IoGroup::kDio || b.kind != Kind::kAnalog) continue;
    s += std::string(s.empty() ? "" : ", ") + address(b) + " (\"" + img.str(b.label) + "\")";
  }
  return s.empty() ? std::string("the program has no ") + block + " block" : "it has " + s;
}

using kernel_rt::sleep_until_ns;

int64_t now_ns() { return kernel_rt::monotonic_now_ns(); }

std::string gp_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "''";
    else out += c;
  }
  return out + "'";
}

}  // namespace

std::pair<const Binding*, const Binding*> plant_bindings(const TaskImage& image, const SimOptions& opt) {
  const Binding* pv = nullptr;
  const Binding* mv = nullptr;
  for (const Binding& b : image.bindings()) {
    if (b.group != IoGroup::kDio || b.kind != Kind::kAnalog) continue;
    if (b.dir == BindingDir::kInput && address(b) == opt.plant_output && !pv) pv = &b;
    if (b.dir == BindingDir::kOutput && address(b) == opt.plant_input && !mv) mv = &b;
  }
  return {pv, mv};
}

bool has_plant_input(const TaskImage& image, const SimOptions& opt) {
  return plant_bindings(image, opt).second != nullptr;
}

bool runs_open_loop(const TaskImage& image, const SimOptions& opt) {
  const auto [pv, mv] = plant_bindings(image, opt);
  // Nothing drives the plant, or nothing measures it: no loop to close.
  return opt.open_loop_if_unwired && (pv == nullptr || mv == nullptr);
}

Result<SimTrace> run_closed_loop(const TaskImage& image, Plant& plant, const SimOptions& opt) {
  if (!(opt.duration > 0) || opt.duration > 1e7) return make_error("duration must be in (0, 1e7] s");
  const double dt = image.period_s();
  SimTrace tr;
  tr.dt = dt;
  int steps = 0;
  tr.plant_step = plant_step_for(dt, &steps);
  tr.plant = plant.describe();

  // A plant with ports (the measuring tank) is wired by label: each port input
  // reads the output channel of that name, each port output drives the input
  // channel of that name when the program has one, else it is traced as plant.<port>.
  const std::vector<std::string> port_in = plant.port_inputs(), port_out = plant.port_outputs();
  const bool ports = !port_in.empty();
  std::vector<const Binding*> port_in_b, port_out_b;
  for (const std::string& name : port_in) {
    const Binding* found = nullptr;
    for (const Binding& b : image.bindings()) {
      if (b.dir == BindingDir::kOutput && name == image.str(b.label)) found = &b;
    }
    if (!found)
      return make_error("the plant reads an output labelled \"" + name +
                        "\"; the program has none");
    port_in_b.push_back(found);
  }
  for (const std::string& name : port_out) {
    const Binding* found = nullptr;
    for (const Binding& b : image.bindings()) {
      if (b.dir == BindingDir::kInput && name == image.str(b.label)) found = &b;
    }
    port_out_b.push_back(found);
  }

  auto [pv, mv] = plant_bindings(image, opt);
  if (ports) {
    pv = mv = nullptr;
  } else if ((!mv || !pv) && opt.open_loop_if_unwired) {
    tr.open_loop = true;
    tr.plant = "none (open loop)";
  }
  if (!ports && !mv && !tr.open_loop) {
    return make_error("no dao at " + opt.plant_input + " to drive the plant: " +
                      list_channels(image, BindingDir::kOutput, "dao") +
                      "; choose one with --plant-input");
  }
  if (!ports && !pv && !tr.open_loop) {
    return make_error("no dai at " + opt.plant_output + " to measure the plant: " +
                      list_channels(image, BindingDir::kInput, "dai") +
                      "; choose one with --plant-output");
  }

  TaskArena arena(image);
  tr.columns.push_back("t");
  tr.is_output.push_back(false);
  std::vector<const Binding*> cols;
  int analog_setpoints = 0;
  for (const Binding& b : image.bindings()) {
    cols.push_back(&b);
    // A `good` block's input: every simulated channel is good.
    const bool quality = b.dir == BindingDir::kQuality;
    if (quality) arena.io_in[b.io_index] = 1.0;
    tr.columns.push_back(std::string(image.str(b.label)) + (quality ? ".good" : ""));
    tr.is_output.push_back(b.dir == BindingDir::kOutput);
    if (&b == pv) tr.pv_column = static_cast<int>(tr.columns.size() - 1);
    if (&b == mv) tr.mv_column = static_cast<int>(tr.columns.size() - 1);
    if (b.dir == BindingDir::kSetpoint && b.kind == Kind::kAnalog) {
      ++analog_setpoints;
      tr.sp_column = static_cast<int>(tr.columns.size() - 1);
    }
    if (b.dir == BindingDir::kSetpoint) arena.io_in[b.io_index] = b.init;
  }
  if (analog_setpoints != 1) tr.sp_column = -1;
  // Several set-points (a PID's, a manual value, a mode): the one every
  // --step changes is the loop's.
  if (tr.sp_column < 0 && !opt.steps.empty()) {
    const std::string& label = opt.steps.front().label;
    bool one_label = true;
    for (const SetpointStep& st : opt.steps) one_label = one_label && st.label == label;
    for (size_t c = 1; c < cols.size() + 1 && one_label; ++c) {
      const Binding& b = *cols[c - 1];
      if (b.dir == BindingDir::kSetpoint && b.kind == Kind::kAnalog && tr.columns[c] == label) {
        tr.sp_column = static_cast<int>(c);
      }
    }
  }
  std::vector<uint32_t> probe_slots;
  std::vector<uint32_t> text_slots;  // STRING probes: read as text each row
  std::vector<bool> text_wide;       // ... a WSTRING's (its UTF-16 as UTF-8)
  tr.text_index.assign(tr.columns.size(), -1);
  for (const std::string& name : opt.probes) {
    // A located variable is already traced as its channel, under the same label.
    if (std::find(tr.columns.begin(), tr.columns.end(), name) != tr.columns.end()) continue;
    bool found = false;
    for (uint32_t s = 0; s < image.blocks().size() && !found; ++s) {
      if (image.str(image.blocks()[s].name) != name) continue;
      const Op op = image.code()[s].op;
      if (!op_writes_value(op)) break;
      probe_slots.push_back(image.code()[s].out);
      tr.text_index.push_back(op_output_string(op) ? static_cast<int>(text_slots.size()) : -1);
      if (op_output_string(op)) {
        text_slots.push_back(image.code()[s].out);
        text_wide.push_back(writes_wide_string(image.code()[s], image.params().data() + image.code()[s].param));
      }
      tr.columns.push_back(name);
      tr.is_output.push_back(false);
      found = true;
    }
    if (!found) return make_error("no block named '" + name + "' to trace");
  }
  for (size_t j = 0; j < port_out.size(); ++j) {
    if (port_out_b[j]) continue;  // already traced as the program's input
    tr.columns.push_back("plant." + port_out[j]);
    tr.is_output.push_back(false);
    tr.text_index.push_back(-1);
  }
  std::vector<double> port_values(port_in.size(), 0.0);

  // Resolve set-point steps to input-buffer indices up front.
  struct Pending {
    uint32_t io;
    double value;
    double at;
  };
  std::vector<Pending> pending;
  for (const SetpointStep& s : opt.steps) {
    const Binding* found = nullptr;
    for (const Binding& b : image.bindings()) {
      if (b.dir == BindingDir::kSetpoint && s.label == image.str(b.label)) found = &b;
    }
    if (!found) return make_error("--step: no set-point labelled \"" + s.label + "\"");
    if (found->kind == Kind::kDigital && s.value != 0 && s.value != 1) {
      return make_error("--step: \"" + s.label + "\" is digital and takes 0 or 1");
    }
    pending.push_back({found->io_index, s.value, s.at});
  }
  std::sort(pending.begin(), pending.end(), [](auto& a, auto& b) { return a.at < b.at; });
  // What "diverged" means is relative to the largest value the loop is asked for.
  double scale = 1;
  for (const Binding& b : image.bindings()) {
    if (b.dir == BindingDir::kSetpoint && std::isfinite(b.init)) scale = std::max(scale, std::fabs(b.init));
  }
  for (const Pending& p : pending) scale = std::max(scale, std::fabs(p.value));
  const double diverge_limit = kDivergenceFactor * scale;

  plant.reset();
  arena.loop_budget = opt.loop_budget;
  ExecContext ctx = make_context(image, arena);
  ctx.native = opt.native;
  const auto cycles = static_cast<uint64_t>(std::floor(opt.duration / dt + 1e-9)) + 1;
  tr.rows.reserve(cycles);
  const int64_t start = now_ns();
  const auto period_ns = image.header().period_ns;
  size_t next_step = 0;
  for (uint64_t k = 0; k < cycles; ++k) {
    const double t = static_cast<double>(k) * dt;
    if (opt.realtime) sleep_until_ns(start + static_cast<int64_t>(k) * period_ns);
    while (next_step < pending.size() && pending[next_step].at <= t + 1e-9) {
      arena.io_in[pending[next_step].io] = pending[next_step].value;
      ++next_step;
    }
    if (ports) {
      for (size_t j = 0; j < port_out_b.size(); ++j) {
        if (port_out_b[j]) arena.io_in[port_out_b[j]->io_index] = plant.port_output(j);
      }
    } else if (pv) {
      const double y = plant.output();
      if (tr.diverged_at < 0 && (!std::isfinite(y) || std::fabs(y) > diverge_limit)) {
        tr.diverged_at = t;
        tr.diverged_value = y;
      }
      arena.io_in[pv->io_index] = y;
    }
    execute_cycle(ctx);
    if (arena.loop_fault != 0 && arena.loop_fault - 1 < image.blocks().size()) {
      const BlockInfo& b = image.blocks()[arena.loop_fault - 1];
      return make_error((opt.file.empty() ? std::string() : opt.file + ":") + std::to_string(b.line) + ":" +
                        std::to_string(b.col) + ": runaway loop: it took more than " +
                        std::to_string(opt.loop_budget) + " iterations in cycle " + std::to_string(k + 1) +
                        " (t = " + format_number(t) +
                        " s); under `rtplc run` the task stops here and its outputs take their safe values "
                        "(the task's loop_budget sets the limit)");
    }
    const double u = mv ? arena.io_out[mv->io_index] : 0.0;
    std::vector<double> row;
    row.reserve(cols.size() + 1 + port_out.size());
    row.push_back(t);
    for (const Binding* b : cols) {
      row.push_back(b->dir == BindingDir::kOutput ? arena.io_out[b->io_index]
                                                  : arena.io_in[b->io_index]);
    }
    for (uint32_t slot : probe_slots) row.push_back(arena.values[slot]);
    for (size_t j = 0; j < port_out.size(); ++j) {
      if (!port_out_b[j]) row.push_back(plant.port_output(j));
    }
    tr.rows.push_back(std::move(row));
    if (!text_slots.empty()) {
      std::vector<std::string> texts;
      texts.reserve(text_slots.size());
      for (size_t j = 0; j < text_slots.size(); ++j) {
        texts.push_back(string_value(arena.values.data(), static_cast<uint32_t>(arena.values.size()), text_slots[j],
                                     text_wide[j]));
      }
      tr.texts.push_back(std::move(texts));
    }
    if (ports) {
      for (size_t j = 0; j < port_in_b.size(); ++j)
        port_values[j] = arena.io_out[port_in_b[j]->io_index];
      for (int s = 0; s < steps; ++s) plant.step_ports(port_values, tr.plant_step);
    } else if (!tr.open_loop) {
      for (int s = 0; s < steps; ++s) plant.step(u, tr.plant_step);
    }
  }
  tr.block_errors = arena.total_errors;
  return tr;
}

namespace {

// The figures of one step over rows [from, to).
StepMetrics one_step(const SimTrace& tr, size_t from, size_t to, double setpoint_from) {
  const auto pv = static_cast<size_t>(tr.pv_column);
  const auto sp = static_cast<size_t>(tr.sp_column);
  StepMetrics m;
  m.at = tr.rows[from][0];
  m.setpoint_from = setpoint_from;
  m.setpoint = tr.rows[from][sp];
  m.initial = tr.rows[from][pv];
  m.final_value = tr.rows[to - 1][pv];
  m.last = to == tr.rows.size();
  const double span = m.setpoint - m.initial;
  m.final_error_pct = std::fabs(m.final_value - m.setpoint) / std::fabs(span) * 100.0;
  m.peak = m.initial;
  double t10 = -1, t90 = -1;
  size_t last_outside = from;
  bool ever_outside = false;
  for (size_t i = from; i < to; ++i) {
    const double y = tr.rows[i][pv], t = tr.rows[i][0];
    const double frac = (y - m.initial) / span;  // progress toward the set-point
    if ((y - m.peak) * (span > 0 ? 1 : -1) > 0) {
      m.peak = y;
      m.peak_time = t - m.at;
    }
    if (t10 < 0 && frac >= 0.1) t10 = t;
    if (t90 < 0 && frac >= 0.9) t90 = t;
    if (std::fabs(y - m.setpoint) > 0.02 * std::fabs(span)) {
      last_outside = i;
      ever_outside = true;
    }
  }
  const double over = (m.peak - m.setpoint) / span * 100.0;
  m.overshoot_pct = over > 0 ? over : 0.0;
  if (t10 >= 0 && t90 >= 0) m.rise_time = t90 - t10;
  if (!ever_outside) m.settling_time = 0;
  else if (last_outside + 1 < to) m.settling_time = tr.rows[last_outside + 1][0] - m.at;
  return m;
}

}  // namespace

std::vector<StepMetrics> step_metrics(const SimTrace& tr) {
  std::vector<StepMetrics> out;
  if (tr.pv_column < 0 || tr.sp_column < 0 || tr.rows.empty()) return out;
  const auto pv = static_cast<size_t>(tr.pv_column);
  const auto sp = static_cast<size_t>(tr.sp_column);
  // Segments between set-point changes; the first starts at t = 0, where the
  // measurement's own start is the "set-point before".
  std::vector<size_t> starts{0};
  for (size_t i = 1; i < tr.rows.size(); ++i) {
    if (tr.rows[i][sp] != tr.rows[i - 1][sp]) starts.push_back(i);
  }
  for (size_t k = 0; k < starts.size(); ++k) {
    const size_t from = starts[k];
    const size_t to = k + 1 < starts.size() ? starts[k + 1] : tr.rows.size();
    // No step to respond to: the measurement already sits at the set-point.
    if (std::fabs(tr.rows[from][sp] - tr.rows[from][pv]) < 1e-12) continue;
    out.push_back(one_step(tr, from, to, k == 0 ? tr.rows[0][pv] : tr.rows[from - 1][sp]));
  }
  return out;
}

std::string format_metrics(const SimTrace& tr, const std::vector<StepMetrics>& steps) {
  if (tr.pv_column < 0 || tr.open_loop) return "";  // no loop: no step response
  const std::string pv = tr.columns[static_cast<size_t>(tr.pv_column)];
  char buf[512];
  if (tr.sp_column < 0) {
    std::snprintf(buf, sizeof buf,
                  "%s: %g -> %g; no step figures: no single analog set-point to compare it with "
                  "(a --step on the loop's set-point names it)\n",
                  pv.c_str(), tr.rows.front()[static_cast<size_t>(tr.pv_column)],
                  tr.rows.back()[static_cast<size_t>(tr.pv_column)]);
    return buf;
  }
  const std::string spn = tr.columns[static_cast<size_t>(tr.sp_column)];
  if (steps.empty()) {
    std::snprintf(buf, sizeof buf, "%s: no step figures: it starts at its set-point %s and that never changes\n",
                  pv.c_str(), spn.c_str());
    return buf;
  }
  std::string out;
  for (const StepMetrics& m : steps) {
    const std::string until = m.last ? "by the end of the run" : "before the next step";
    if (m.at == tr.rows.front()[0]) {
      // The run starts away from the set-point: the "step" is the start.
      std::snprintf(buf, sizeof buf, "from the start, %s = %g: %s %g -> %g, final error %.3f%% of the step\n",
                    spn.c_str(), m.setpoint, pv.c_str(), m.initial, m.final_value, m.final_error_pct);
    } else {
      std::snprintf(buf, sizeof buf, "step at %g s, %s %g -> %g: %s %g -> %g, final error %.3f%% of the step\n",
                    m.at, spn.c_str(), m.setpoint_from, m.setpoint, pv.c_str(), m.initial, m.final_value,
                    m.final_error_pct);
    }
    out += buf;
    std::snprintf(buf, sizeof buf, "  overshoot %.1f%% (peak %g, %g s after the %s)\n", m.overshoot_pct, m.peak,
                  m.peak_time, m.at == tr.rows.front()[0] ? "start" : "step");
    out += buf;
    if (m.rise_time >= 0) std::snprintf(buf, sizeof buf, "  rise time (10%%-90%%) %g s\n", m.rise_time);
    else std::snprintf(buf, sizeof buf, "  rise time: never reached 90%% of the step %s\n", until.c_str());
    out += buf;
    if (m.settling_time >= 0) {
      std::snprintf(buf, sizeof buf, "  settling time (2%% band) %g s after the %s\n", m.settling_time,
                    m.at == tr.rows.front()[0] ? "start" : "step");
    } else {
      std::snprintf(buf, sizeof buf, "  did not settle within 2%% of the step %s\n", until.c_str());
    }
    out += buf;
  }
  return out;
}

std::string csv_header_line(const std::vector<std::string>& columns) {
  std::string line;
  for (size_t i = 0; i < columns.size(); ++i) line += (i ? "," : "") + columns[i];
  return line + '\n';
}

std::string csv_row_line(const double* row, size_t n) {
  std::string line;
  char cell[40];
  for (size_t i = 0; i < n; ++i) {
    // t to the microsecond over a day-long run, without trailing zeros;
    // values with full precision.
    std::snprintf(cell, sizeof cell, i == 0 ? "%.11g" : ",%.10g", row[i]);
    line += cell;
  }
  return line + '\n';
}

// A text as one CSV cell: in quotes, a quote inside doubled (RFC 4180).
static std::string csv_text_cell(const std::string& s) {
  std::string cell = "\"";
  for (char c : s) cell += c == '"' ? std::string("\"\"") : std::string(1, c);
  return cell + "\"";
}

Result<void> write_csv(const SimTrace& tr, const std::string& path) {
  // Whole or not at all: a failed write (a folder at PATH, a full disk) leaves
  // neither a half file nor a stray PATH.tmp behind.
  const bool texts = !tr.texts.empty();
  return write_file_atomically(path, 0644, [&](const FileSink& sink) {
    if (!sink(csv_header_line(tr.columns))) return false;
    for (size_t r = 0; r < tr.rows.size(); ++r) {
      const auto& row = tr.rows[r];
      if (!texts || r >= tr.texts.size()) {
        if (!sink(csv_row_line(row.data(), row.size()))) return false;
        continue;
      }
      std::string line;
      for (size_t c = 0; c < row.size(); ++c) {
        const int t = c < tr.text_index.size() ? tr.text_index[c] : -1;
        if (t >= 0) line += "," + csv_text_cell(tr.texts[r][static_cast<size_t>(t)]);
        else {
          char cell[40];
          std::snprintf(cell, sizeof cell, c == 0 ? "%.11g" : ",%.10g", row[c]);
          line += cell;
        }
      }
      if (!sink(line + '\n')) return false;
    }
    return true;
  });
}

Result<void> write_plot(const SimTrace& tr, const std::string& csv_path, const std::string& png_path,
                        const std::string& title) {
  std::string script;
  script += "set terminal pngcairo size 1100,760 enhanced font 'Sans,10'\n";
  const std::string tmp_png = png_path + ".tmp";
  script += "set output " + gp_quote(tmp_png) + "\n";
  script += "set datafile separator ','\n";
  script += "set grid\nset key outside right top\n";
  script += "set multiplot layout 2,1 title " + gp_quote(title) + " noenhanced\n";
  std::string top, bottom;
  if (tr.pv_column < 0) {
    // No single measurement (a plant with ports, e.g. the SFC tank): analog
    // signals above, every 0/1 signal below as a timing chart, one lane each.
    std::string ytics;
    int lane = 0;
    for (size_t c = 1; c < tr.columns.size(); ++c) {
      if (c < tr.text_index.size() && tr.text_index[c] >= 0) continue;  // a STRING: in the CSV only
      bool digital = true;
      for (const auto& row : tr.rows) digital = digital && (row[c] == 0 || row[c] == 1);
      const std::string col = std::to_string(c + 1);
      if (!digital) {
        top += (top.empty() ? "" : ", ") + gp_quote(csv_path) + " using 1:" + col +
               " with lines lw 2 title " + gp_quote(tr.columns[c]) + " noenhanced";
        continue;
      }
      const std::string base = std::to_string(lane * 1.5);
      bottom += (bottom.empty() ? "" : ", ") + gp_quote(csv_path) + " using 1:($" + col + "*0.9+" +
                base + ") with steps lw 1.5 notitle";
      ytics += (ytics.empty() ? "" : ", ") + gp_quote(tr.columns[c]) + " " + base;
      ++lane;
    }
    script += "set ylabel 'analog'\n";
    script += "plot " + (top.empty() ? std::string("0 notitle") : top) + "\n";
    script += "set ylabel ''\nset xlabel 't (s)'\nset ytics (" + ytics + ") noenhanced\n";
    script += "set yrange [-0.5:" + std::to_string(lane * 1.5) + "]\n";
    script += "plot " + (bottom.empty() ? std::string("0 notitle") : bottom) + "\n";
    script += "unset multiplot\n";
    top.clear();
    bottom.clear();
  }
  // Inputs and set-points above (the measurement in bold), outputs below.
  for (size_t c = 1; c < tr.columns.size() && tr.pv_column >= 0; ++c) {
    if (c < tr.text_index.size() && tr.text_index[c] >= 0) continue;
    const bool is_out = tr.is_output[c];
    std::string item = gp_quote(csv_path) + " using 1:" + std::to_string(c + 1) +
                       " with lines lw " + (static_cast<int>(c) == tr.pv_column ? "2.5" : "1.5") +
                       " title " + gp_quote(tr.columns[c]) + " noenhanced";
    std::string& panel = is_out ? bottom : top;
    panel += panel.empty() ? item : ", " + item;
  }
  if (tr.pv_column >= 0) {
    script += "set ylabel 'inputs and set-points'\n";
    script += "plot " + (top.empty() ? std::string("0 notitle") : top) + "\n";
    script += "set ylabel 'outputs'\nset xlabel 't (s)'\n";
    script += "plot " + (bottom.empty() ? std::string("0 notitle") : bottom) + "\n";
    script += "unset multiplot\n";
  }
  // gnuplot writes into a temporary file beside the PNG (so a failed run
  // leaves no half picture), its own output goes to /dev/null (a PNG it could
  // not open would otherwise land on the terminal), its errors into a file we
  // read back for the message.
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    return make_error("cannot draw " + png_path + ": gnuplot is not installed (Debian: apt-get install gnuplot-nox)");
  }
  char err_name[] = "/tmp/rtplc-gnuplot-XXXXXX";
  const int err_fd = mkstemp(err_name);
  if (err_fd < 0) return make_error(std::string("cannot create a temporary file: ") + std::strerror(errno));
  close(err_fd);
  FILE* gp = popen(("gnuplot >/dev/null 2>" + std::string(err_name)).c_str(), "w");
  if (!gp) {
    unlink(err_name);
    return make_error("cannot start gnuplot: " + std::string(std::strerror(errno)));
  }
  std::fputs(script.c_str(), gp);
  const int rc = pclose(gp);
  std::string said;
  if (Result<std::string> e = read_file_bounded(err_name, 64 * 1024); e) said = *e;
  unlink(err_name);
  struct stat st{};
  const bool drawn = rc == 0 && stat(tmp_png.c_str(), &st) == 0 && st.st_size > 0;
  if (!drawn) {
    unlink(tmp_png.c_str());
    // gnuplot's own words, the last non-empty line (it names the file and why).
    while (!said.empty() && (said.back() == '\n' || said.back() == ' ')) said.pop_back();
    const size_t nl = said.find_last_of('\n');
    const std::string last = nl == std::string::npos ? said : said.substr(nl + 1);
    return make_error("cannot draw " + png_path + (last.empty() ? std::string(": gnuplot failed") : ": gnuplot: " + last));
  }
  if (std::rename(tmp_png.c_str(), png_path.c_str()) != 0) {
    const int e = errno;
    unlink(tmp_png.c_str());
    return make_error("cannot write " + png_path + ": " + std::strerror(e));
  }
  return {};
}

}  // namespace rtplc::io
