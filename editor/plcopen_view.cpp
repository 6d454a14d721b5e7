// PLCopen bodies as positioned elements for the editor's read-only view
// (plcopen_view.h): the graph's elements that carry a localId, their
// position and size as written, the connections found under them, and a
// flow depth (longest chain of connections leading in) for projects whose
// positions say nothing.
#include "editor/plcopen_view.h"

#include <algorithm>
#include <map>
#include <set>
#include <string>

#include "lang/plcopen/project.h"

namespace rtplc::editor {

using nlohmann::json;
namespace pc = lang::plcopen;

namespace {

std::string attr(const XmlElement& e, std::string_view n) {
  const XmlAttribute* a = e.attribute(n);
  return a ? a->value : std::string();
}

double num_attr(const XmlElement& e, std::string_view n) {
  const std::string v = attr(e, n);
  if (v.empty()) return 0;
  try {
    return std::stod(v);
  } catch (...) {
    return 0;
  }
}

// Every <connection refLocalId> under `e`, with the formal parameter of the
// <variable> it sits in (a block's input pin) when there is one.
void connections(const XmlElement& e, const std::string& pin, bool negated, json& out) {
  for (const XmlElement& c : e.children) {
    if (c.name == "connection" && c.attribute("refLocalId")) {
      out.push_back({{"pin", pin},
                     {"from", attr(c, "refLocalId")},
                     {"from_pin", attr(c, "formalParameter")},
                     {"negated", negated}});
      continue;
    }
    if (c.name == "variable" && c.attribute("formalParameter")) {
      connections(c, attr(c, "formalParameter"), attr(c, "negated") == "true", out);
      continue;
    }
    if (c.name == "outputVariables" || c.name == "inOutVariables") {
      if (e.name != "block") connections(c, pin, negated, out);
      continue;
    }
    connections(c, pin, negated, out);
  }
}

std::string label_of(const XmlElement& e) {
  if (const XmlElement* x = e.child("expression")) return x->text;
  for (const char* a : {"typeName", "name", "variable"}) {
    if (e.attribute(a)) return attr(e, a);
  }
  if (const XmlElement* v = e.child("variable")) return v->text;
  if (const XmlElement* r = e.child("reference")) return attr(*r, "name");
  return "";
}

json body_json(const pc::Body& b) {
  json els = json::array();
  if (b.graph == nullptr) return els;
  for (const XmlElement& e : b.graph->children) {
    if (!e.attribute("localId")) continue;
    json j = {{"id", attr(e, "localId")},
              {"element", e.name},
              {"label", label_of(e)},
              {"type", attr(e, "typeName")},
              {"instance", attr(e, "instanceName")},
              {"x", 0},
              {"y", 0},
              {"w", num_attr(e, "width")},
              {"h", num_attr(e, "height")}};
    if (const XmlElement* p = e.child("position")) {
      j["x"] = num_attr(*p, "x");
      j["y"] = num_attr(*p, "y");
    }
    json inputs = json::array();
    connections(e, "", attr(e, "negated") == "true", inputs);
    j["inputs"] = inputs;
    json outputs = json::array();
    if (const XmlElement* ov = e.child("outputVariables")) {
      for (const XmlElement& v : ov->children) {
        if (v.name == "variable") outputs.push_back(attr(v, "formalParameter"));
      }
    }
    j["outputs"] = outputs;
    els.push_back(std::move(j));
  }
  // Flow depth: 0 for an element nothing leads into, else one more than the
  // deepest of its sources (a cycle, a feedback loop, stops where it closes).
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < els.size(); ++i) index[els[i]["id"].get<std::string>()] = i;
  std::vector<int> depth(els.size(), -1);
  std::vector<bool> busy(els.size(), false);
  auto visit = [&](auto&& self, size_t i) -> int {
    if (depth[i] >= 0) return depth[i];
    if (busy[i]) return 0;
    busy[i] = true;
    int d = 0;
    for (const json& in : els[i]["inputs"]) {
      auto it = index.find(in["from"].get<std::string>());
      if (it != index.end()) d = std::max(d, self(self, it->second) + 1);
    }
    busy[i] = false;
    return depth[i] = d;
  };
  for (size_t i = 0; i < els.size(); ++i) els[i]["depth"] = visit(visit, i);
  return els;
}

const char* pou_type(pc::PouType t) {
  switch (t) {
    case pc::PouType::kProgram: return "program";
    case pc::PouType::kFunctionBlock: return "functionBlock";
    case pc::PouType::kFunction: return "function";
  }
  return "?";
}

}  // namespace

Result<json> plcopen_view(std::string_view xml, const std::string& file) {
  DiagnosticList diags;
  auto project = pc::read_project(xml, diags);
  if (!project) return make_error(diags.render(file, xml));
  json pous = json::array();
  for (const pc::Pou& p : project->pous) {
    json els = body_json(p.body);
    std::set<std::pair<double, double>> at;
    for (const json& e : els) at.insert({e["x"].get<double>(), e["y"].get<double>()});
    pous.push_back({{"name", p.name},
                    {"type", pou_type(p.type)},
                    {"language", pc::language_name(p.body.language)},
                    {"source", p.body.source},
                    {"positioned", at.size() == els.size() && !els.empty()},
                    {"elements", els}});
  }
  return json{{"pous", pous}};
}

}  // namespace rtplc::editor
