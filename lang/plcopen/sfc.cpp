// PLCopen SFC bodies -> blocks (docs/plcopen.md, "SFC"), with the evolution
// rules of rtplc's own SFC (docs/sfc.md, "How an SFC runs"; lang/sfc/builder.cpp):
//   - a transition fires when all its source steps were active at the end of
//     the last cycle and its condition holds; of the transitions leaving one
//     step through a selection divergence, the first in the document wins;
//   - step X = (last cycle's X AND NOT a leaving transition fired) OR an
//     entering one fired (OR the first cycle, for the initial step), a block
//     named `instance.step.NAME.X`, so a swap keeps the active steps;
//   - actions see this cycle's step flags: N, S, R, P, L and D on a BOOL
//     variable or on a named action whose body (ST, FBD, LD or IL) then runs,
//     if-converted, while the action is active.
#include <algorithm>
#include <functional>
#include <map>
#include <set>

#include "lang/plcopen/lowering.h"

namespace rtplc::lang::plcopen {
namespace {

std::string attr(const XmlElement& e, std::string_view n) {
  const XmlAttribute* a = e.attribute(n);
  return a ? a->value : std::string();
}

// The localIds an element's connectionPointIn(s) connect to.
std::vector<std::string> inputs_of(const XmlElement& e) {
  std::vector<std::string> out;
  for (const XmlElement& c : e.children) {
    if (c.name != "connectionPointIn") continue;
    for (const XmlElement& k : c.children) {
      if (k.name == "connection") out.push_back(attr(k, "refLocalId"));
    }
  }
  return out;
}

struct ActionUse {
  std::string qualifier;
  double duration = 0;
  std::string target;  // a variable or an action name
  const XmlElement* inline_body = nullptr;
  SourcePos pos;
  std::string step;
};

}  // namespace

void Lowering::lower_sfc(Scope& s, const XmlElement& body) {
  std::map<std::string, const XmlElement*> el;
  std::vector<std::string> order;
  std::map<std::string, std::vector<std::string>> consumers;  // id -> ids reading it
  std::map<std::string, std::string> step_by_name;           // upper name -> id
  for (const XmlElement& e : body.children) {
    if (e.name == "addData" || e.name == "documentation" || e.name == "comment") continue;
    static const char* const kKnown[] = {"step", "transition", "selectionDivergence", "selectionConvergence",
                                         "simultaneousDivergence", "simultaneousConvergence", "jumpStep",
                                         "actionBlock"};
    bool known = false;
    for (const char* k : kKnown) known = known || e.name == k;
    if (!known) {
      d_.error(e.pos, "<" + e.name + "> in an SFC body is not supported yet" +
                          (e.name == "macroStep" ? std::string(" (macro steps)") : std::string()));
      return;
    }
    const std::string id = attr(e, "localId");
    if (id.empty() || !el.emplace(id, &e).second) {
      d_.error(e.pos, "<" + e.name + "> needs a localId of its own");
      return;
    }
    order.push_back(id);
    if (e.name == "step") {
      const std::string n = upper(attr(e, "name"));
      if (n.empty() || !step_by_name.emplace(n, id).second) {
        d_.error(e.pos, "step '" + attr(e, "name") + "' needs a name of its own");
        return;
      }
    }
  }
  for (const std::string& id : order) {
    for (const std::string& src : inputs_of(*el[id])) consumers[src].push_back(id);
  }
  auto kind = [&](const std::string& id) -> std::string {
    auto it = el.find(id);
    return it == el.end() ? std::string() : it->second->name;
  };
  // Steps a transition leaves: back through divergences and convergences.
  std::function<void(const std::string&, std::set<std::string>&, int)> sources =
      [&](const std::string& id, std::set<std::string>& out, int depth) {
        if (depth > 1000) return;
        const std::string k = kind(id);
        if (k == "step") {
          out.insert(id);
        } else if (k == "selectionDivergence" || k == "simultaneousConvergence") {
          for (const std::string& i : inputs_of(*el[id])) sources(i, out, depth + 1);
        } else if (!k.empty()) {
          d_.error(el[id]->pos, "<" + k + "> cannot lead into a transition");
        } else {
          d_.error(body.pos, "connection to localId " + id + ", which is no element of this SFC");
        }
      };
  // Steps a transition enters: forward through divergences, convergences and jumps.
  std::function<void(const std::string&, std::set<std::string>&, int)> targets =
      [&](const std::string& id, std::set<std::string>& out, int depth) {
        if (depth > 1000) return;
        for (const std::string& c : consumers[id]) {
          const std::string k = kind(c);
          if (k == "step") {
            out.insert(c);
          } else if (k == "jumpStep") {
            auto st = step_by_name.find(upper(attr(*el[c], "targetName")));
            if (st == step_by_name.end()) {
              d_.error(el[c]->pos, "<jumpStep> to '" + attr(*el[c], "targetName") + "', which is no step of this SFC");
            } else {
              out.insert(st->second);
            }
          } else if (k == "simultaneousDivergence" || k == "selectionConvergence") {
            targets(c, out, depth + 1);
          }
        }
      };

  Emitter& em = em_;
  auto flag = [&](const std::string& step_id) { return s.path + ".step." + attr(*el[step_id], "name") + ".X"; };
  auto prev = [&](const std::string& step_id) {
    Value v;
    v.ref = flag(step_id);  // made below: read here, it is last cycle's flag
    v.digital = true;
    return v;
  };

  // Transitions, in document order.
  std::map<std::string, Value> leaving, entering;  // step id -> OR of fired transitions
  std::map<std::string, Value> earlier;            // step id -> OR of earlier transitions from it (priority)
  for (const std::string& id : order) {
    if (d_.has_errors()) return;
    const XmlElement& t = *el[id];
    if (t.name != "transition") continue;
    std::set<std::string> from, to;
    for (const std::string& i : inputs_of(t)) sources(i, from, 0);
    targets(id, to, 0);
    if (from.empty() || to.empty()) {
      if (!d_.has_errors()) d_.error(t.pos, "this transition is not between steps");
      return;
    }
    Value cond = constant(0, true);
    const XmlElement* c = t.child("condition");
    const XmlElement* inl = c ? c->child("inline") : nullptr;
    const XmlElement* ref = c ? c->child("reference") : nullptr;
    if (inl) {
      const XmlElement* st = inl->child("ST");
      if (!st) {
        d_.error(inl->pos, "an inline transition condition must be ST");
        return;
      }
      const XmlElement* holder = st;
      for (const XmlElement& h : st->children) {
        if (h.name == "p" || h.name == "xhtml") holder = &h;
      }
      auto ex = parse_st_expression(holder->text, *holder, d_);
      if (!ex) return;
      cond = em.to_digital(eval(s, *ex), t.pos);
    } else if (ref) {
      const std::string n = attr(*ref, "name");
      const NamedBody* nb = nullptr;
      for (const NamedBody& b : s.pou->transitions) {
        if (iequals(b.name, n)) nb = &b;
      }
      if (!nb) {
        d_.error(ref->pos, "transition '" + n + "' is not declared in the POU's <transitions>");
        return;
      }
      if (nb->body.language != BodyLanguage::kSt) {
        d_.error(nb->pos, "transition '" + n + "': only ST transition bodies are supported yet");
        return;
      }
      // An expression, or `NAME := expression;`.
      std::string text = nb->body.source;
      const size_t assign = text.find(":=");
      size_t begin = 0, end = text.size();
      if (assign != std::string::npos) {
        begin = assign + 2;
        const size_t semi = text.rfind(';');
        if (semi != std::string::npos && semi > begin) end = semi;
      } else if (const size_t semi = text.rfind(';'); semi != std::string::npos) {
        end = semi;
      }
      auto ex = parse_st_expression(text, *nb->body.text, d_, begin, end);
      if (!ex) return;
      cond = em.to_digital(eval(s, *ex), t.pos);
    } else {
      d_.error(t.pos, "a transition condition connected to FBD or LD elements is not supported yet (write it inline in ST)");
      return;
    }
    Value fire = cond;
    for (const std::string& f : from) fire = em.binary(BinOp::kAnd, fire, prev(f), t.pos);
    if (from.size() == 1) {  // selection divergence: the first transition in the document wins
      const std::string f = *from.begin();
      if (earlier.count(f)) fire = em.binary(BinOp::kAnd, fire, em.unary_not(earlier[f], t.pos), t.pos);
      earlier[f] = earlier.count(f) ? em.binary(BinOp::kOr, earlier[f], fire, t.pos) : fire;
    }
    for (const std::string& f : from)
      leaving[f] = leaving.count(f) ? em.binary(BinOp::kOr, leaving[f], fire, t.pos) : fire;
    for (const std::string& g : to)
      entering[g] = entering.count(g) ? em.binary(BinOp::kOr, entering[g], fire, t.pos) : fire;
  }

  // Steps.
  std::map<std::string, Value> active;  // this cycle's flags
  int initial = 0;
  for (const std::string& id : order) {
    const XmlElement& st = *el[id];
    if (st.name != "step") continue;
    Value x = prev(id);
    if (leaving.count(id)) x = em.binary(BinOp::kAnd, x, em.unary_not(leaving[id], st.pos), st.pos);
    if (entering.count(id)) x = em.binary(BinOp::kOr, x, entering[id], st.pos);
    if (attr(st, "initialStep") == "true") {
      ++initial;
      x = em.binary(BinOp::kOr, x, em.first_cycle(st.pos), st.pos);
    }
    em.copy_as(x, flag(id), st.pos);
    Value v;
    v.ref = flag(id);
    v.digital = true;
    active[id] = v;
    out_.variables.push_back(flag(id));
  }
  if (initial == 0) {
    d_.error(body.pos, "this SFC has no initial step (initialStep=\"true\")");
    return;
  }

  // Actions: every (qualifier, target) use, grouped by target.
  std::vector<ActionUse> uses;
  for (const std::string& id : order) {
    const XmlElement& ab = *el[id];
    if (ab.name != "actionBlock") continue;
    std::set<std::string> steps;
    for (const std::string& i : inputs_of(ab)) {
      if (kind(i) == "step") steps.insert(i);
    }
    if (steps.size() != 1) {
      d_.error(ab.pos, "an <actionBlock> must be connected to one step");
      return;
    }
    for (const XmlElement& a : ab.children) {
      if (a.name != "action") continue;
      ActionUse u;
      u.qualifier = upper(attr(a, "qualifier"));
      if (u.qualifier.empty()) u.qualifier = "N";
      u.pos = a.pos;
      u.step = *steps.begin();
      const std::string dur = attr(a, "duration");
      if (!dur.empty()) {
        auto k = parse_literal(dur);
        if (!k || *k < 0) {
          d_.error(a.pos, "action duration '" + dur + "' is not a TIME literal");
          return;
        }
        u.duration = *k;
      }
      if (const XmlElement* r = a.child("reference")) {
        u.target = attr(*r, "name");
      } else if (const XmlElement* in = a.child("inline")) {
        u.inline_body = in;
        u.target = "inline" + attr(a, "localId") + "@" + id;
      } else {
        d_.error(a.pos, "an <action> needs a <reference> or an <inline> body");
        return;
      }
      static const char* const kQual[] = {"N", "S", "R", "P", "L", "D"};
      bool ok = false;
      for (const char* q : kQual) ok = ok || u.qualifier == q;
      if (!ok) {
        d_.error(a.pos, "action qualifier " + u.qualifier + " is not supported yet (N, S, R, P, L and D are)");
        return;
      }
      if ((u.qualifier == "L" || u.qualifier == "D") && dur.empty()) {
        d_.error(a.pos, "qualifier " + u.qualifier + " needs a duration");
        return;
      }
      uses.push_back(u);
    }
  }
  std::vector<std::string> targets_in_order;
  for (const ActionUse& u : uses) {
    if (std::find(targets_in_order.begin(), targets_in_order.end(), upper(u.target)) == targets_in_order.end())
      targets_in_order.push_back(upper(u.target));
  }
  int timer = 0;
  for (const std::string& tgt : targets_in_order) {
    Value on = constant(0, true), set = constant(0, true), reset = constant(0, true);
    SourcePos pos;
    const ActionUse* first = nullptr;
    for (const ActionUse& u : uses) {
      if (upper(u.target) != tgt) continue;
      if (!first) first = &u;
      pos = u.pos;
      const Value x = active[u.step];
      const std::string name = s.path + ".action." + u.target + "." + u.qualifier + std::to_string(++timer);
      Value term;
      if (u.qualifier == "N") {
        term = x;
      } else if (u.qualifier == "S") {
        set = em.binary(BinOp::kOr, set, x, u.pos);
        continue;
      } else if (u.qualifier == "R") {
        reset = em.binary(BinOp::kOr, reset, x, u.pos);
        continue;
      } else if (u.qualifier == "P") {
        term = rising(x, name, u.pos);
      } else {
        // D: on after the duration; L: on for the duration (the IEC TON of the step flag).
        em.emit("ton", name, u.pos, {em.ref(x, u.pos), em.ref(constant(u.duration, false), u.pos)});
        Value q;
        q.ref = name;
        q.digital = true;
        term = u.qualifier == "D" ? q : em.binary(BinOp::kAnd, x, em.unary_not(q, u.pos), u.pos);
      }
      on = em.binary(BinOp::kOr, on, term, u.pos);
    }
    // The stored (S/R) part is a latch of its own, reset dominant.
    const std::string latch = s.path + ".action." + first->target + ".stored";
    if (!(set.is_const && set.k == 0)) {
      Value l;
      l.ref = latch;
      l.digital = true;
      const Value stored = em.binary(BinOp::kAnd, em.binary(BinOp::kOr, l, set, pos), em.unary_not(reset, pos), pos);
      em.copy_as(stored, latch, pos);
      Value st;
      st.ref = latch;
      st.digital = true;
      on = em.binary(BinOp::kOr, on, st, pos);
    }
    // A named action with a body, an inline body, or a BOOL variable.
    const NamedBody* nb = nullptr;
    for (const NamedBody& b : s.pou->actions) {
      if (iequals(b.name, first->target)) nb = &b;
    }
    const XmlElement* text = nullptr;
    std::string source;
    if (first->inline_body) {
      const XmlElement* st = first->inline_body->child("ST");
      if (!st) {
        d_.error(first->pos, "an inline action body must be ST");
        return;
      }
      text = st;
      for (const XmlElement& h : st->children) {
        if (h.name == "p" || h.name == "xhtml") text = &h;
      }
      source = text->text;
    } else if (nb) {
      // FBD, LD, ST or IL: the body runs, if-converted, while the action is active.
      guarded(on, pos, [&] { lower_body_of(s, nb->body); });
      continue;
    }
    if (text) {
      Block blk = parse_st(source, *text, d_);
      if (d_.has_errors()) return;
      lower_st_guarded(s, blk, on, pos);
    } else {
      Var* v = lookup(s, first->target, first->pos, false);
      if (!v || !v->digital) {
        d_.error(first->pos, "action '" + first->target + "' is neither an action of this POU nor a BOOL variable");
        return;
      }
      assign(*v, on, pos);
    }
  }
}

}  // namespace rtplc::lang::plcopen
