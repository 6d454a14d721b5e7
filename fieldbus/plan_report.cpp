// Text and JSON renderings of a Plan (see plan_report.h).
#include "fieldbus/plan_report.h"

#include <algorithm>
#include <cstdio>

#include "common/text.h"

namespace rtplc::fieldbus {
namespace {

const char* access_name(Access a) {
  return a == Access::kTokenPassing ? "token passing" : "polling";
}

std::string frame_reason(const Design& d, const Plan& p) {
  if (d.frame) return "given by link.frame";
  for (const LoopSpec& l : d.loops) {
    if (l.period && *l.period == p.t1) return "the shortest fixed period";
  }
  return "half the tightest max_delay";
}

}  // namespace

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (static_cast<unsigned char>(ch) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(ch));
      out += buf;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

std::string json_seconds(Nanos x) {
  // Nanoseconds are exact in decimal: print them as a decimal fraction.
  const bool neg = x < 0;
  const Nanos a = neg ? -x : x;
  std::string frac = std::to_string(a % kNanosPerSecond);
  frac.insert(0, 9 - frac.size(), '0');
  while (!frac.empty() && frac.back() == '0') frac.pop_back();
  return (neg ? "-" : "") + std::to_string(a / kNanosPerSecond) + (frac.empty() ? "" : "." + frac);
}

std::string render_plan_text(const Design& d, const Plan& p, const std::string& file) {
  std::string s = "fieldbus plan " + file + ": " + (p.feasible ? "FEASIBLE" : "INFEASIBLE") + "\n";
  s += "link     " + std::to_string(d.nodes) + " nodes, " + access_name(d.access) +
       (d.link_text.empty() ? "" : ", " + d.link_text) + "; server overhead sigma " +
       format_time(d.server_overhead) + ", R = N sigma = " + format_time(p.server_round) + "\n";
  s += "packets  periodic L_p " + format_time(d.periodic_packet) + "; real-time " +
       std::to_string(d.rt_queues) + " queues x L_c " + format_time(d.rt_packet);
  if (d.nonrt_packet) s += "; non-RT " + format_time(*d.nonrt_packet);
  s += "\n";
  if (p.t1 <= 0) {
    s += "\n";
  } else {
    s += "T_1      " + format_time(p.t1) + " (" + frame_reason(d, p) + ")\n";
    s += "gamma    " + std::to_string(p.gamma) + " periodic packets in the busiest frame (lower " +
         "bound " + std::to_string(p.gamma_lower_bound) + "; " + std::to_string(p.periodic_nodes) +
         " nodes send periodic data)\n";
    s += "periodic gamma L_p + N_c L_c + R = " + std::to_string(p.gamma) + " * " +
         format_time(d.periodic_packet) + " + " + std::to_string(d.rt_queues) + " * " + format_time(d.rt_packet) +
         " + " + format_time(p.server_round) + " = " + format_time(p.periodic_part) +
         (p.periodic_part <= p.t1 ? " <= " : " > ") + "T_1\n";
    if (p.periodic_part <= p.t1) {
      s += "L_n max  (T_1 - " + format_time(p.periodic_part) +
           ") / (N - gamma + 1) = " + format_time(p.t1 - p.periodic_part) + " / " +
           std::to_string(d.nodes - p.gamma + 1) + " = " + format_time(p.ln_max) + "\n";
      s += "W        worst transfer delay of a periodic packet " + format_time(p.transfer_bound) +
           " (one packet in flight " + format_time(p.transfer_bound - p.periodic_part) +
           " + periodic part)\n";
    }
    s += "\n" + pad_right("loop", 14) + pad_right("period", 12) + pad_right("offset", 8) + pad_right("nodes", 9) +
         pad_right("delay bound", 14) + "max_delay\n";
    for (const LoopPlan& l : p.loops) {
      s += pad_right(l.name, 14) + pad_right(format_time(l.period) + (l.fixed ? "" : "*"), 12) +
           pad_right(l.offset < 0 ? "-" : std::to_string(l.offset), 8) +
           pad_right(std::to_string(l.sensor_node) + "->" + std::to_string(l.controller_node), 9) +
           pad_right(format_time(l.delay_bound), 14) + (l.max_delay ? format_time(*l.max_delay) : "-") + "\n";
    }
    s += "(* = chosen by the planner; offset in T_1 frames; delay bound D = T_i + W)\n";
    const size_t shown = std::min<size_t>(p.frame_load.size(), 32);
    s += "frames   packets per frame over the " + std::to_string(p.hyperperiod) + "-frame cycle:";
    for (size_t f = 0; f < shown; ++f) s += " " + std::to_string(p.frame_load[f]);
    if (shown < p.frame_load.size()) s += " ...";
    s += "\n";
  }
  if (p.feasible) {
    s += "\nresult   feasible: non-RT packets up to L_n max = " + format_time(p.ln_max) + "\n";
  } else {
    s += "\nresult   infeasible; failing conditions:\n";
    for (const Failure& f : p.failures) {
      s += "  " + pad_right(std::string(to_string(f.condition)) + ":", 14) + f.message;
      if (f.shortfall > 0) s += " [short by " + format_time(f.shortfall) + "]";
      s += "\n";
    }
  }
  return s;
}

std::string render_plan_json(const Design& d, const Plan& p, const std::string& simulation) {
  std::string s = "{\n";
  s += "  \"feasible\": " + std::string(p.feasible ? "true" : "false") + ",\n";
  s += "  \"T1\": " + json_seconds(p.t1) + ",\n";
  s += "  \"gamma\": " + std::to_string(p.gamma) + ",\n";
  s += "  \"gamma_lower_bound\": " + std::to_string(p.gamma_lower_bound) + ",\n";
  s += "  \"nodes\": " + std::to_string(d.nodes) + ",\n";
  s += "  \"periodic_nodes\": " + std::to_string(p.periodic_nodes) + ",\n";
  s += "  \"R\": " + json_seconds(p.server_round) + ",\n";
  s += "  \"Lp\": " + json_seconds(d.periodic_packet) + ",\n";
  s += "  \"Lc\": " + json_seconds(d.rt_packet) + ",\n";
  s += "  \"Nc\": " + std::to_string(d.rt_queues) + ",\n";
  s += "  \"periodic_part\": " + json_seconds(p.periodic_part) + ",\n";
  const bool stable = p.t1 > 0 && p.periodic_part <= p.t1;
  s += "  \"Ln_max\": " + (stable ? json_seconds(p.ln_max) : std::string("null")) + ",\n";
  s += "  \"transfer_bound\": " + json_seconds(p.transfer_bound) + ",\n";
  s += "  \"hyperperiod_frames\": " + std::to_string(p.hyperperiod) + ",\n";
  if (!p.feasible) s += "  \"shortfall\": " + json_seconds(p.shortfall()) + ",\n";
  s += "  \"failures\": [";
  for (size_t i = 0; i < p.failures.size(); ++i) {
    const Failure& f = p.failures[i];
    s += std::string(i ? "," : "") +
         "\n    {\"condition\": " + json_string(to_string(f.condition)) +
         ", \"loop\": " + json_string(f.loop) + ", \"shortfall\": " + json_seconds(f.shortfall) +
         ", \"message\": " + json_string(f.message) + "}";
  }
  s += p.failures.empty() ? "],\n" : "\n  ],\n";
  s += "  \"loops\": [";
  for (size_t i = 0; i < p.loops.size(); ++i) {
    const LoopPlan& l = p.loops[i];
    s += std::string(i ? "," : "") + "\n    {\"name\": " + json_string(l.name) +
         ", \"period\": " + json_seconds(l.period) + ", \"offset\": " + std::to_string(l.offset) +
         ", \"fixed\": " + (l.fixed ? "true" : "false") +
         ", \"sensor_node\": " + std::to_string(l.sensor_node) +
         ", \"controller_node\": " + std::to_string(l.controller_node) +
         ", \"delay_bound\": " + json_seconds(l.delay_bound) +
         ", \"max_delay\": " + (l.max_delay ? json_seconds(*l.max_delay) : std::string("null")) +
         "}";
  }
  s += p.loops.empty() ? "]" : "\n  ]";
  if (!simulation.empty()) s += ",\n  \"simulation\": " + simulation;
  return s + "\n}\n";
}

}  // namespace rtplc::fieldbus
