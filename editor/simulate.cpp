// The editor's simulation (simulate.h): the request read and bounded, the
// program compiled from the diagram's text, run_closed_loop as `rtplc sim`
// runs it, the trace thinned for the plot and whole in the CSV.
#include "editor/simulate.h"

#include <algorithm>
#include <cmath>

#include "io/drivers/sim/plant.h"
#include "lang/compiler.h"
#include "sim/sim_loop.h"

namespace rtplc::editor {

using nlohmann::json;

namespace {

Result<double> number_field(const json& j, const char* key, double fallback) {
  if (!j.contains(key) || j[key].is_null()) return fallback;
  if (!j[key].is_number()) return make_error(std::string(key) + " must be a number");
  const double v = j[key].get<double>();
  if (!std::isfinite(v)) return make_error(std::string(key) + " must be finite");
  return v;
}

Result<std::string> string_field(const json& j, const char* key, const std::string& fallback) {
  if (!j.contains(key) || j[key].is_null()) return fallback;
  if (!j[key].is_string()) return make_error(std::string(key) + " must be a string");
  std::string s = j[key].get<std::string>();
  return s.empty() ? fallback : s;
}

json metrics_json(const io::StepMetrics& m) {
  auto opt = [](double v) { return v < 0 ? json(nullptr) : json(v); };
  return {{"at", m.at},
          {"setpoint_from", m.setpoint_from},
          {"setpoint", m.setpoint},
          {"initial", m.initial},
          {"final_value", m.final_value},
          {"final_error_pct", m.final_error_pct},
          {"overshoot_pct", m.overshoot_pct},
          {"peak", m.peak},
          {"peak_time", m.peak_time},
          {"rise_time", opt(m.rise_time)},
          {"settling_time", opt(m.settling_time)},
          {"last", m.last}};
}

}  // namespace

Result<json> simulate(const Diagram& d, const json& request) {
  if (!request.is_object()) return make_error("the simulation request is an object");
  auto plant_spec = string_field(request, "plant", io::kDefaultPlant);
  if (!plant_spec) return make_error(plant_spec.error());
  auto duration = number_field(request, "duration", 30);
  if (!duration) return make_error(duration.error());
  if (*duration <= 0 || *duration > kMaxSimSeconds) {
    return make_error("duration must be more than 0 and at most " + std::to_string(static_cast<int>(kMaxSimSeconds)) +
                      " s of plant time");
  }
  io::SimOptions opt;
  opt.duration = *duration;
  auto in = string_field(request, "plant_input", opt.plant_input);
  auto out = string_field(request, "plant_output", opt.plant_output);
  if (!in) return make_error(in.error());
  if (!out) return make_error(out.error());
  opt.plant_input = *in;
  opt.plant_output = *out;
  opt.open_loop_if_unwired = true;
  if (request.contains("steps") && !request["steps"].is_null()) {
    if (!request["steps"].is_array()) return make_error("steps must be a list of {label, value, at}");
    for (const json& s : request["steps"]) {
      if (!s.is_object() || !s.contains("label") || !s["label"].is_string() || s["label"].get<std::string>().empty()) {
        return make_error("a step is {\"label\": SET-POINT, \"value\": V, \"at\": SECONDS}");
      }
      io::SetpointStep st;
      st.label = s["label"].get<std::string>();
      auto v = number_field(s, "value", NAN);
      auto at = number_field(s, "at", NAN);
      if (!v || !std::isfinite(*v)) return make_error("step " + st.label + ": value must be a finite number");
      if (!at || !std::isfinite(*at) || *at < 0 || *at > *duration) {
        return make_error("step " + st.label + ": at must be within the run, 0 to " + json(*duration).dump() + " s");
      }
      st.value = *v;
      st.at = *at;
      opt.steps.push_back(std::move(st));
    }
  }
  auto plant = io::make_plant(*plant_spec);
  if (!plant) return make_error("plant " + *plant_spec + ": " + plant.error());

  const std::string text = to_text(d);
  lang::CompileResult c = lang::compile_source(text);
  if (!c.ok()) {
    json v = check_json(check(d, request.value("file", std::string("diagram.fbd"))));
    v["compiles"] = false;
    return v;
  }
  const double period = c.image->period_s();
  if (period <= 0 || *duration / period > static_cast<double>(kMaxSimCycles)) {
    return make_error("the run would take " + json(std::floor(*duration / period)).dump() + " cycles, more than " +
                      std::to_string(kMaxSimCycles) + ": shorten the duration");
  }
  auto trace = io::run_closed_loop(*c.image, **plant, opt);
  if (!trace) return make_error(trace.error());
  const std::vector<io::StepMetrics> m = io::step_metrics(*trace);

  json rows = json::array();
  const size_t n = trace->rows.size();
  const size_t every = std::max<size_t>(1, (n + kPlotRows - 1) / kPlotRows);
  for (size_t i = 0; i < n; ++i) {
    if (i % every == 0 || i + 1 == n) rows.push_back(trace->rows[i]);
  }
  std::string csv = io::csv_header_line(trace->columns);
  for (const std::vector<double>& r : trace->rows) csv += io::csv_row_line(r.data(), r.size());
  json metrics = json::array();
  if (trace->diverged_at < 0) {
    for (const io::StepMetrics& x : m) metrics.push_back(metrics_json(x));
  }
  std::vector<bool> is_output = trace->is_output;
  return json{{"compiles", true},
              {"plant", trace->open_loop ? std::string("none (open loop)") : (*plant)->describe()},
              {"period_s", period},
              {"cycles", n},
              {"columns", trace->columns},
              {"is_output", is_output},
              {"pv", trace->pv_column},
              {"mv", trace->mv_column},
              {"sp", trace->sp_column},
              {"rows", rows},
              {"metrics", metrics},
              {"figures", trace->diverged_at < 0 ? io::format_metrics(*trace, m) : std::string()},
              {"csv", csv},
              {"block_errors", trace->block_errors},
              {"open_loop", trace->open_loop},
              {"diverged_at", trace->diverged_at < 0 ? json(nullptr) : json(trace->diverged_at)}};
}

}  // namespace rtplc::editor
