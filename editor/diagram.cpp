// The FBD editor's model: text <-> diagram, the automatic layout, the layout
// sidecar, the page's JSON, and the real compiler's verdict placed on blocks.
#include "editor/diagram.h"

#include <algorithm>
#include <charconv>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>

#include "blocks/registry.h"
#include "lang/compiler.h"
#include "lang/lexer.h"
#include "lang/parser.h"

namespace rtplc::editor {
namespace {

using nlohmann::json;

DArg from_ast(const lang::Arg& a) {
  DArg out;
  switch (a.kind) {
    case lang::Arg::Kind::kRef:
      out.kind = DArg::Kind::kRef;
      out.text = a.ref.text();
      break;
    case lang::Arg::Kind::kNumber:
      out.kind = DArg::Kind::kNumber;
      out.number = a.number;
      break;
    case lang::Arg::Kind::kDevice:
      out.kind = DArg::Kind::kDevice;
      out.text = std::string(1, a.device) + std::to_string(a.device_no);
      break;
    case lang::Arg::Kind::kString:
      out.kind = DArg::Kind::kString;
      out.text = a.text;
      break;
  }
  return out;
}

DBlock from_ast(const lang::Call& c) {
  DBlock b;
  if (c.has_target) b.id = c.target.text();
  b.kind = c.name;
  b.macro = c.is_macro;
  for (const lang::Arg& a : c.args) b.args.push_back(from_ast(a));
  return b;
}

std::string number_text(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// What a block is on the seed's screen: an input (top rows), an output
// (bottom row) or a computation between.
enum class Place : uint8_t { kInput, kCompute, kOutput };

Place place_of(const DBlock& b) {
  if (b.macro) return Place::kCompute;
  const BlockSpec* s = find_block(b.kind);
  if (!s) return Place::kCompute;
  switch (s->signature) {
    case Signature::kDeviceIn:
    case Signature::kSetpoint:
      return Place::kInput;
    case Signature::kDeviceOut:
      return Place::kOutput;
    case Signature::kCompute:
      break;
  }
  return Place::kCompute;
}

// The value references among a block's arguments (not P<n> parameters).
bool is_value_ref(const DArg& a) {
  return a.kind == DArg::Kind::kRef && !a.text.empty() && std::strchr("FDMN", a.text[0]) != nullptr;
}

// Where each id is defined (its first definition) in `blocks`.
std::map<std::string, size_t> definitions(const std::vector<DBlock>& blocks) {
  std::map<std::string, size_t> at;
  for (size_t i = 0; i < blocks.size(); ++i) {
    if (!blocks[i].id.empty()) at.emplace(blocks[i].id, i);
  }
  return at;
}

void layout_blocks(std::vector<DBlock>& blocks, int width, int first_row) {
  const size_t n = blocks.size();
  const auto def = definitions(blocks);
  std::set<std::pair<int, int>> taken;
  for (DBlock& b : blocks) {
    if (b.col < 0 || b.row < 0) continue;
    if (!taken.insert({b.col, b.row}).second) b.col = b.row = -1;  // two on one cell: the later moves
  }
  // Layers: inputs 0, computations 1 + the deepest non-feedback input, outputs last.
  std::vector<int> depth(n, 0);
  int deepest = 0;
  for (size_t i = 0; i < n; ++i) {
    const Place p = place_of(blocks[i]);
    if (p == Place::kInput) continue;
    int d = 0;
    for (const DArg& a : blocks[i].args) {
      if (!is_value_ref(a)) continue;
      auto it = def.find(a.text);
      if (it != def.end() && it->second < i) d = std::max(d, depth[it->second]);
    }
    depth[i] = d + 1;
    if (p == Place::kCompute) deepest = std::max(deepest, depth[i]);
  }
  for (size_t i = 0; i < n; ++i) {
    if (place_of(blocks[i]) == Place::kOutput) depth[i] = deepest + 1;
  }
  int row = first_row;
  for (int layer = 0; layer <= deepest + 1; ++layer) {
    std::vector<size_t> members;
    for (size_t i = 0; i < n; ++i) {
      if (depth[i] == layer) members.push_back(i);
    }
    if (members.empty()) continue;
    // The layer's rows: enough for its blocks at `width` a row; outputs go
    // below every block already placed.
    int rows = static_cast<int>((members.size() + static_cast<size_t>(width) - 1) / static_cast<size_t>(width));
    if (layer == deepest + 1) {
      for (const DBlock& b : blocks) {
        if (b.row >= row && place_of(b) != Place::kOutput) row = b.row + 1;
      }
    }
    // Each block's wish: the mean column of its inputs (textual order for
    // those with none), so wires run down rather than across.
    std::vector<std::pair<double, size_t>> order;
    for (size_t k = 0; k < members.size(); ++k) {
      const size_t i = members[k];
      double sum = 0;
      int count = 0;
      for (const DArg& a : blocks[i].args) {
        if (!is_value_ref(a)) continue;
        auto it = def.find(a.text);
        if (it != def.end() && blocks[it->second].col >= 0) {
          sum += blocks[it->second].col;
          ++count;
        }
      }
      order.push_back({count > 0 ? sum / count : static_cast<double>(k), i});
    }
    std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [wish, i] : order) {
      DBlock& b = blocks[i];
      if (b.col >= 0 && b.row >= 0) continue;  // kept where it was
      const int want = std::max(0, static_cast<int>(std::lround(wish)));
      bool placed = false;
      // Within the grid's width first, from the wished column, row by row;
      // then past the width (the sheet grows to the right).
      for (int pass = 0; pass < 2 && !placed; ++pass) {
        for (int r = row; r < row + rows && !placed; ++r) {
          const int from = pass == 0 ? std::min(want, width - 1) : width;
          for (int c = from; !placed && (pass == 1 || c < width); ++c) {
            if (taken.insert({c, r}).second) {
              b.col = c;
              b.row = r;
              placed = true;
            }
          }
          for (int c = 0; pass == 0 && !placed && c < std::min(want, width - 1); ++c) {
            if (taken.insert({c, r}).second) {
              b.col = c;
              b.row = r;
              placed = true;
            }
          }
        }
      }
    }
    row += rows;
  }
}

json arg_json(const DArg& a) {
  switch (a.kind) {
    case DArg::Kind::kRef:
      return {{"ref", a.text}};
    case DArg::Kind::kNumber:
      return {{"number", a.number}};
    case DArg::Kind::kDevice:
      return {{"device", a.text}};
    case DArg::Kind::kString:
      return {{"string", a.text}};
  }
  return nullptr;
}

json blocks_json(const std::vector<DBlock>& blocks, json& wires, const std::string& macro) {
  const auto def = definitions(blocks);
  json out = json::array();
  for (size_t i = 0; i < blocks.size(); ++i) {
    const DBlock& b = blocks[i];
    json args = json::array();
    for (const DArg& a : b.args) args.push_back(arg_json(a));
    json j = {{"id", b.id.empty() ? json(nullptr) : json(b.id)},
              {"kind", b.kind},
              {"macro", b.macro},
              {"args", args},
              {"col", b.col},
              {"row", b.row},
              {"order", i + 1}};
    const BlockSpec* s = b.macro ? nullptr : find_block(b.kind);
    j["group"] = b.macro ? "macro" : s ? group_name(s->group) : "unknown";
    json label = nullptr, device = nullptr;
    std::string dev;
    for (const DArg& a : b.args) {
      if (a.kind == DArg::Kind::kString) label = a.text;
      if (a.kind == DArg::Kind::kDevice) dev += (dev.empty() ? "" : ".") + a.text;
    }
    if (!dev.empty()) device = dev;
    j["label"] = label;
    j["device"] = device;
    out.push_back(std::move(j));
    for (size_t k = 0; k < b.args.size(); ++k) {
      if (!is_value_ref(b.args[k])) continue;
      auto it = def.find(b.args[k].text);
      const bool known = it != def.end();
      wires.push_back({{"from", b.args[k].text},
                       {"from_block", known ? json(it->second) : json(nullptr)},
                       {"to_block", i},
                       {"arg", k},
                       {"feedback", known && it->second >= i},
                       {"macro", macro}});
    }
  }
  return out;
}

bool is_name(const std::string& s) {
  if (s.empty() || s.size() > 64 || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

bool is_ref_text(const std::string& s, const char* letters) {
  return s.size() >= 2 && s.size() <= 11 && std::strchr(letters, s[0]) != nullptr &&
         std::all_of(s.begin() + 1, s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

Result<DBlock> block_from_json(const json& j, const std::string& where) {
  if (!j.is_object()) return make_error(where + ": not an object");
  DBlock b;
  if (j.contains("id") && !j["id"].is_null()) {
    if (!j["id"].is_string() || !is_ref_text(j["id"].get<std::string>(), "FDMN"))
      return make_error(where + ": id must be F<n>, D<n> (M<n>, N<n> in a macro) or null");
    b.id = j["id"].get<std::string>();
  }
  if (!j.contains("kind") || !j["kind"].is_string() || !is_name(j["kind"].get<std::string>()))
    return make_error(where + ": kind must be a block or macro name");
  b.kind = j["kind"].get<std::string>();
  b.macro = j.value("macro", false);
  if (j.contains("col") && j["col"].is_number_integer()) b.col = std::clamp(j["col"].get<int>(), -1, 100000);
  if (j.contains("row") && j["row"].is_number_integer()) b.row = std::clamp(j["row"].get<int>(), -1, 100000);
  if (!j.contains("args") || !j["args"].is_array()) return make_error(where + ": args must be a list");
  for (size_t k = 0; k < j["args"].size(); ++k) {
    const json& a = j["args"][k];
    const std::string at = where + ": argument " + std::to_string(k + 1);
    DArg d;
    if (a.is_object() && a.contains("ref") && a["ref"].is_string()) {
      d.kind = DArg::Kind::kRef;
      d.text = a["ref"].get<std::string>();
      if (!is_ref_text(d.text, "FDMNP")) return make_error(at + ": a reference is F<n>, D<n>, M<n>, N<n> or P<n>");
    } else if (a.is_object() && a.contains("number") && a["number"].is_number()) {
      d.kind = DArg::Kind::kNumber;
      d.number = a["number"].get<double>();
      if (!std::isfinite(d.number)) return make_error(at + ": not a finite number");
    } else if (a.is_object() && a.contains("device") && a["device"].is_string()) {
      d.kind = DArg::Kind::kDevice;
      d.text = a["device"].get<std::string>();
      if (!is_ref_text(d.text, "pdc")) return make_error(at + ": a device address part is p<n>, d<n> or c<n>");
    } else if (a.is_object() && a.contains("string") && a["string"].is_string()) {
      d.kind = DArg::Kind::kString;
      d.text = a["string"].get<std::string>();
      if (d.text.size() > 64 || std::any_of(d.text.begin(), d.text.end(), [](char c) {
            return c == '"' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
          }))
        return make_error(at + ": a label is at most 64 characters, without quotes or control characters");
    } else {
      return make_error(at + ": must be {\"ref\"}, {\"number\"}, {\"device\"} or {\"string\"}");
    }
    b.args.push_back(std::move(d));
  }
  return b;
}

std::string layout_key(const DBlock& b, size_t index) {
  if (!b.id.empty()) return b.id;
  for (const DArg& a : b.args) {
    if (a.kind == DArg::Kind::kString) return "out:" + a.text;
  }
  return "#" + std::to_string(index);
}

void write_call(const DBlock& b, std::string& out, uint32_t line, std::vector<TextSpan>* spans,
                const std::string& macro, size_t index) {
  TextSpan span{macro, index, line, {}};
  std::string s;
  if (!b.id.empty()) s += b.id + " = ";
  if (b.macro) s += "MACRO ";
  s += b.kind + "(";
  for (size_t k = 0; k < b.args.size(); ++k) {
    if (k) s += ", ";
    span.arg_cols.push_back(static_cast<uint32_t>(s.size() + 1));
    const DArg& a = b.args[k];
    switch (a.kind) {
      case DArg::Kind::kNumber:
        s += number_text(a.number);
        break;
      case DArg::Kind::kString:
        s += "\"" + a.text + "\"";
        break;
      default:
        s += a.text;
    }
  }
  s += ")";
  out += s + "\n";
  if (spans) spans->push_back(std::move(span));
}

}  // namespace

Result<Diagram> from_text(std::string_view text, DiagnosticList* diags) {
  DiagnosticList local;
  DiagnosticList& dl = diags ? *diags : local;
  const auto tokens = lang::tokenize(text, dl);
  const lang::Program p = lang::parse(tokens, dl);
  if (dl.has_errors()) {
    const Diagnostic* first = nullptr;
    for (const Diagnostic& x : dl.items()) {
      if (x.severity == Severity::kError) {
        first = &x;
        break;
      }
    }
    return make_error(first ? std::to_string(first->pos.line) + ":" + std::to_string(first->pos.col) + ": " + first->message
                            : "the text does not parse");
  }
  Diagram d;
  if (p.has_stime) d.period_s = p.stime;
  for (const lang::Call& c : p.body) d.blocks.push_back(from_ast(c));
  auto macro = [&](const std::string& name) -> DMacro& {
    for (DMacro& m : d.macros) {
      if (m.name == name) return m;
    }
    d.macros.push_back(DMacro{});
    d.macros.back().name = name;
    return d.macros.back();
  };
  for (const lang::MacroDecl& m : p.decls) {
    DMacro& x = macro(m.name);
    x.declared = true;
    x.n_analog = m.n_analog;
    x.n_digital = m.n_digital;
    x.n_params = m.n_params;
  }
  for (const lang::MacroDef& m : p.defs) {
    DMacro& x = macro(m.name);
    x.defined = true;
    for (const lang::Ref& f : m.formals) x.formals.push_back(f.text());
    for (const lang::Call& c : m.body) x.blocks.push_back(from_ast(c));
    if (m.has_return) x.ret = m.ret.text();
  }
  return d;
}

std::string to_text(const Diagram& d, std::vector<TextSpan>* spans) {
  std::string out;
  uint32_t line = 0;
  auto put = [&](const std::string& s) {
    out += s + "\n";
    ++line;
  };
  for (const DMacro& m : d.macros) {
    if (m.declared)
      put("MACRO " + m.name + "(" + std::to_string(m.n_analog) + "|" + std::to_string(m.n_digital) + "|" +
          std::to_string(m.n_params) + ")");
  }
  put("%%");
  if (d.period_s) put("stime(" + number_text(*d.period_s) + ")");
  for (size_t i = 0; i < d.blocks.size(); ++i) write_call(d.blocks[i], out, ++line, spans, "", i);
  put("END");
  bool defs = false;
  for (const DMacro& m : d.macros) {
    if (!m.defined) continue;
    if (!defs) put("%%");
    defs = true;
    std::string formals;
    for (const std::string& f : m.formals) formals += (formals.empty() ? "" : ", ") + f;
    put("MACRO " + m.name + "(" + formals + ")");
    put("{");
    for (size_t i = 0; i < m.blocks.size(); ++i) write_call(m.blocks[i], out, ++line, spans, m.name, i);
    if (!m.ret.empty()) put("RETURN(" + m.ret + ")");
    put("}");
  }
  return out;
}

void auto_layout(Diagram& d) {
  const int width = std::max(1, d.cols);
  layout_blocks(d.blocks, width, 0);
  // Inside a macro its formals are the inputs: row 0 is left for them.
  for (DMacro& m : d.macros) layout_blocks(m.blocks, width, 1);
}

nlohmann::json layout_json(const Diagram& d) {
  json cells = json::object();
  for (size_t i = 0; i < d.blocks.size(); ++i) {
    if (d.blocks[i].col >= 0) cells[layout_key(d.blocks[i], i)] = {d.blocks[i].col, d.blocks[i].row};
  }
  for (const DMacro& m : d.macros) {
    for (size_t i = 0; i < m.blocks.size(); ++i) {
      if (m.blocks[i].col >= 0) cells[m.name + "/" + layout_key(m.blocks[i], i)] = {m.blocks[i].col, m.blocks[i].row};
    }
  }
  return {{"format", "rtplc-fbd-layout"}, {"version", 1}, {"grid", {{"cols", d.cols}, {"rows", d.rows}}}, {"cells", cells}};
}

Result<void> apply_layout(Diagram& d, const nlohmann::json& layout) {
  if (!layout.is_object() || layout.value("format", "") != "rtplc-fbd-layout")
    return make_error("not a layout file (its format is not rtplc-fbd-layout)");
  if (layout.value("version", 0) != 1) return make_error("layout version " + layout.value("version", json(0)).dump() + " is not 1");
  if (layout.contains("grid") && layout["grid"].is_object()) {
    d.cols = std::clamp(layout["grid"].value("cols", 7), 1, 64);
    d.rows = std::clamp(layout["grid"].value("rows", 5), 1, 64);
  }
  if (!layout.contains("cells") || !layout["cells"].is_object()) return {};
  const json& cells = layout["cells"];
  auto cell = [&](const std::string& key, DBlock& b) {
    auto it = cells.find(key);
    if (it == cells.end() || !it->is_array() || it->size() != 2 || !(*it)[0].is_number_integer() ||
        !(*it)[1].is_number_integer())
      return;
    b.col = std::clamp((*it)[0].get<int>(), 0, 100000);
    b.row = std::clamp((*it)[1].get<int>(), 0, 100000);
  };
  for (size_t i = 0; i < d.blocks.size(); ++i) cell(layout_key(d.blocks[i], i), d.blocks[i]);
  for (DMacro& m : d.macros) {
    for (size_t i = 0; i < m.blocks.size(); ++i) cell(m.name + "/" + layout_key(m.blocks[i], i), m.blocks[i]);
  }
  return {};
}

nlohmann::json diagram_json(const Diagram& d) {
  json wires = json::array();
  json blocks = blocks_json(d.blocks, wires, "");
  int cols = d.cols, rows = d.rows;
  for (const DBlock& b : d.blocks) {
    cols = std::max(cols, b.col + 1);
    rows = std::max(rows, b.row + 1);
  }
  json macros = json::array();
  for (const DMacro& m : d.macros) {
    json mw = json::array();
    json mb = blocks_json(m.blocks, mw, m.name);
    macros.push_back({{"name", m.name},
                      {"declared", m.declared},
                      {"analog", m.n_analog},
                      {"digital", m.n_digital},
                      {"params", m.n_params},
                      {"defined", m.defined},
                      {"formals", m.formals},
                      {"return", m.ret.empty() ? json(nullptr) : json(m.ret)},
                      {"blocks", mb},
                      {"wires", mw}});
  }
  return {{"format", "rtplc-fbd"},
          {"version", 1},
          {"grid", {{"cols", d.cols}, {"rows", d.rows}}},
          {"sheet", {{"cols", cols}, {"rows", rows}}},
          {"period_s", d.period_s ? json(*d.period_s) : json(nullptr)},
          {"blocks", blocks},
          {"wires", wires},
          {"macros", macros}};
}

static Result<Diagram> read_diagram(const nlohmann::json& j) {
  if (!j.is_object()) return make_error("the diagram must be an object");
  Diagram d;
  if (j.contains("grid") && j["grid"].is_object()) {
    d.cols = std::clamp(j["grid"].value("cols", 7), 1, 64);
    d.rows = std::clamp(j["grid"].value("rows", 5), 1, 64);
  }
  if (j.contains("period_s") && !j["period_s"].is_null()) {
    if (!j["period_s"].is_number() || !std::isfinite(j["period_s"].get<double>()))
      return make_error("period_s must be a number of seconds or null");
    d.period_s = j["period_s"].get<double>();
  }
  if (!j.contains("blocks") || !j["blocks"].is_array()) return make_error("the diagram has no blocks list");
  if (j["blocks"].size() > 100000) return make_error("too many blocks");
  for (size_t i = 0; i < j["blocks"].size(); ++i) {
    auto b = block_from_json(j["blocks"][i], "block " + std::to_string(i + 1));
    if (!b) return make_error(b.error());
    d.blocks.push_back(std::move(b).value());
  }
  if (j.contains("macros") && j["macros"].is_array()) {
    for (const json& m : j["macros"]) {
      if (!m.is_object() || !m.contains("name") || !m["name"].is_string() || !is_name(m["name"].get<std::string>()))
        return make_error("a macro needs a name");
      DMacro x;
      x.name = m["name"].get<std::string>();
      x.declared = m.value("declared", false);
      x.defined = m.value("defined", false);
      x.n_analog = std::min<uint32_t>(m.value("analog", 0u), 99);
      x.n_digital = std::min<uint32_t>(m.value("digital", 0u), 99);
      x.n_params = std::min<uint32_t>(m.value("params", 0u), 99);
      if (m.contains("formals") && m["formals"].is_array()) {
        for (const json& f : m["formals"]) {
          if (!f.is_string() || !is_ref_text(f.get<std::string>(), "MNP"))
            return make_error("macro " + x.name + ": a formal is M<n>, N<n> or P<n>");
          x.formals.push_back(f.get<std::string>());
        }
      }
      if (m.contains("return") && m["return"].is_string()) {
        x.ret = m["return"].get<std::string>();
        if (!is_ref_text(x.ret, "MN")) return make_error("macro " + x.name + ": RETURN takes M<n> or N<n>");
      }
      if (m.contains("blocks") && m["blocks"].is_array()) {
        for (size_t i = 0; i < m["blocks"].size(); ++i) {
          auto b = block_from_json(m["blocks"][i], "macro " + x.name + " block " + std::to_string(i + 1));
          if (!b) return make_error(b.error());
          x.blocks.push_back(std::move(b).value());
        }
      }
      d.macros.push_back(std::move(x));
    }
  }
  return d;
}

Result<Diagram> diagram_from_json(const nlohmann::json& j) {
  try {
    return read_diagram(j);
  } catch (const json::exception& e) {
    return make_error(std::string("the diagram is malformed: ") + e.what());
  }
}

CheckResult check(const Diagram& d, const std::string& file_name) {
  CheckResult r;
  std::vector<TextSpan> spans;
  r.text = to_text(d, &spans);
  lang::CompileResult c = lang::compile_source(r.text);
  r.ok = c.ok();
  r.rendered = c.diags.render(file_name, r.text);
  if (c.ok()) r.identity = image_identity(*c.image);
  for (const Diagnostic& x : c.diags.items()) {
    BlockDiagnostic b;
    b.diag = x;
    for (const TextSpan& s : spans) {
      if (s.line != x.pos.line) continue;
      b.macro = s.macro;
      b.block = s.block;
      for (size_t k = 0; k < s.arg_cols.size(); ++k) {
        if (s.arg_cols[k] <= x.pos.col) b.arg = k;
      }
      break;
    }
    r.diagnostics.push_back(std::move(b));
  }
  return r;
}

namespace {
json diag_json(const Diagnostic& x) {
  return {{"severity", x.severity == Severity::kError ? "error" : x.severity == Severity::kWarning ? "warning" : "note"},
          {"message", x.message},
          {"line", x.pos.line},
          {"col", x.pos.col}};
}
}  // namespace

nlohmann::json check_json(const CheckResult& r) {
  json diags = json::array();
  for (const BlockDiagnostic& b : r.diagnostics) {
    json j = diag_json(b.diag);
    j["macro"] = b.macro.empty() ? json(nullptr) : json(b.macro);
    j["block"] = b.block ? json(*b.block) : json(nullptr);
    j["arg"] = b.arg ? json(*b.arg) : json(nullptr);
    diags.push_back(std::move(j));
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(r.identity));
  // The hash the runtime shows for this text once it runs (rtplc status,
  // the program store): FNV-1a 64 over the source text.
  char ph[17];
  std::snprintf(ph, sizeof ph, "%016llx", static_cast<unsigned long long>(fnv1a64(r.text)));
  return {{"compiles", r.ok},
          {"text", r.text},
          {"program_hash", ph},
          {"rendered", r.rendered},
          {"identity", r.ok ? json(hex) : json(nullptr)},
          {"diagnostics", diags}};
}

nlohmann::json diagnostics_json(const DiagnosticList& diags) {
  json out = json::array();
  for (const Diagnostic& x : diags.items()) out.push_back(diag_json(x));
  return out;
}

uint64_t image_identity(const TaskImage& image) {
  std::string bytes(reinterpret_cast<const char*>(image.bytes().data()), image.bytes().size());
  ImageHeader h;
  std::memcpy(&h, bytes.data(), sizeof h);
  h.source_hash = 0;
  h.body_check = 0;
  std::memcpy(bytes.data(), &h, sizeof h);
  for (uint32_t i = 0; i < h.n_instr; ++i) {
    const size_t at = h.off_blocks + i * sizeof(BlockInfo);
    BlockInfo b;
    std::memcpy(&b, bytes.data() + at, sizeof b);
    b.line = b.col = b.call_line = 0;
    std::memcpy(bytes.data() + at, &b, sizeof b);
  }
  for (uint32_t i = 0; i < h.n_bindings; ++i) {
    const size_t at = h.off_bindings + i * sizeof(Binding);
    Binding b;
    std::memcpy(&b, bytes.data() + at, sizeof b);
    b.line = 0;
    std::memcpy(bytes.data() + at, &b, sizeof b);
  }
  return fnv1a64(bytes);
}

}  // namespace rtplc::editor
