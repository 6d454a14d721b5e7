// PLCopen SFC bodies -> blocks (docs/plcopen.md, "SFC"). This file reads the
// XML graph: steps, transitions, divergences, convergences, jumps and action
// blocks become a lang/sfc chart, whose builder (lang/sfc/builder.h) applies
// the evolution rules and action qualifiers (docs/sfc.md, "How an SFC runs"),
// so a PLCopen chart and a .sfc file evolve by one definition. What stays here
// is what only PLCopen has:
//   - transition conditions, lowered to importer blocks the chart reads as
//     host signals: ST (inline or a named <transition>), FBD or LD bodies
//     (inline or named: the outVariable or coil named after the transition,
//     graph.h), and FBD/LD elements drawn in the SFC body itself feeding the
//     condition's connectionPointIn;
//   - step flags copied to blocks named `instance.step.NAME.X` (traced by
//     `rtplc sim`; the chart's own flag keeps its name, so a swap keeps the
//     active steps);
//   - each action target's flag then drives a BOOL variable, or guards a
//     named action's body or an inline one (ST, FBD, LD or IL), which runs
//     if-converted while the action is active.
#include <algorithm>
#include <functional>
#include <iterator>
#include <map>
#include <optional>
#include <set>

#include "lang/plcopen/graph.h"
#include "lang/plcopen/lowering.h"
#include "lang/plcopen/sfc_chart.h"
#include "lang/sfc/builder.h"
#include "lang/sfc/semantics.h"

namespace rtplc::lang::plcopen {
namespace {

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

const char* const kChartElements[] = {"step", "transition", "selectionDivergence", "selectionConvergence",
                                    "simultaneousDivergence", "simultaneousConvergence", "jumpStep",
                                    "actionBlock"};
// FBD and LD elements an SFC body may hold beside the chart: they compute
// transition conditions (graph.h, lower_sfc_graph_inputs).
const char* const kGraphElements[] = {"block", "inVariable", "outVariable", "inOutVariable", "connector",
                                      "continuation", "contact", "coil", "leftPowerRail", "rightPowerRail"};

bool is_sfc_element(const std::string& n) {
  return std::any_of(std::begin(kChartElements), std::end(kChartElements), [&](const char* k) { return n == k; });
}
bool is_graph_element(const std::string& n) {
  return std::any_of(std::begin(kGraphElements), std::end(kGraphElements), [&](const char* k) { return n == k; });
}

// The body of an <inline> (an inline condition or action): its language
// element, as read_project() reads a POU's <body>.
bool read_inline_body(const XmlElement& inl, DiagnosticList& diags, Body* b) {
  b->pos = inl.pos;
  for (const XmlElement& c : inl.children) {
    if (c.name == "addData" || c.name == "documentation") continue;
    if (c.name == "FBD") b->language = BodyLanguage::kFbd;
    else if (c.name == "LD") b->language = BodyLanguage::kLd;
    else if (c.name == "SFC") b->language = BodyLanguage::kSfc;
    else if (c.name == "ST") b->language = BodyLanguage::kSt;
    else if (c.name == "IL") b->language = BodyLanguage::kIl;
    else {
      diags.error(c.pos, "<" + c.name + "> in an <inline> is no PLCopen body language (FBD, LD, ST, IL)");
      return false;
    }
    b->pos = c.pos;
    if (b->language == BodyLanguage::kSt || b->language == BodyLanguage::kIl) {
      const XmlElement* holder = &c;
      for (const XmlElement& t : c.children) {
        if (t.name == "p" || t.name == "xhtml") holder = &t;
      }
      b->text = holder;
      b->source = holder->text;
    } else {
      b->graph = &c;
    }
    return true;
  }
  diags.error(inl.pos, "<inline> holds no FBD, LD, ST or IL body");
  return false;
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
    if (!is_sfc_element(e.name) && !is_graph_element(e.name)) {
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
    int nth = 0;  // inline actions are named by their place in the block: Beremiz gives each localId 0
    for (const XmlElement& a : ab.children) {
      if (a.name != "action") continue;
      ++nth;
      SfcActionUse u;
      u.qualifier = upper(attr(a, "qualifier"));
      if (u.qualifier.empty()) u.qualifier = "N";
      u.pos = a.pos;
      u.step = step_at[*steps.begin()];
      const std::string dur = attr(a, "duration");
      if (!dur.empty()) {
        auto k = parse_literal(dur);
        const bool a_name = std::all_of(dur.begin(), dur.end(), [](char ch) {
          return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '.';
        }) && (std::isalpha(static_cast<unsigned char>(dur[0])) || dur[0] == '_');
        if (!k && a_name) {
          u.duration_variable = dur;  // a TIME variable: read each cycle (lower_sfc)
        } else if (!k || *k < 0) {
          diags.error(a.pos, "action duration '" + dur + "' is not a TIME literal or a variable");
          return false;
        } else {
          u.duration = *k;
        }
      }
      if (const XmlElement* r = a.child("reference")) {
        u.target = attr(*r, "name");
      } else if (const XmlElement* in = a.child("inline")) {
        u.inline_body = in;
        u.target = "inline" + std::to_string(nth) + "@" + id;
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
    if (sfc::is_timed_qualifier(u.qualifier) && !u.duration_variable.empty()) {
      sfc::Signal d;
      d.role = sfc::Signal::Role::kHost;
      d.name = "$dur" + std::to_string(g->durations.size());
      d.pos = u.pos;
      chart.signals.push_back(d);
      ca.time_signal = d.name;
      g->durations.emplace_back(d.name, &u);
    } else if (sfc::is_timed_qualifier(u.qualifier)) {
      ca.seconds = u.duration;
    }
    ca.time_pos = u.pos;
    chart.steps[u.step].actions.push_back(std::move(ca));
  }

  return !diags.has_errors();
}

std::optional<sfc::Chart> read_sfc_pou(std::string_view xml, const std::string& pou,
                                       DiagnosticList& diags) {
  std::optional<Project> project = read_project(xml, diags);
  if (!project || diags.has_errors()) return std::nullopt;
  return read_sfc_pou(*project, pou, diags);
}

std::optional<sfc::Chart> read_sfc_pou(const Project& project, const std::string& pou, DiagnosticList& diags) {
  std::vector<const Pou*> charts;
  std::string names;
  for (const Pou& p : project.pous) {
    if (p.body.language != BodyLanguage::kSfc || p.body.graph == nullptr) continue;
    if (pou.empty() || iequals(p.name, pou)) charts.push_back(&p);
    names += (names.empty() ? "" : ", ") + p.name;
  }
  if (charts.size() != 1) {
    diags.error(project.root.pos,
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

std::optional<Value> Lowering::step_member(Scope& s, const std::string& path, SourcePos pos) {
  const size_t dot = path.find('.');
  if (dot == std::string::npos || path.find('.', dot + 1) != std::string::npos) return std::nullopt;
  auto chart = chart_steps_.find(&s);
  if (chart == chart_steps_.end()) return std::nullopt;
  const std::string step = upper(path.substr(0, dot)), member = upper(path.substr(dot + 1));
  auto it = chart->second.find(step);
  if (it == chart->second.end() || lookup(s, path.substr(0, dot), pos, false)) return std::nullopt;
  if (member == "X") {
    // The flag block comes after the conditions under MatIEC's order, so a
    // condition reads the flag the cycle started with; an action, the new one.
    Value x;
    x.ref = it->second;
    x.digital = true;
    return x;
  }
  if (member == "T") {
    if (auto t = step_times_.find(&s); t != step_times_.end()) {
      if (auto v = t->second.find(step); v != t->second.end()) return v->second.now;
    }
  }
  d_.error(pos, member == "T" ? "'" + path + "': rtplc did not see this step's .T written as `" + path.substr(0, dot) +
                                  ".T` in the POU's text (a comment inside it?), so it has no elapsed time to read"
                              : "'" + path + "': a step has .X (active) and .T (elapsed time), no ." +
                                    path.substr(dot + 1));
  return constant(0, false);
}

namespace {

// The flag of the chart's step `step` as a value (read before the chart's
// blocks: the flag the scan started with; after: this scan's).
Value step_flag(const sfc::HostLink& host, const std::string& step) {
  Value x;
  x.ref = sfc::step_flag_block(host, step);
  x.digital = true;
  return x;
}

// Whether `up` (upper-case text) names `S.T` for step `step` (upper-case), as a word.
bool mentions_step_time(const std::string& up, const std::string& step) {
  auto word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  for (size_t k = up.find(step); k != std::string::npos; k = up.find(step, k + 1)) {
    if (k > 0 && (word(up[k - 1]) || up[k - 1] == '.')) continue;
    size_t e = k + step.size();
    while (e < up.size() && std::isspace(static_cast<unsigned char>(up[e]))) ++e;
    if (e >= up.size() || up[e] != '.') continue;
    ++e;
    while (e < up.size() && std::isspace(static_cast<unsigned char>(up[e]))) ++e;
    if (e < up.size() && up[e] == 'T' && (e + 1 >= up.size() || !word(up[e + 1]))) return true;
  }
  return false;
}
// Every text of `e` (its own, its attributes', its children's) appended to
// `out`, each piece ended by '\x01' (neither blank nor a word's), so no
// match spans two pieces.
void chart_text(const XmlElement& e, std::string& out) {
  (out += e.text) += '\x01';
  for (const XmlAttribute& a : e.attributes) (out += a.value) += '\x01';
  for (const XmlElement& c : e.children) chart_text(c, out);
}
// The chart's text and its POU's actions' and transitions', upper-case: where
// a condition or action may name `S.T` (read once per chart).
std::string chart_texts(const Pou& pou, const XmlElement& chart) {
  std::string out;
  chart_text(chart, out);
  for (const std::vector<NamedBody>* bodies : {&pou.actions, &pou.transitions}) {
    for (const NamedBody& b : *bodies) {
      (out += b.body.source) += '\x01';
      if (b.body.graph) chart_text(*b.body.graph, out);
    }
  }
  return upper(out);
}

}  // namespace

// A step's elapsed time, as MatIEC keeps it: at the start of each scan an
// active step's T grows by the scan's time, a step entered in the scan starts
// at 0, a step left keeps its last T. Built for the steps whose `.T` the POU
// mentions, before the conditions (which read T as the scan started):
//   T = X ? T at the end of the last scan + dt : T at the end of the last scan
// on the nanosecond grid, X the flag the scan started with. dt, the scan's
// time, is the step of a timer that runs from 0 to an hour and starts again
// (`.$sfc.clock`: TON(IN := NOT its Q)): ET - ET of the last scan, while it
// grows (kept across the restart), so every figure stays small and exact.
// After the chart (stamp_step_times) T at the end of the scan,
// `<path>.step.<S>.T`, is 0 for a step entered in it; MatIEC's actions run
// after the chart and read that, CODESYS's run before it and read T as the
// conditions do.
void Lowering::step_times(Scope& s, const XmlElement& body, const sfc::Chart& chart, const sfc::HostLink& host) {
  std::map<std::string, StepTime>& times = step_times_[&s];
  const std::string texts = chart_texts(*s.pou, body);
  const double ns = iec::time_grid(iec::IecType::kTime);  // TIME's grid
  Value dt;
  for (const sfc::Step& st : chart.steps) {
    const std::string up = upper(st.name);
    if (!mentions_step_time(texts, up)) continue;
    if (!dt.valid()) {
      const std::string clock = s.path + ".$sfc.clock";
      Value q, last, held;
      q.ref = clock + ".Q";  // read before the timer: last scan's
      q.digital = true;
      const std::vector<Value> outs = lower_iec(*iec::find_iec("TON"), clock,
                                                {em_.unary_not(q, chart.pos), constant(3600, false)}, chart.pos);
      if (outs.size() < 2) return;
      const Value et = outs[1];
      last.ref = clock + ".last";
      held.ref = s.path + ".$sfc.dt";
      const Value grew = em_.binary(BinOp::kGt, et, last, chart.pos);
      const Value step = on_time_grid(em_.binary(BinOp::kSub, et, last, chart.pos), ns, chart.pos);
      em_.copy_as(em_.select(grew, step, held, chart.pos), held.ref, chart.pos);
      em_.copy_as(et, last.ref, chart.pos);
      dt = held;
    }
    const std::string base = s.path + ".step." + st.name;
    const Value flag = step_flag(host, st.name);  // before the chart: the flag the scan started with
    Value last;
    last.ref = base + ".T";  // made by stamp_step_times: the end of the last scan
    const Value grown = on_time_grid(em_.binary(BinOp::kAdd, last, dt, st.pos), ns, st.pos);
    Value t = em_.select(flag, grown, last, st.pos);
    t.time_type = iec::IecType::kTime;
    times[up] = StepTime{st.name, t};
    out_.variables.push_back(last.ref);
  }
}

void Lowering::stamp_step_times(Scope& s, const sfc::HostLink& host, bool entered_reads_zero) {
  auto it = step_times_.find(&s);
  if (it == step_times_.end()) return;
  for (auto& [up, t] : it->second) {
    const std::string base = s.path + ".step." + t.step;
    const Value entering = rising(step_flag(host, t.step), base + ".$rise", SourcePos{});
    Value end = em_.select(entering, constant(0, false), t.now, SourcePos{});
    end.time_type = iec::IecType::kTime;
    em_.copy_as(end, base + ".T", SourcePos{});
    if (entered_reads_zero) t.now = end;
  }
}

void Lowering::lower_sfc(Scope& s, const XmlElement& body) {
  SfcGraph g;
  if (!read_sfc_graph(body, s.path, d_, &g)) return;
  const sfc::Chart& chart = g.chart;
  const std::vector<SfcActionUse>& uses = g.uses;
  Emitter& em = em_;
  const bool actions_first = semantics_ == EditorSemantics::kCodesys;
  std::map<std::string, uint32_t> host_blocks;  // host signal -> block index
  sfc::HostLink host;
  host.prefix = s.path + ".$sfc.";
  host.actions_first = actions_first;
  for (const sfc::Step& st : chart.steps) chart_steps_[&s][upper(st.name)] = sfc::step_flag_block(host, st.name);
  // The transitions' conditions, each lowered in the importer's blocks and
  // held in a block (named .$sfc.cond.<localId>) the chart reads as a host
  // signal.
  auto conditions = [&]() -> bool {
    // Conditions drawn in the SFC body itself (Beremiz): FBD and LD elements
    // beside the steps, lowered once as one graph, each feeding a condition's
    // <connectionPointIn>.
    std::vector<Value> drawn(g.transitions.size());
    {
      std::set<std::string> sfc_ids;
      bool graph_elements = false;
      for (const XmlElement& e : body.children) {
        if (is_sfc_element(e.name)) sfc_ids.insert(attr(e, "localId"));
        graph_elements = graph_elements || is_graph_element(e.name);
      }
      std::vector<const XmlElement*> points;
      std::vector<size_t> point_of;
      for (size_t i = 0; i < g.transitions.size(); ++i) {
        const XmlElement* c = g.transitions[i]->child("condition");
        const XmlElement* cp = c ? c->child("connectionPointIn") : nullptr;
        if (!cp) continue;
        const std::string id = attr(*g.transitions[i], "localId");
        if (inputs_of(*c).empty()) {
          d_.error(cp->pos, "the condition of transition localId " + id + " has nothing connected to it");
          return false;
        }
        for (const std::string& src : inputs_of(*c)) {
          if (sfc_ids.count(src)) {
            d_.error(cp->pos, "the condition of transition localId " + id + " is connected to localId " + src +
                                  ", an SFC element: a condition takes its value from FBD or LD elements");
            return false;
          }
        }
        points.push_back(cp);
        point_of.push_back(i);
      }
      if (graph_elements || !points.empty()) {
        std::vector<Value> v = lower_sfc_graph_inputs(*this, s, body, points);
        if (d_.has_errors()) return false;
        for (size_t k = 0; k < points.size(); ++k) drawn[point_of[k]] = v[k];
      }
    }

    // Each condition, lowered in the importer's blocks, is held in a block the
    // chart reads as a host signal.
    for (size_t i = 0; i < g.transitions.size(); ++i) {
      const XmlElement& t = *g.transitions[i];
      const std::string id = attr(t, "localId");
      Value cond = constant(0, true);
      const XmlElement* c = t.child("condition");
      if (!c) {
        d_.error(t.pos, "<transition> localId " + id + " has no <condition>");
        return false;
      }
      const XmlElement* inl = c->child("inline");
      const XmlElement* ref = c->child("reference");
      Body inline_b;
      if (drawn[i].valid()) {
        cond = em.to_digital(drawn[i], t.pos);
      } else if (inl && read_inline_body(*inl, d_, &inline_b) && inline_b.language == BodyLanguage::kSt) {
        auto ex = parse_st_expression(inline_b.source, *inline_b.text, d_);
        if (!ex) return false;
        cond = em.to_digital(eval(s, *ex), t.pos);
      } else if (inl) {
        if (d_.has_errors()) return false;
        const bool ladder = inline_b.language == BodyLanguage::kLd;
        const std::string name = attr(*inl, "name");
        if (inline_b.language == BodyLanguage::kIl) {
          // IL: the current result at the end of the body.
          lower_il(s, inline_b);
          if (!il_result()) return false;
          cond = em.to_digital(*il_result(), t.pos);
        } else if (inline_b.language != BodyLanguage::kFbd && !ladder) {
          d_.error(inline_b.pos, std::string("an inline transition condition in ") + language_name(inline_b.language) +
                                     " is not supported (ST, FBD, LD and IL are)");
          return false;
        } else if (name.empty() && !ladder) {
          d_.error(inl->pos, "an inline FBD condition needs <inline name=...> and an outVariable of that name (its value)");
          return false;
        } else {
          Value v = lower_graph_result(*this, s, *inline_b.graph, ladder, name,
                                       "the inline condition of transition localId " + id, inl->pos);
          if (!v.valid()) return false;
          cond = em.to_digital(v, t.pos);
        }
      } else if (ref) {
        const std::string n = attr(*ref, "name");
        const NamedBody* nb = nullptr;
        for (const NamedBody& b : s.pou->transitions) {
          if (iequals(b.name, n)) nb = &b;
        }
        if (!nb) {
          d_.error(ref->pos, "transition '" + n + "' is not declared in the POU's <transitions>");
          return false;
        }
        if (nb->body.language == BodyLanguage::kFbd || nb->body.language == BodyLanguage::kLd) {
          // The value of the outVariable or coil named after the transition.
          Value v = lower_graph_result(*this, s, *nb->body.graph, nb->body.language == BodyLanguage::kLd, nb->name,
                                       "transition '" + nb->name + "'", nb->pos);
          if (!v.valid()) return false;
          cond = em.to_digital(v, t.pos);
        } else if (nb->body.language == BodyLanguage::kIl) {
          lower_il(s, nb->body);  // the current result at the end is the condition
          if (!il_result()) return false;
          cond = em.to_digital(*il_result(), t.pos);
        } else if (nb->body.language != BodyLanguage::kSt) {
          d_.error(nb->pos, "transition '" + n + "': a transition body in " + language_name(nb->body.language) +
                                " is not supported yet (ST, FBD, LD and IL are)");
          return false;
        } else {
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
          if (!ex) return false;
          cond = em.to_digital(eval(s, *ex), t.pos);
        }
      } else {
        d_.error(c->pos, "a transition's <condition> needs a <reference>, an <inline> body or a <connectionPointIn>");
        return false;
      }
      if (attr(*c, "negated") == "true") cond = em.unary_not(cond, t.pos);
      // A chart called only in some cycles (under IF, CASE, EN, in an SFC
      // action or an event task) evolves only in those: no transition fires
      // in a cycle it is not called, so its steps hold, as MatIEC's chart
      // does between calls of its FB.
      if (conditional()) cond = em.binary(BinOp::kAnd, cond, active(t.pos), t.pos);
      const std::string x = em.ref(cond, t.pos);
      host_blocks[chart.transitions[i].condition.name] =
          static_cast<uint32_t>(em.emit("or", s.path + ".$sfc.cond." + id, t.pos, {x, x}));
    }

    return !d_.has_errors();
  };
  // The actions: each target's flag drives a BOOL variable or guards a body.
  auto actions = [&]() -> bool {
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
      // CODESYS runs an action body once more in the cycle after its step is
      // left (IEC steps' last call); MatIEC does not.
      // (on OR was: `was` is a block made just below, read as last cycle's.)
      Value run = on;
      if (actions_first) {
        Value was;
        was.ref = s.path + ".$sfc.was." + tgt;
        was.digital = true;
        run = em.binary(BinOp::kOr, on, was, pos);
        em.emit("or", was.ref, pos, {on.ref, on.ref});
      }
      // A named action with a body, an inline body, or a BOOL variable.
      const NamedBody* nb = nullptr;
      for (const NamedBody& b : s.pou->actions) {
        if (iequals(b.name, first->target)) nb = &b;
      }
      const XmlElement* text = nullptr;
      std::string source;
      if (first->inline_body) {
        Body b;
        if (!read_inline_body(*first->inline_body, d_, &b)) return false;
        if (b.language == BodyLanguage::kSfc) {
          d_.error(b.pos, "an SFC inside an SFC action is not supported");
          return false;
        }
        if (b.language != BodyLanguage::kSt) {
          // FBD, LD or IL: runs, if-converted, while the action is active.
          guarded(run, pos, [&] { lower_body_of(s, b); });
          continue;
        }
        text = b.text;
        source = b.source;
      } else if (nb) {
        // FBD, LD, ST or IL: the body runs, if-converted, while the action is active.
        guarded(run, pos, [&] { lower_body_of(s, nb->body); });
        continue;
      }
      if (text) {
        Block blk = parse_st(source, *text, d_);
        if (d_.has_errors()) return false;
        lower_st_guarded(s, blk, run, pos);
      } else {
        Var* v = lookup(s, first->target, first->pos, false);
        if (!v || !v->digital) {
          d_.error(first->pos, "action '" + first->target + "' is neither an action of this POU nor a BOOL variable");
          return false;
        }
        assign(*v, on, pos);
      }
    }
    return !d_.has_errors();
  };
  // Durations given by variables (`a(L, delay)`): each held, in seconds as
  // rtplc keeps TIME, in a block `.$sfc.dur.<n>` the chart's timers read.
  auto durations = [&]() -> bool {
    for (size_t k = 0; k < g.durations.size(); ++k) {
      const SfcActionUse& u = *g.durations[k].second;
      const Value v = load(s, u.duration_variable, {}, u.pos);
      if (d_.has_errors()) return false;
      if (v.digital || v.str) {
        d_.error(u.pos, "action duration '" + u.duration_variable + "' is not a TIME");
        return false;
      }
      const std::string x = em.ref(v, u.pos);
      host_blocks[g.durations[k].first] = static_cast<uint32_t>(
          em.emit("scale", s.path + ".$sfc.dur." + std::to_string(k), u.pos, {x}, {1.0, 0.0}));
    }
    return true;
  };
  auto step_flags = [&]() {
    // Step flags under the names a PLCopen user knows (and `rtplc sim` traces).
    for (const sfc::Step& st : chart.steps) {
      const std::string name = s.path + ".step." + st.name + ".X";
      em.copy_as(step_flag(host, st.name), name, st.pos);
      out_.variables.push_back(name);
    }
  };

  if (!actions_first) {
    // MatIEC's order: conditions, the chart (transitions, steps, the actions'
    // flags), the action bodies.
    step_times(s, body, chart, host);
    if (!conditions() || !durations()) return;
    const sfc::ChartIndex index = sfc::check_chart(chart, d_);
    if (d_.has_errors()) return;
    host.first_index = static_cast<uint32_t>(em.size());
    host.resolve = [&](const std::string& name) -> std::optional<uint32_t> {
      auto it = host_blocks.find(name);
      if (it == host_blocks.end()) return std::nullopt;
      return it->second;
    };
    CheckedProgram built = sfc::build_flat_program(chart, index, d_, &host);
    if (d_.has_errors()) return;
    for (FlatBlock& b : built.blocks) em.append_resolved(std::move(b));
    stamp_step_times(s, host, true);
    step_flags();
    actions();
    return;
  }
  // CODESYS's order: the actions' flags from the steps active at the start of
  // the cycle, the action bodies, the conditions (seeing what the actions
  // did), then the transitions and steps for the next cycle. The chart's two
  // parts go in by name, so the blocks between them do not move its inputs.
  const sfc::ChartIndex index = sfc::check_chart(chart, d_);
  if (d_.has_errors()) return;
  constexpr uint32_t kConditionBase = 0x40000000u;  // stands for condition i until the names are known
  std::map<std::string, uint32_t> condition_of;
  std::vector<std::string> condition_block;
  for (size_t i = 0; i < g.transitions.size() && i < chart.transitions.size(); ++i) {
    condition_of[chart.transitions[i].condition.name] = kConditionBase + static_cast<uint32_t>(i);
    condition_block.push_back(s.path + ".$sfc.cond." + attr(*g.transitions[i], "localId"));
  }
  for (size_t k = 0; k < g.durations.size(); ++k) {
    condition_of[g.durations[k].first] = kConditionBase + static_cast<uint32_t>(condition_block.size());
    condition_block.push_back(s.path + ".$sfc.dur." + std::to_string(k));
  }
  host.first_index = 0;
  host.resolve = [&](const std::string& name) -> std::optional<uint32_t> {
    auto it = condition_of.find(name);
    if (it == condition_of.end()) return std::nullopt;
    return it->second;
  };
  size_t split = 0;
  CheckedProgram built = sfc::build_flat_program(chart, index, d_, &host, &split);
  if (d_.has_errors()) return;
  for (FlatBlock& b : built.blocks) {
    if (b.name.empty()) b.name = em.fresh(host.prefix + "b");
  }
  auto append = [&](size_t from, size_t to) {
    for (size_t i = from; i < to; ++i) {
      FlatBlock b = built.blocks[i];
      std::vector<std::string> ins;
      for (uint32_t k = 0; k < b.n_in && k < 3; ++k) {
        ins.push_back(b.in[k] >= kConditionBase ? condition_block[b.in[k] - kConditionBase]
                                                : built.blocks[b.in[k]].name);
      }
      em.append_named(std::move(b), std::move(ins));
    }
  };
  step_times(s, body, chart, host);
  if (!durations()) return;  // before the actions' part, whose timers read them
  append(0, split);
  if (!actions()) return;
  if (!conditions()) return;
  append(split, built.blocks.size());
  stamp_step_times(s, host, false);
  step_flags();
}

}  // namespace rtplc::lang::plcopen
