// FBD and LD bodies -> blocks (docs/plcopen.md, "FBD and LD"). Both are graphs
// of elements joined by `connection refLocalId`. Assignments run in the
// editors' order (execution_order()); each element is lowered once, after
// everything it reads through connections; an element reached again while it
// is being lowered closes a feedback loop: that reference reads the previous
// cycle's value (the one-cycle rule) and is listed by `check --explain`. A
// variable read sees the assignments to it that ran before.
#include "lang/plcopen/graph.h"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "lang/plcopen/lowering.h"

namespace rtplc::lang::plcopen {
namespace {

std::string trim(std::string s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// The first identifier of a target expression ("fb1.IN" -> "FB1").
std::string target_name(const std::string& text) {
  std::string t = trim(text);
  size_t e = t.empty() || t[0] != '%' ? 0 : 1;  // %QX0.0: the whole address
  while (e < t.size() && (std::isalnum(static_cast<unsigned char>(t[e])) || t[e] == '_' || (t[0] == '%' && t[e] == '.'))) ++e;
  return upper(t.substr(0, e));
}

const char* const kSfcElements[] = {"step", "transition", "selectionDivergence", "selectionConvergence",
                                    "simultaneousDivergence", "simultaneousConvergence", "jumpStep",
                                    "macroStep", "actionBlock"};

class Graph {
 public:
  // `in_sfc`: the FBD and LD elements drawn in an SFC body; its SFC elements
  // are the chart's (sfc.cpp) and are skipped here.
  Graph(Lowering& L, Scope& s, const XmlElement& body, bool ladder, bool in_sfc = false)
      : L_(L), s_(s), body_(body), ladder_(ladder), in_sfc_(in_sfc), d_(L.diags()) {}

  // A transition body: an outVariable or coil that names `name` assigns no
  // variable; its value is the transition's (result()).
  void set_result_name(const std::string& name) {
    result_as_written_ = name;
    result_name_ = upper(name);
  }

  void run() {
    for (const XmlElement& e : body_.children) {
      if (e.name == "addData" || e.name == "documentation" || e.name == "comment" || e.name == "error")
        continue;
      bool sfc_element = false;
      for (const char* n : kSfcElements) sfc_element = sfc_element || e.name == n;
      if (sfc_element && in_sfc_) continue;
      for (const char* n : kSfcElements) {
        if (e.name == n) {
          d_.error(e.pos, "<" + e.name + "> in an " + lang() + " body: SFC elements in PLCopen XML are not supported yet");
          return;
        }
      }
      if (e.name == "vendorElement") {
        d_.error(e.pos, "<vendorElement> is vendor-specific and not supported");
        return;
      }
      static const char* const kKnown[] = {"block", "inVariable", "outVariable", "inOutVariable", "connector",
                                           "continuation", "contact", "coil", "leftPowerRail", "rightPowerRail"};
      bool known = false;
      for (const char* k : kKnown) known = known || e.name == k;
      if (!known) {
        d_.error(e.pos, "<" + e.name + "> is not supported in an " + lang() + " body");
        return;
      }
      if (!ladder_ && (e.name == "contact" || e.name == "coil" || e.name == "leftPowerRail" || e.name == "rightPowerRail")) {
        // Mixed FBD/LD graphs occur (Beremiz); accepted.
      }
      const std::string id = attr(e, "localId");
      if (id.empty()) {
        d_.error(e.pos, "<" + e.name + "> without a localId");
        return;
      }
      if (!elems_.emplace(id, &e).second) {
        d_.error(e.pos, "localId " + id + " is used twice in this body");
        return;
      }
      order_.push_back(id);
      if (e.name == "connector") connectors_[upper(attr(e, "name"))] = id;
      if (e.name == "outVariable" || e.name == "inOutVariable") {
        if (const XmlElement* x = e.child("expression")) writers_[target_name(x->text)].push_back(id);
      } else if (e.name == "coil") {
        if (const XmlElement* x = e.child("variable")) writers_[target_name(x->text)].push_back(id);
      }
    }
    auto saved = L_.before_read;
    L_.before_read = [this](const std::string& name) { lower_writers(name); };
    for (const std::string& id : execution_order()) {
      if (d_.has_errors()) break;
      lower(id);
    }
    L_.before_read = saved;
  }

  // After run(): the value flowing into `cpin`, a connection point of an
  // element outside the graph (an SFC transition's condition).
  Value value_into(const XmlElement& cpin) { return input(&cpin); }

  // After run() with a result name: the value of the one outVariable or coil
  // naming it; without one, in LD, what reaches the right power rail (the
  // OR of its rungs). Invalid, with the reason in the diagnostics, otherwise.
  Value result(const std::string& what, SourcePos pos) {
    if (results_.size() > 1) {
      d_.error(elems_[results_[1].first]->pos, what + " is written twice in its body (localId " +
                                                   results_[0].first + " and " + results_[1].first + ")");
      return {};
    }
    if (results_.size() == 1) return results_[0].second;
    const XmlElement* rail = nullptr;
    int rails = 0;
    for (const std::string& id : order_) {
      if (elems_[id]->name == "rightPowerRail") {
        rail = elems_[id];
        ++rails;
      }
    }
    if (!ladder_ || rails != 1) {
      const std::string named = "named '" + result_as_written_ + "'";
      if (!ladder_)
        d_.error(pos, what + " has no outVariable " + named + " in its FBD body: that element gives its value");
      else if (result_name_.empty())
        d_.error(pos, what + " needs one right power rail in its LD body: what reaches it is its value");
      else
        d_.error(pos, what + " has no coil " + named + " and not one right power rail in its LD body: one of "
                      "them gives its value");
      return {};
    }
    Value r;
    for (const XmlElement& c : rail->children) {
      if (c.name != "connectionPointIn") continue;
      Value v = input(&c);
      if (!v.valid()) continue;
      v = L_.em().to_digital(v, c.pos);
      r = r.valid() ? L_.em().binary(BinOp::kOr, r, v, c.pos) : v;
    }
    if (!r.valid()) d_.error(rail->pos, what + ": nothing reaches the right power rail");
    return r;
  }

 private:
  std::string lang() const { return in_sfc_ ? "SFC" : ladder_ ? "LD" : "FBD"; }

  // An outVariable's expression or a coil's variable that is the result name.
  bool writes_result(const XmlElement& e, const char* child) const {
    const XmlElement* x = e.child(child);
    return !result_name_.empty() && x && upper(trim(x->text)) == result_name_;
  }

  // The order the editors' own runtimes run a body in (Beremiz and OpenPLC
  // generate one statement per assignment in this order; CODESYS exports
  // put every element at 0,0, which leaves document order): elements with
  // executionOrderId > 0 by that id; then assignments and coils, then blocks
  // no assignment reaches (FB calls whose outputs nobody reads), each top to
  // bottom (rows within 10 units of each other left to right); then the rest.
  // Each lowers what it reads on demand, so data flow through connections is
  // always respected.
  std::vector<std::string> execution_order() {
    struct Item {
      std::string id;
      double x = 0, y = 0;
    };
    std::vector<std::pair<long, std::string>> numbered;
    std::vector<Item> sinks, blocks;
    std::vector<std::string> rest;
    for (const std::string& id : order_) {
      const XmlElement& e = *elems_[id];
      const bool assigns = e.name == "outVariable" || e.name == "inOutVariable";
      const long eo = std::strtol(attr(e, "executionOrderId").c_str(), nullptr, 10);
      Item it{id};
      if (const XmlElement* p = e.child("position")) {
        it.x = std::strtod(attr(*p, "x").c_str(), nullptr);
        it.y = std::strtod(attr(*p, "y").c_str(), nullptr);
      }
      if (eo > 0 && (assigns || e.name == "block")) numbered.emplace_back(eo, id);
      else if (assigns || e.name == "coil") sinks.push_back(it);
      else if (e.name == "block") blocks.push_back(it);
      else rest.push_back(id);
    }
    std::stable_sort(numbered.begin(), numbered.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    auto by_rows = [](std::vector<Item>& v) {
      std::stable_sort(v.begin(), v.end(), [](const Item& a, const Item& b) { return a.y < b.y; });
      for (size_t b = 0; b < v.size();) {  // a row: within 10 units of its first element
        size_t e = b + 1;
        while (e < v.size() && v[e].y - v[b].y < 10) ++e;
        std::stable_sort(v.begin() + static_cast<std::ptrdiff_t>(b), v.begin() + static_cast<std::ptrdiff_t>(e),
                         [](const Item& p, const Item& q) { return p.x < q.x; });
        b = e;
      }
    };
    by_rows(sinks);
    by_rows(blocks);
    std::vector<std::string> out;
    for (const auto& [eo, id] : numbered) out.push_back(id);
    for (const Item& it : sinks) out.push_back(it.id);
    for (const Item& it : blocks) out.push_back(it.id);
    out.insert(out.end(), rest.begin(), rest.end());
    return out;
  }

  // A read of variable `name` sees what the elements before it in the
  // execution order wrote; a writer after it (or the one being lowered, a
  // loop) has not run yet: the read sees the value from before, last cycle's
  // when nothing earlier wrote it. `check --explain` lists each such read.
  void lower_writers(const std::string& name) {
    auto it = writers_.find(name);
    if (it == writers_.end()) return;
    for (const std::string& id : it->second) {
      if (state_[id] == 2) continue;
      if (reported_.insert(id + "@" + name).second)
        L_.note(s_.pou->name + " (" + lang() + "): '" + name + "' is read before localId " + id +
                " writes it" + (state_[id] == 1 ? " (a feedback loop)" : " (later in the execution order)") +
                ": that read sees the value from before, the previous cycle's unless an earlier element wrote it");
    }
  }

  Value output_of(const std::string& id, const std::string& param, SourcePos pos) {
    auto it = elems_.find(id);
    if (it == elems_.end()) {
      d_.error(pos, "connection to localId " + id + ", which is no element of this body");
      return constant(0, false);
    }
    if (state_[id] == 1) {
      // A feedback loop: read the previous cycle's value through an alias.
      const std::string alias = s_.path + ".fb" + id + (param.empty() ? "" : "." + param);
      bool digital = guess_digital(*it->second, param);
      if (aliases_.emplace(id + "|" + param, digital).second)
        L_.note(s_.pou->name + " (" + lang() + "): feedback loop through localId " + id + " (" +
                describe(*it->second) + "): the reference at line " + std::to_string(pos.line) +
                " reads its previous-cycle value");
      Value v;
      v.ref = alias;
      v.digital = aliases_[id + "|" + param];
      return v;
    }
    lower(id);
    auto& outs = values_[id];
    auto o = outs.find(upper(param));
    if (o == outs.end()) o = outs.find("");
    if (o == outs.end()) {
      d_.error(pos, "localId " + id + " (" + describe(*it->second) + ") has no output '" + param + "'");
      return constant(0, false);
    }
    return o->second;
  }

  static std::string describe(const XmlElement& e) {
    std::string n = attr(e, "typeName");
    if (n.empty()) {
      if (const XmlElement* x = e.child("expression")) n = trim(x->text);
      else if (const XmlElement* v = e.child("variable")) n = trim(v->text);
    }
    return e.name + (n.empty() ? "" : " " + n);
  }

  bool guess_digital(const XmlElement& e, const std::string& param) {
    if (e.name == "contact" || e.name == "coil" || e.name == "leftPowerRail") return true;
    const std::string p = upper(param);
    if (p == "Q" || p == "Q1" || p == "ENO" || p == "QU" || p == "QD") return true;
    if (e.name == "block") {
      const std::string t = upper(attr(e, "typeName"));
      return t == "GT" || t == "GE" || t == "LT" || t == "LE" || t == "EQ" || t == "NE" || t == "NOT" ||
             t == "AND" || t == "OR" || t == "XOR";
    }
    return false;
  }

  // The value flowing into a connectionPointIn: one connection (FBD), or the
  // OR of several (LD wired-or). Invalid when nothing is connected.
  Value input(const XmlElement* cpin) {
    Value r;
    if (!cpin) return r;
    bool first = true;
    for (const XmlElement& c : cpin->children) {
      if (c.name != "connection") continue;
      const std::string ref = attr(c, "refLocalId");
      if (ref.empty()) {
        d_.error(c.pos, "<connection> without refLocalId");
        return r;
      }
      Value v = output_of(ref, attr(c, "formalParameter"), c.pos);
      if (whole_elems_.count(ref)) {  // known once output_of lowered it
        d_.error(c.pos, "localId " + ref + " names a whole structure or array: connect it to a structure or array "
                        "input of a function block, or name one member");
        return r;
      }
      if (first) {
        r = v;
        first = false;
      } else {
        r = L_.em().binary(BinOp::kOr, L_.em().to_digital(r, c.pos), L_.em().to_digital(v, c.pos), c.pos);
      }
    }
    return r;
  }

  Value expression_value(const XmlElement& e, SourcePos pos) {
    const XmlElement* x = e.child("expression");
    if (!x) {
      d_.error(pos, "<" + e.name + "> without an <expression>");
      return constant(0, false);
    }
    auto ex = parse_st_expression(x->text, *x, d_);
    if (!ex) return constant(0, false);
    if (ex->kind == Expr::Kind::kName && ex->args.empty() && L_.whole_var(s_, ex->name)) {
      // A whole structure or array: only a structure or array input of a
      // function block takes it (connected_variable), never as a value.
      whole_elems_.insert(attr(e, "localId"));
      return constant(0, false);
    }
    return L_.eval(s_, *ex);
  }

  Var* target(const XmlElement& e, const char* child) {
    const XmlElement* x = e.child(child);
    if (!x) {
      d_.error(e.pos, "<" + e.name + "> without a <" + child + ">");
      return nullptr;
    }
    auto ex = parse_st_expression(x->text, *x, d_);
    if (!ex) return nullptr;
    if (ex->kind != Expr::Kind::kName) {
      d_.error(x->pos, "'" + trim(x->text) + "' is not a variable to assign");
      return nullptr;
    }
    return L_.resolve_static(s_, ex->name, ex->args, x->pos);
  }

  // The variable an in-out parameter (or, `whole`, a structure or array
  // input) is connected to: an inVariable or inOutVariable naming it.
  Var* connected_variable(const XmlElement& v, const std::string& type, bool whole) {
    const std::string formal = attr(v, "formalParameter");
    const XmlElement* cpin = v.child("connectionPointIn");
    const XmlElement* c = cpin ? cpin->child("connection") : nullptr;
    auto it = c ? elems_.find(attr(*c, "refLocalId")) : elems_.end();
    const XmlElement* src = it == elems_.end() ? nullptr : it->second;
    if (!src || (src->name != "inVariable" && src->name != "inOutVariable")) {
      d_.error(v.pos, "block " + type + ": " + (whole ? "structure or array input '" : "in-out parameter '") + formal +
                          "' must be connected to a variable (an inVariable or inOutVariable)");
      return nullptr;
    }
    const XmlElement* x = src->child("expression");
    auto ex = x ? parse_st_expression(x->text, *x, d_) : nullptr;
    if (!ex) return nullptr;
    if (ex->kind != Expr::Kind::kName) {
      d_.error(x->pos, "block " + type + ": " + (whole ? "structure or array input '" : "in-out parameter '") + formal +
                           "' needs a variable, not '" + trim(x->text) + "'");
      return nullptr;
    }
    if (whole) {
      Var* w = ex->args.empty() ? L_.whole_var(s_, ex->name) : nullptr;
      if (!w) d_.error(x->pos, "block " + type + ": input '" + formal + "' is a structure or array: connect a variable of its type");
      return w;
    }
    return L_.in_out_argument(s_, *ex, formal, x->pos);
  }

  Value negate_if(const XmlElement& e, Value v) {
    if (attr(e, "negated") == "true") return L_.em().unary_not(L_.em().to_digital(v, e.pos), e.pos);
    return v;
  }

  void lower(const std::string& id) {
    int& st = state_[id];
    if (st != 0) return;
    if (depth_ >= kMaxDepth) {
      if (!d_.has_errors())
        d_.error(elems_[id]->pos, "the data flow runs through more than " + std::to_string(kMaxDepth) +
                                      " elements in a row; split the network");
      return;
    }
    ++depth_;
    lower_element(id, st);
    --depth_;
  }

  static constexpr int kMaxDepth = 2000;

  void lower_element(const std::string& id, int& st) {
    st = 1;
    const XmlElement& e = *elems_[id];
    auto& outs = values_[id];
    Emitter& em = L_.em();
    const SourcePos pos = e.pos;
    if (e.name == "inVariable") {
      outs[""] = negate_if(e, expression_value(e, pos));
    } else if (e.name == "outVariable" || e.name == "inOutVariable") {
      const XmlElement* cp = e.child("connectionPointIn");
      const bool wired = cp && cp->child("connection");
      Value v = input(cp);
      if (!wired && !writes_result(e, "expression")) {
        // Left unconnected in the editor: Beremiz and OpenPLC generate no
        // statement for it, and neither does rtplc.
        d_.warning(pos, "<" + e.name + "> localId " + id + " has nothing connected to its input: it assigns nothing");
      } else if (!v.valid()) {
        if (!d_.has_errors()) d_.error(pos, "<" + e.name + "> localId " + id + " has nothing connected to its input");
      } else if (writes_result(e, "expression")) {
        v = L_.em().to_digital(negate_if(e, v), pos);
        results_.emplace_back(id, v);
        outs[""] = v;
      } else {
        v = negate_if(e, v);
        if (Var* t = target(e, "expression")) {
          // Fed by a function whose EN is false this cycle: the assignment does not happen.
          const XmlElement* c = cp ? cp->child("connection") : nullptr;
          auto en = c ? enable_.find(attr(*c, "refLocalId")) : enable_.end();
          if (en != enable_.end()) v = L_.em().select(en->second, v, L_.read(*t, pos), pos);
          L_.assign(*t, v, pos);
        }
        outs[""] = v;
      }
    } else if (e.name == "connector") {
      Value v = input(e.child("connectionPointIn"));
      outs[""] = v.valid() ? v : constant(0, false);
    } else if (e.name == "continuation") {
      auto c = connectors_.find(upper(attr(e, "name")));
      if (c == connectors_.end()) {
        d_.error(pos, "<continuation name=\"" + attr(e, "name") + "\"> has no <connector> of that name");
      } else {
        outs[""] = output_of(c->second, "", pos);
      }
    } else if (e.name == "leftPowerRail") {
      outs[""] = constant(1, true);
    } else if (e.name == "rightPowerRail") {
      for (const XmlElement& c : e.children) {
        if (c.name == "connectionPointIn") input(&c);
      }
    } else if (e.name == "contact") {
      Value power = input(e.child("connectionPointIn"));
      if (!power.valid()) power = constant(0, true);
      Value v = contact_variable(e, id);
      outs[""] = em.binary(BinOp::kAnd, em.to_digital(power, pos), v, pos);
    } else if (e.name == "coil") {
      coil(e, id, outs);
    } else if (e.name == "block") {
      block(e, id, outs);
    }
    st = 2;
    for (auto& [key, digital] : aliases_) {
      const size_t bar = key.find('|');
      if (key.substr(0, bar) != id || made_alias_.count(key)) continue;
      made_alias_.insert(key);
      const std::string param = key.substr(bar + 1);
      auto o = outs.find(upper(param));
      if (o == outs.end()) o = outs.find("");
      Value v = o == outs.end() ? constant(0, digital) : o->second;
      v = digital ? em.to_digital(v, pos) : em.to_analog(v, pos);
      em.copy_as(v, s_.path + ".fb" + id + (param.empty() ? "" : "." + param), pos);
    }
  }

  Value contact_variable(const XmlElement& e, const std::string& id) {
    Emitter& em = L_.em();
    const XmlElement* x = e.child("variable");
    if (!x) {
      d_.error(e.pos, "<contact> without a <variable>");
      return constant(0, true);
    }
    auto ex = parse_st_expression(x->text, *x, d_);
    if (!ex) return constant(0, true);
    Value v = em.to_digital(L_.eval(s_, *ex), e.pos);
    const std::string edge = attr(e, "edge");
    const std::string mem = s_.path + ".contact" + id;
    if (edge == "rising") v = L_.rising(v, mem, e.pos);
    else if (edge == "falling") v = L_.falling(v, mem, e.pos);
    if (attr(e, "negated") == "true") v = em.unary_not(v, e.pos);
    return v;
  }

  void coil(const XmlElement& e, const std::string& id, std::map<std::string, Value>& outs) {
    Emitter& em = L_.em();
    Value power = input(e.child("connectionPointIn"));
    if (!power.valid()) power = constant(0, true);
    power = em.to_digital(power, e.pos);
    outs[""] = power;
    const bool result = writes_result(e, "variable");
    Var* t = result ? nullptr : target(e, "variable");
    if (!t && !result) return;
    Value v = power;
    const std::string edge = attr(e, "edge");
    if (edge == "rising") v = L_.rising(v, s_.path + ".coil" + id, e.pos);
    else if (edge == "falling") v = L_.falling(v, s_.path + ".coil" + id, e.pos);
    const std::string storage = attr(e, "storage");
    if (attr(e, "negated") == "true") v = em.unary_not(v, e.pos);
    if (result) {
      if (!storage.empty() && storage != "none") {
        d_.error(e.pos, "a " + storage + " coil cannot give a transition its value (it has no memory): use a plain coil");
        return;
      }
      results_.emplace_back(id, v);
      return;
    }
    if (storage == "set") {
      v = em.binary(BinOp::kOr, em.to_digital(L_.read(*t, e.pos), e.pos), v, e.pos);
    } else if (storage == "reset") {
      v = em.binary(BinOp::kAnd, em.to_digital(L_.read(*t, e.pos), e.pos), em.unary_not(v, e.pos), e.pos);
    } else if (!storage.empty() && storage != "none") {
      d_.error(e.pos, "coil storage '" + storage + "' is not none, set or reset");
      return;
    }
    L_.assign(*t, v, e.pos);
  }

  void block(const XmlElement& e, const std::string& id, std::map<std::string, Value>& outs) {
    Emitter& em = L_.em();
    const std::string type = attr(e, "typeName");
    const std::string up = upper(type);
    const SourcePos pos = e.pos;
    std::vector<std::pair<std::string, Value>> inputs;
    std::vector<std::pair<Var*, Var*>> wholes;  // (the FB's structure or array input, the caller's)
    std::vector<std::pair<std::string, Var*>> function_wholes;  // (a function's such input, the caller's)
    Var* instance = attr(e, "instanceName").empty() ? nullptr : L_.lookup(s_, attr(e, "instanceName"), pos, false);
    Value en = constant(1, true);
    if (const XmlElement* iv = e.child("inputVariables")) {
      for (const XmlElement& v : iv->children) {
        if (v.name != "variable") continue;
        const std::string formal = attr(v, "formalParameter");
        if (Var* m = L_.whole_member(instance, formal)) {
          Var* src = connected_variable(v, type, true);
          if (!src) return;
          wholes.emplace_back(m, src);
          continue;
        }
        if (!instance && L_.whole_parameter(type, formal)) {  // a user function's structure input
          Var* src = connected_variable(v, type, true);
          if (!src) return;
          function_wholes.emplace_back(formal, src);
          continue;
        }
        Value x = input(v.child("connectionPointIn"));
        if (!x.valid()) continue;  // an unconnected input keeps its default
        x = negate_if(v, x);
        const std::string edge = attr(v, "edge");
        if (edge == "rising" || edge == "falling") {
          const std::string mem = s_.path + ".b" + id + "." + formal;
          x = edge == "rising" ? L_.rising(em.to_digital(x, v.pos), mem, v.pos)
                               : L_.falling(em.to_digital(x, v.pos), mem, v.pos);
        }
        if (upper(formal) == "EN") {
          en = x;
          continue;
        }
        inputs.emplace_back(formal, x);
      }
    }
    // In-out parameters: the variable drawn into each, passed by reference;
    // the parameter's output side is that variable after the call.
    std::vector<std::pair<std::string, Var*>> inouts;
    if (const XmlElement* io = e.child("inOutVariables")) {
      for (const XmlElement& v : io->children) {
        if (v.name != "variable") continue;
        Var* var = connected_variable(v, type, false);
        if (!var) return;
        inouts.emplace_back(attr(v, "formalParameter"), var);
      }
    }
    std::vector<std::pair<std::string, const XmlElement*>> out_vars;
    if (const XmlElement* ov = e.child("outputVariables")) {
      for (const XmlElement& v : ov->children) {
        if (v.name == "variable") out_vars.emplace_back(attr(v, "formalParameter"), &v);
      }
    }
    outs["ENO"] = en;
    const std::string inst = attr(e, "instanceName");
    if (L_.is_function(up) && inst.empty()) {
      std::vector<Value> args;
      std::vector<std::string> formals;
      for (auto& [f, v] : inputs) {
        formals.push_back(upper(f));
        args.push_back(v);
      }
      auto r = L_.call_function(s_, type, args, formals, pos, inouts, function_wholes);
      if (!r) return;
      for (const auto& [f, var] : inouts) outs[upper(f)] = L_.read(*var, pos);
      // EN false: the function does not run, so a variable it feeds keeps its value.
      if (!(en.is_const && en.k != 0)) enable_[id] = en;
      for (auto& [f, v] : out_vars) {
        if (upper(f) == "ENO") continue;
        outs[upper(f)] = negate_if(*v, *r);
      }
      outs[""] = *r;
      return;
    }
    if (inst.empty()) {
      d_.error(pos, "block '" + type + "' is neither a function rtplc knows nor a function block instance (no instanceName)");
      return;
    }
    Var* fb = L_.lookup(s_, inst, pos);
    if (!fb) return;
    if (fb->role != Var::Role::kUserFb && fb->role != Var::Role::kStdFb) {
      d_.error(pos, "block instance '" + inst + "' is not declared as a function block");
      return;
    }
    // EN false: the instance is not called, so it keeps its state and shows
    // its last outputs (if-converted like a call under IF; ENO = EN).
    auto call = [&] {
      for (const auto& [m, src] : wholes) L_.assign_whole(*m, *src, pos);
      L_.call_fb(*fb, inputs, pos, inouts);
    };
    if (en.is_const && en.k != 0) call();
    else L_.guarded(en, pos, call);
    for (const auto& [f, var] : inouts) outs[upper(f)] = L_.read(*var, pos);
    for (auto& [f, v] : out_vars) {
      if (upper(f) == "ENO") continue;
      outs[upper(f)] = negate_if(*v, L_.fb_output(*fb, f, pos));
    }
    if (!out_vars.empty() && !outs.count("")) outs[""] = outs[upper(out_vars[0].first)];
  }

  Lowering& L_;
  Scope& s_;
  const XmlElement& body_;
  bool ladder_;
  bool in_sfc_;
  DiagnosticList& d_;
  std::string result_name_;                              // upper case; empty: none
  std::string result_as_written_;
  std::vector<std::pair<std::string, Value>> results_;  // (localId, value) writing it
  std::map<std::string, const XmlElement*> elems_;
  std::vector<std::string> order_;
  std::map<std::string, std::string> connectors_;
  std::map<std::string, std::vector<std::string>> writers_;
  std::map<std::string, int> state_;  // 0 new, 1 being lowered, 2 done
  std::map<std::string, std::map<std::string, Value>> values_;
  std::map<std::string, bool> aliases_;  // "id|param" -> digital
  std::map<std::string, Value> enable_;  // function block localId -> its EN, when not always true
  std::set<std::string> made_alias_;
  std::set<std::string> reported_;
  std::set<std::string> whole_elems_;  // inVariables naming a whole structure or array
  int depth_ = 0;
};

}  // namespace

void Lowering::lower_graph(Scope& s, const XmlElement& body, bool ladder) {
  Graph g(*this, s, body, ladder);
  g.run();
}

std::vector<Value> lower_sfc_graph_inputs(Lowering& L, Scope& s, const XmlElement& sfc,
                                          const std::vector<const XmlElement*>& points) {
  Graph g(L, s, sfc, false, true);
  g.run();
  std::vector<Value> out;
  for (const XmlElement* p : points) out.push_back(L.diags().has_errors() ? Value{} : g.value_into(*p));
  return out;
}

Value lower_graph_result(Lowering& L, Scope& s, const XmlElement& body, bool ladder,
                         const std::string& name, const std::string& what, SourcePos pos) {
  Graph g(L, s, body, ladder);
  g.set_result_name(name);
  g.run();
  if (L.diags().has_errors()) return {};
  return g.result(what, pos);
}

void collect_written(const Pou& p, std::vector<std::string>& out) {
  if (p.body.language == BodyLanguage::kSt) {
    st_written_names(p.body.source, out);
    return;
  }
  if (!p.body.graph) return;
  for (const XmlElement& e : p.body.graph->children) {
    const XmlElement* x = nullptr;
    if (e.name == "outVariable" || e.name == "inOutVariable") x = e.child("expression");
    else if (e.name == "coil") x = e.child("variable");
    if (x) out.push_back(target_name(x->text));
  }
}

}  // namespace rtplc::lang::plcopen
