// PLCopen SFC bodies -> blocks (docs/plcopen.md, "SFC"). This file reads the
// XML graph: steps, transitions, divergences, convergences, jumps and action
// blocks become a lang/sfc chart, whose builder (lang/sfc/builder.h) applies
// the evolution rules and action qualifiers (docs/sfc.md, "How an SFC runs"),
// so a PLCopen chart and a .sfc file evolve by one definition. What stays here
// is what only PLCopen has:
//   - transition conditions in ST (inline or a named <transition>), lowered to
//     importer blocks the chart reads as host signals;
//   - step flags copied to blocks named `instance.step.NAME.X` (traced by
//     `rtplc sim`; the chart's own flag keeps its name, so a swap keeps the
//     active steps);
//   - each action target's flag then drives a BOOL variable, or guards a
//     named action's body (ST, FBD, LD or IL) or an inline ST body, which runs
//     if-converted while the action is active.
#include <algorithm>
#include <functional>
#include <map>
#include <optional>
#include <set>

#include "lang/plcopen/lowering.h"
#include "lang/plcopen/sfc_chart.h"
#include "lang/sfc/builder.h"
#include "lang/sfc/semantics.h"

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

}  // namespace

std::string sfc_output_name(std::string target) {
  std::replace(target.begin(), target.end(), '.', '$');
  return "$" + upper(target);
}

bool read_sfc_graph(const XmlElement& body, const std::string& name, DiagnosticList& diags, SfcGraph* g) {
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
      diags.error(e.pos, "<" + e.name + "> in an SFC body is not supported yet" +
                          (e.name == "macroStep" ? std::string(" (macro steps)") : std::string()));
      return false;
    }
    const std::string id = attr(e, "localId");
    if (id.empty() || !el.emplace(id, &e).second) {
      diags.error(e.pos, "<" + e.name + "> needs a localId of its own");
      return false;
    }
    order.push_back(id);
    if (e.name == "step") {
      const std::string n = upper(attr(e, "name"));
      if (n.empty() || !step_by_name.emplace(n, id).second) {
        diags.error(e.pos, "step '" + attr(e, "name") + "' needs a name of its own");
        return false;
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
          diags.error(el[id]->pos, "<" + k + "> cannot lead into a transition");
        } else {
          diags.error(body.pos, "connection to localId " + id + ", which is no element of this SFC");
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
              diags.error(el[c]->pos, "<jumpStep> to '" + attr(*el[c], "targetName") + "', which is no step of this SFC");
            } else {
              out.insert(st->second);
            }
          } else if (k == "simultaneousDivergence" || k == "selectionConvergence") {
            targets(c, out, depth + 1);
          }
        }
      };

  // The chart in lang/sfc's terms; its builder owns the evolution rules.
  // Names the importer invents start with '$', which no IEC identifier holds.
  sfc::Chart& chart = g->chart;
  chart.name = name;
  chart.pos = body.pos;
  std::map<std::string, size_t> step_at;  // step id -> chart.steps index
  for (const std::string& id : order) {
    const XmlElement& st = *el[id];
    if (st.name != "step") continue;
    sfc::Step cs;
    cs.name = attr(st, "name");
    cs.pos = st.pos;
    cs.initial = attr(st, "initialStep") == "true";
    step_at[id] = chart.steps.size();
    chart.steps.push_back(std::move(cs));
  }
  auto step_ref = [&](const std::string& step_id, SourcePos pos) {
    return sfc::NameRef{chart.steps[step_at[step_id]].name, pos};
  };

  // Transitions, in document order (the order that decides a selection
  // divergence). Each condition is a host signal `$c<localId>`: the lowering
  // holds it in a block, the analysis takes it as free.
  for (const std::string& id : order) {
    if (diags.has_errors()) return false;
    const XmlElement& t = *el[id];
    if (t.name != "transition") continue;
    std::set<std::string> from, to;
    for (const std::string& i : inputs_of(t)) sources(i, from, 0);
    targets(id, to, 0);
    if (from.empty() || to.empty()) {
      if (!diags.has_errors()) diags.error(t.pos, "this transition is not between steps");
      return false;
    }
    const std::string held = "$c" + id;
    sfc::Signal sig;
    sig.role = sfc::Signal::Role::kHost;
    sig.name = held;
    sig.pos = t.pos;
    chart.signals.push_back(std::move(sig));
    sfc::Transition ct;
    ct.name = "$t" + id;
    ct.pos = t.pos;
    for (const std::string& f : from) ct.from.push_back(step_ref(f, t.pos));
    for (const std::string& e : to) ct.to.push_back(step_ref(e, t.pos));
    ct.condition.op = sfc::Expr::Op::kName;
    ct.condition.name = held;
    ct.condition.pos = t.pos;
    chart.transitions.push_back(std::move(ct));
    g->transitions.push_back(&t);
  }
  if (diags.has_errors()) return false;
  if (std::none_of(chart.steps.begin(), chart.steps.end(), [](const sfc::Step& st) { return st.initial; })) {
    diags.error(body.pos, "this SFC has no initial step (initialStep=\"true\")");
    return false;
  }

  // Actions: every (qualifier, target) use, grouped by target.
  std::vector<SfcActionUse>& uses = g->uses;
  for (const std::string& id : order) {
    const XmlElement& ab = *el[id];
    if (ab.name != "actionBlock") continue;
    std::set<std::string> steps;
    for (const std::string& i : inputs_of(ab)) {
      if (kind(i) == "step") steps.insert(i);
    }
    if (steps.size() != 1) {
      diags.error(ab.pos, "an <actionBlock> must be connected to one step");
      return false;
    }
    for (const XmlElement& a : ab.children) {
      if (a.name != "action") continue;
      SfcActionUse u;
      u.qualifier = upper(attr(a, "qualifier"));
      if (u.qualifier.empty()) u.qualifier = "N";
      u.pos = a.pos;
      u.step = step_at[*steps.begin()];
      const std::string dur = attr(a, "duration");
      if (!dur.empty()) {
        auto k = parse_literal(dur);
        if (!k || *k < 0) {
          diags.error(a.pos, "action duration '" + dur + "' is not a TIME literal");
          return false;
        }
        u.duration = *k;
      }
      if (const XmlElement* r = a.child("reference")) {
        u.target = attr(*r, "name");
      } else if (const XmlElement* in = a.child("inline")) {
        u.inline_body = in;
        u.target = "inline" + attr(a, "localId") + "@" + id;
      } else {
        diags.error(a.pos, "an <action> needs a <reference> or an <inline> body");
        return false;
      }
      static const char* const kQual[] = {"N", "S", "R", "P", "P1", "P0", "L", "D", "SD", "DS", "SL"};
      bool ok = false;
      for (const char* q : kQual) ok = ok || u.qualifier == q;
      if (!ok) {
        diags.error(a.pos, "action qualifier " + u.qualifier +
                               " is not supported (N, S, R, P, P1, P0, L, D, SD, DS and SL are)");
        return false;
      }
      if (sfc::is_timed_qualifier(u.qualifier) && dur.empty()) {
        diags.error(a.pos, "qualifier " + u.qualifier + " needs a duration");
        return false;
      }
      uses.push_back(u);
    }
  }
  // One chart OUTPUT per action target (a variable or an action, named
  // without case, as IEC names are); the builder ORs its N, P, P1, P0, L, D,
  // SD, DS and SL terms and its reset-dominant S/R latch into the output's
  // action flag.
  std::vector<std::string>& targets_in_order = g->targets;
  for (const SfcActionUse& u : uses) {
    if (std::find(targets_in_order.begin(), targets_in_order.end(), upper(u.target)) == targets_in_order.end()) {
      targets_in_order.push_back(upper(u.target));
      sfc::Signal out;
      out.role = sfc::Signal::Role::kOutput;
      out.name = sfc_output_name(u.target);
      out.pos = u.pos;
      chart.signals.push_back(std::move(out));
    }
    sfc::Action ca;
    ca.qualifier = u.qualifier;
    ca.pos = u.pos;
    ca.target = sfc_output_name(u.target);
    ca.target_pos = u.pos;
    if (sfc::is_timed_qualifier(u.qualifier)) ca.seconds = u.duration;
    ca.time_pos = u.pos;
    chart.steps[u.step].actions.push_back(std::move(ca));
  }

  return !diags.has_errors();
}

std::optional<sfc::Chart> read_sfc_pou(std::string_view xml, const std::string& pou,
                                       DiagnosticList& diags) {
  std::optional<Project> project = read_project(xml, diags);
  if (!project || diags.has_errors()) return std::nullopt;
  std::vector<const Pou*> charts;
  std::string names;
  for (const Pou& p : project->pous) {
    if (p.body.language != BodyLanguage::kSfc || p.body.graph == nullptr) continue;
    if (pou.empty() || iequals(p.name, pou)) charts.push_back(&p);
    names += (names.empty() ? "" : ", ") + p.name;
  }
  if (charts.size() != 1) {
    diags.error(project->root.pos,
                names.empty() ? std::string("the project has no POU with an SFC body")
                : charts.empty() ? "no POU '" + pou + "' with an SFC body; the project has " + names
                                 : "the project has several POUs with an SFC body (" + names +
                                       "); choose one with --pou");
    return std::nullopt;
  }
  SfcGraph g;
  if (!read_sfc_graph(*charts[0]->body.graph, charts[0]->name, diags, &g)) return std::nullopt;
  return std::move(g.chart);
}

void Lowering::lower_sfc(Scope& s, const XmlElement& body) {
  SfcGraph g;
  if (!read_sfc_graph(body, s.path, d_, &g)) return;
  const sfc::Chart& chart = g.chart;
  const std::vector<SfcActionUse>& uses = g.uses;
  Emitter& em = em_;
  // Each condition, lowered in the importer's blocks, is held in a block the
  // chart reads as a host signal.
  std::map<std::string, uint32_t> host_blocks;  // host signal -> block index
  for (size_t i = 0; i < g.transitions.size(); ++i) {
    const XmlElement& t = *g.transitions[i];
    const std::string id = attr(t, "localId");
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
    const std::string x = em.ref(cond, t.pos);
    host_blocks[chart.transitions[i].condition.name] =
        static_cast<uint32_t>(em.emit("or", s.path + ".$sfc.cond." + id, t.pos, {x, x}));
  }

  const sfc::ChartIndex index = sfc::check_chart(chart, d_);
  if (d_.has_errors()) return;
  sfc::HostLink host;
  host.prefix = s.path + ".$sfc.";
  host.first_index = static_cast<uint32_t>(em.size());
  host.resolve = [&](const std::string& name) -> std::optional<uint32_t> {
    auto it = host_blocks.find(name);
    if (it == host_blocks.end()) return std::nullopt;
    return it->second;
  };
  CheckedProgram built = sfc::build_flat_program(chart, index, d_, &host);
  if (d_.has_errors()) return;
  for (FlatBlock& b : built.blocks) em.append_resolved(std::move(b));

  // Step flags under the names a PLCopen user knows (and `rtplc sim` traces).
  for (const sfc::Step& st : chart.steps) {
    Value x;
    x.ref = sfc::step_flag_block(host, st.name);
    x.digital = true;
    const std::string name = s.path + ".step." + st.name + ".X";
    em.copy_as(x, name, st.pos);
    out_.variables.push_back(name);
  }

  for (const std::string& tgt : g.targets) {
    SourcePos pos;
    const SfcActionUse* first = nullptr;
    for (const SfcActionUse& u : uses) {
      if (upper(u.target) != tgt) continue;
      if (!first) first = &u;
      pos = u.pos;
    }
    Value on;
    on.ref = sfc::action_flag_block(host, sfc_output_name(first->target));
    on.digital = true;
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
