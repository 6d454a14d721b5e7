// PNML reader and writer for P/T nets (see pnml.h; issue item 3).
#include "lang/petri/pnml.h"

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "common/xml_reader.h"

namespace rtplc::petri {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() &&
         (s.front() == ' ' || s.front() == '\n' || s.front() == '\t' || s.front() == '\r'))
    s.remove_prefix(1);
  while (!s.empty() &&
         (s.back() == ' ' || s.back() == '\n' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

// The text of <label><text>...</text></label>, if present.
const XmlElement* label_text(const XmlElement& e, std::string_view label) {
  const XmlElement* l = e.child(label);
  return l ? l->child("text") : nullptr;
}

std::optional<uint32_t> parse_count(std::string_view s) {
  s = trim(s);
  if (s.empty() || s.size() > 10) return std::nullopt;
  uint64_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return std::nullopt;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  if (v > UINT32_MAX) return std::nullopt;
  return static_cast<uint32_t>(v);
}

// What other net types are called, so a refusal can name the kind of net.
std::string describe_type(std::string_view type) {
  const size_t slash = type.rfind('/');
  const std::string_view last = slash == std::string_view::npos ? type : type.substr(slash + 1);
  if (last == "symmetricnet") return "a symmetric net (coloured)";
  if (last == "highlevelnet") return "a high-level Petri net graph (coloured)";
  if (last == "pt-hlpng") return "a P/T net in high-level notation";
  if (last == "ptnet") return "a P/T net of another PNML version";
  return "an unknown net type";
}

struct PendingArc {
  const XmlElement* element;
};

class PnmlReader {
 public:
  explicit PnmlReader(DiagnosticList& diags) : diags_(diags) {}

  std::optional<Net> read(const XmlElement& root) {
    if (root.name != "pnml") {
      diags_.error(root.pos, "the root element is <" + root.name + ">, not <pnml>");
      return std::nullopt;
    }
    const XmlElement* net_el = nullptr;
    size_t nets = 0;
    for (const XmlElement& c : root.children) {
      if (c.name != "net") continue;
      if (!net_el) net_el = &c;
      ++nets;
    }
    if (!net_el) {
      diags_.error(root.pos, "the document has no <net>");
      return std::nullopt;
    }
    if (nets > 1)
      diags_.warning(net_el->pos,
                     "the document has " + std::to_string(nets) + " nets; only the first is read");
    const XmlAttribute* type = net_el->attribute("type");
    if (!type) {
      diags_.error(net_el->pos, "<net> has no type attribute");
      return std::nullopt;
    }
    if (trim(type->value) != kPtNetType) {
      diags_.error(type->pos, "net type '" + type->value + "' is " + describe_type(type->value) +
                                  "; only P/T nets (" + std::string(kPtNetType) +
                                  ") are supported");
      return std::nullopt;
    }
    std::string name;
    if (const XmlElement* t = label_text(*net_el, "name")) name = std::string(trim(t->text));
    if (name.empty()) {
      if (const XmlAttribute* id = net_el->attribute("id")) name = id->value;
    }
    net_ = Net(name.empty() ? "net" : name);
    collect(*net_el, 0);
    resolve_references();
    for (const PendingArc& a : arcs_) arc(*a.element);
    if (diags_.has_errors()) return std::nullopt;
    return std::move(net_);
  }

 private:
  const XmlAttribute* need_id(const XmlElement& e) {
    const XmlAttribute* id = e.attribute("id");
    if (!id || id->value.empty()) {
      diags_.error(e.pos, "<" + e.name + "> has no id");
      return nullptr;
    }
    return id;
  }

  // Walks the net and its pages (nested to any depth) in document order.
  void collect(const XmlElement& e, size_t depth) {
    for (const XmlElement& c : e.children) {
      if (c.name == "page") {
        collect(c, depth + 1);
      } else if (c.name == "place") {
        place(c);
      } else if (c.name == "transition") {
        transition(c);
      } else if (c.name == "arc") {
        arcs_.push_back({&c});
      } else if (c.name == "referencePlace" || c.name == "referenceTransition") {
        const XmlAttribute* id = need_id(c);
        const XmlAttribute* ref = c.attribute("ref");
        if (!id) continue;
        if (!ref) {
          diags_.error(c.pos, "<" + c.name + "> has no ref");
          continue;
        }
        if (!claim(*id)) continue;
        references_[id->value] = Reference{ref, c.name == "referencePlace"};
      }
      // name, graphics, toolspecific and unknown labels: nothing to read
    }
  }

  bool claim(const XmlAttribute& id) {
    if (!ids_.emplace(id.value, id.pos).second) {
      diags_.error(id.pos, "the id '" + id.value + "' is used twice");
      return false;
    }
    return true;
  }

  void place(const XmlElement& e) {
    const XmlAttribute* id = need_id(e);
    if (!id || !claim(*id)) return;
    uint32_t tokens = 0;
    if (const XmlElement* t = label_text(e, "initialMarking")) {
      auto v = parse_count(t->text);
      if (!v) {
        diags_.error(t->pos, "initial marking '" + std::string(trim(t->text)) +
                                 "' is not a token count (0 to 4294967295)");
      } else {
        tokens = *v;
      }
    }
    std::string label;
    if (const XmlElement* t = label_text(e, "name")) label = std::string(trim(t->text));
    auto p = net_.add_place(id->value, tokens, label == id->value ? "" : label);
    if (!p) diags_.error(id->pos, p.error());
  }

  void transition(const XmlElement& e) {
    const XmlAttribute* id = need_id(e);
    if (!id || !claim(*id)) return;
    std::string label;
    if (const XmlElement* t = label_text(e, "name")) label = std::string(trim(t->text));
    auto t = net_.add_transition(id->value, label == id->value ? "" : label);
    if (!t) diags_.error(id->pos, t.error());
  }

  struct Reference {
    const XmlAttribute* ref;
    bool is_place;
  };
  struct Node {
    bool is_place = false;
    uint32_t index = 0;
  };

  // Reference nodes may name other reference nodes; follow the chain, refusing cycles.
  void resolve_references() {
    for (const auto& [id, r] : references_) {
      const XmlAttribute* ref = r.ref;
      size_t hops = 0;
      for (;;) {
        if (auto p = net_.find_place(ref->value)) {
          if (!r.is_place)
            diags_.error(ref->pos,
                         "referenceTransition '" + id + "' names place '" + ref->value + "'");
          else
            resolved_[id] = Node{true, *p};
          break;
        }
        if (auto t = net_.find_transition(ref->value)) {
          if (r.is_place)
            diags_.error(ref->pos,
                         "referencePlace '" + id + "' names transition '" + ref->value + "'");
          else
            resolved_[id] = Node{false, *t};
          break;
        }
        auto next = references_.find(ref->value);
        if (next == references_.end()) {
          diags_.error(ref->pos, "reference '" + id + "' names '" + ref->value +
                                     "', which is not in the net");
          break;
        }
        if (++hops > references_.size()) {
          diags_.error(ref->pos, "reference '" + id + "' is part of a cycle of references");
          break;
        }
        ref = next->second.ref;
      }
    }
  }

  std::optional<Node> node(const XmlAttribute& a) {
    if (auto p = net_.find_place(a.value)) return Node{true, *p};
    if (auto t = net_.find_transition(a.value)) return Node{false, *t};
    auto r = resolved_.find(a.value);
    if (r != resolved_.end()) return r->second;
    if (!references_.count(a.value))
      diags_.error(a.pos, "arc end '" + a.value + "' is not a place or transition of the net");
    return std::nullopt;
  }

  void arc(const XmlElement& e) {
    const XmlAttribute* id = need_id(e);
    if (!id || !claim(*id)) return;
    const XmlAttribute* src = e.attribute("source");
    const XmlAttribute* dst = e.attribute("target");
    if (!src || !dst) {
      diags_.error(e.pos, "arc '" + id->value + "' needs a source and a target");
      return;
    }
    uint32_t weight = 1;
    if (const XmlElement* t = label_text(e, "inscription")) {
      auto v = parse_count(t->text);
      if (!v || *v == 0) {
        diags_.error(t->pos, "arc inscription '" + std::string(trim(t->text)) +
                                 "' is not a positive integer");
        return;
      }
      weight = *v;
    }
    if (const XmlElement* ty = e.child("type")) {
      const XmlAttribute* v = ty->attribute("value");
      if (v && v->value != "normal") {
        diags_.error(v->pos, "arc type '" + v->value + "' is not part of P/T nets");
        return;
      }
    }
    auto s = node(*src);
    auto d = node(*dst);
    if (!s || !d) return;
    if (s->is_place == d->is_place) {
      diags_.error(e.pos,
                   "arc '" + id->value + "' joins two " + (s->is_place ? "places" : "transitions"));
      return;
    }
    if (s->is_place)
      net_.add_input(s->index, d->index, weight);
    else
      net_.add_output(s->index, d->index, weight);
  }

  DiagnosticList& diags_;
  Net net_;
  std::vector<PendingArc> arcs_;
  std::unordered_map<std::string, SourcePos> ids_;
  std::unordered_map<std::string, Reference> references_;
  std::unordered_map<std::string, Node> resolved_;
};

std::string xml_id(std::string_view s) {
  std::string out;
  for (char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-' || c == '.';
    out += ok ? c : '_';
  }
  if (out.empty() || (out[0] >= '0' && out[0] <= '9') || out[0] == '-' || out[0] == '.')
    out = "n" + out;
  return out;
}

}  // namespace

PnmlReadResult read_pnml(std::string_view text) {
  PnmlReadResult r;
  std::optional<XmlElement> root = parse_xml(text, r.diags);
  if (!root) return r;
  PnmlReader reader(r.diags);
  r.net = reader.read(*root);
  return r;
}

std::string write_pnml(const Net& net) {
  std::string o;
  o += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  o += "<pnml xmlns=\"http://www.pnml.org/version-2009/grammar/pnml\">\n";
  o += "  <net id=\"" + xml_id(net.name()) + "\" type=\"" + std::string(kPtNetType) + "\">\n";
  o += "    <name><text>" + xml_escape(net.name()) + "</text></name>\n";
  o += "    <page id=\"page0\">\n";
  for (PlaceId p = 0; p < net.place_count(); ++p) {
    const Place& pl = net.place(p);
    o += "      <place id=\"" + xml_escape(pl.id) + "\">";
    o += "<name><text>" + xml_escape(net.place_label(p)) + "</text></name>";
    if (pl.initial)
      o += "<initialMarking><text>" + std::to_string(pl.initial) + "</text></initialMarking>";
    o += "</place>\n";
  }
  for (TransitionId t = 0; t < net.transition_count(); ++t) {
    o += "      <transition id=\"" + xml_escape(net.transition(t).id) + "\">";
    o += "<name><text>" + xml_escape(net.transition_label(t)) + "</text></name></transition>\n";
  }
  size_t n = 0;
  auto arc = [&](const std::string& from, const std::string& to, uint32_t w) {
    o += "      <arc id=\"arc" + std::to_string(n++) + "\" source=\"" + xml_escape(from) +
         "\" target=\"" + xml_escape(to) + "\">";
    if (w != 1) o += "<inscription><text>" + std::to_string(w) + "</text></inscription>";
    o += "</arc>\n";
  };
  for (TransitionId t = 0; t < net.transition_count(); ++t) {
    for (const ArcEnd& e : net.inputs(t))
      arc(net.place(e.place).id, net.transition(t).id, e.weight);
    for (const ArcEnd& e : net.outputs(t))
      arc(net.transition(t).id, net.place(e.place).id, e.weight);
  }
  o += "    </page>\n  </net>\n</pnml>\n";
  return o;
}

}  // namespace rtplc::petri
