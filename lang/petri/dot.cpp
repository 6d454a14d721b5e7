// Graphviz output of a net and its reachability graph (see dot.h).
#include "lang/petri/dot.h"

#include <vector>

namespace rtplc::petri {
namespace {

std::string quote(std::string_view s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (c == '\n') {
      o += "\\n";
      continue;
    }
    o += c;
  }
  return o + "\"";
}

std::string tokens(uint32_t n) {
  if (n == 0) return "";
  if (n <= 3) {
    std::string s;
    for (uint32_t i = 0; i < n; ++i) s += "\u25CF";  // a black dot per token
    return s;
  }
  return std::to_string(n);
}

}  // namespace

std::string write_dot(const Net& net, const ReachabilityGraph* graph) {
  std::string o = "digraph " + quote(net.name()) + " {\n  rankdir=LR;\n  fontname=\"Helvetica\";\n";
  o += "  node [fontname=\"Helvetica\"]; edge [fontname=\"Helvetica\"];\n";
  o += "  subgraph cluster_net {\n    label=" + quote("net " + net.name()) + ";\n";
  for (PlaceId p = 0; p < net.place_count(); ++p) {
    const std::string t = tokens(net.place(p).initial);
    o += "    p" + std::to_string(p) +
         " [shape=circle, label=" + quote(net.place_label(p) + (t.empty() ? "" : "\n" + t)) +
         "];\n";
  }
  for (TransitionId t = 0; t < net.transition_count(); ++t) {
    o += "    t" + std::to_string(t) +
         " [shape=box, style=filled, fillcolor=gray85, label=" + quote(net.transition_label(t)) +
         "];\n";
  }
  for (TransitionId t = 0; t < net.transition_count(); ++t) {
    for (const ArcEnd& e : net.inputs(t)) {
      const std::string w = e.weight == 1 ? "" : " label=" + quote(std::to_string(e.weight)) + ",";
      if (net.post(e.place, t) == e.weight) {  // a read arc
        o += "    p" + std::to_string(e.place) + " -> t" + std::to_string(t) + " [" + w +
             " dir=both, style=dashed];\n";
      } else {
        o += "    p" + std::to_string(e.place) + " -> t" + std::to_string(t) + " [" + w + "];\n";
      }
    }
    for (const ArcEnd& e : net.outputs(t)) {
      if (net.pre(e.place, t) == e.weight) continue;  // drawn as a read arc
      const std::string w = e.weight == 1 ? "" : "label=" + quote(std::to_string(e.weight));
      o += "    t" + std::to_string(t) + " -> p" + std::to_string(e.place) + " [" + w + "];\n";
    }
  }
  o += "  }\n";
  if (graph) {
    o += "  subgraph cluster_rg {\n    label=\"reachability graph\";\n";
    std::vector<bool> has_out(graph->markings.size(), false);
    for (const auto& e : graph->edges) has_out[e.from] = true;
    for (size_t i = 0; i < graph->markings.size(); ++i) {
      o += "    m" + std::to_string(i) + " [shape=box, style=rounded" +
           std::string(i == 0 ? ",penwidth=2" : "") +
           std::string(has_out[i] ? "" : ",color=red,fontcolor=red") + ", label=" +
           quote("M" + std::to_string(i) + "\n" + marking_text(net, graph->markings[i])) + "];\n";
    }
    for (const auto& e : graph->edges) {
      o += "    m" + std::to_string(e.from) + " -> m" + std::to_string(e.to) +
           " [label=" + quote(net.transition_label(e.transition)) + "];\n";
    }
    o += "  }\n";
  }
  return o + "}\n";
}

}  // namespace rtplc::petri
