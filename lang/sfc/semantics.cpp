// Name and reference rules of an SFC program (see semantics.h; docs/sfc.md,
// "Names and rules").
#include "lang/sfc/semantics.h"

#include <algorithm>
#include <set>

#include "blocks/registry.h"

namespace rtplc::lang::sfc {

std::string step_of_flag(const std::string& name) {
  if (name.size() > 2 && name.compare(name.size() - 2, 2, ".X") == 0) {
    return name.substr(0, name.size() - 2);
  }
  return {};
}

std::string closest_name(const std::string& name, const std::vector<std::string>& candidates) {
  // A hint is for a typo among a handful of names; a huge chart gets none
  // rather than a quadratic search per mistake.
  if (candidates.size() > 2000 || name.size() > 64) return "";
  size_t best = std::max<size_t>(2, name.size() / 3 + 1);
  std::string out;
  for (const std::string& c : candidates) {
    const size_t d = edit_distance(name, c);
    if (d < best) {
      best = d;
      out = c;
    }
  }
  return out.empty() ? "" : "; did you mean '" + out + "'?";
}

namespace {

uint32_t len(const std::string& s) {
  return static_cast<uint32_t>(s.empty() ? 1 : s.size());
}

class Checker {
 public:
  Checker(const Chart& c, DiagnosticList& d) : c_(c), d_(d) {}

  ChartIndex run() {
    declare_names();
    check_signals();
    check_steps();
    check_transitions();
    check_plant();
    return std::move(ix_);
  }

 private:
  // Every name lives in one space: a step, a signal, a transition, a module or a
  // plant place may not share it (a condition's `X` must mean one thing).
  void claim(const std::string& name, SourcePos pos, const char* what) {
    if (name.find('.') != std::string::npos) {
      // Dots are for the generated names (step.Fill, out.V1) and Step.X.
      d_.error(pos, std::string(what) + " name '" + name + "' may not contain '.'", len(name));
      return;
    }
    auto [it, fresh] = owner_.try_emplace(name, std::make_pair(std::string(what), pos.line));
    if (!fresh) {
      d_.error(pos,
               std::string(what) + " '" + name + "' is already defined as " + it->second.first +
                   " (line " + std::to_string(it->second.second) + ")",
               len(name));
    }
  }

  void declare_names() {
    for (size_t i = 0; i < c_.signals.size(); ++i) {
      const Signal& s = c_.signals[i];
      claim(s.name, s.pos,
            s.role == Signal::Role::kInput    ? "input"
            : s.role == Signal::Role::kOutput ? "output"
                                              : "signal");
      ix_.signals.emplace(s.name, i);
    }
    for (size_t i = 0; i < c_.steps.size(); ++i) {
      claim(c_.steps[i].name, c_.steps[i].pos, "step");
      ix_.steps.emplace(c_.steps[i].name, i);
      step_names_.push_back(c_.steps[i].name);
    }
    for (size_t i = 0; i < c_.transitions.size(); ++i) {
      claim(c_.transitions[i].name, c_.transitions[i].pos, "transition");
      ix_.transitions.emplace(c_.transitions[i].name, i);
    }
    for (size_t m = 0; m < c_.modules.size(); ++m) {
      claim(c_.modules[m].name, c_.modules[m].pos, "module");
      ix_.modules.emplace(c_.modules[m].name, m);
      for (size_t p = 0; p < c_.modules[m].places.size(); ++p) {
        const PlaceDecl& pd = c_.modules[m].places[p];
        claim(pd.name, pd.pos, "place");
        ix_.places.emplace(pd.name, PlaceRef{m, p});
        place_names_.push_back(pd.name);
      }
    }
    for (const Event& e : c_.events) claim(e.name, e.pos, "event");
    for (const Signal& s : c_.signals) signal_names_.push_back(s.name);
  }

  void check_signals() {
    for (const Signal& s : c_.signals) {
      if (!s.model_on.empty()) {
        check_place(s.model_on, s.model_pos);
        check_place(s.model_off, s.model_pos);
        auto a = ix_.places.find(s.model_on), b = ix_.places.find(s.model_off);
        if (a != ix_.places.end() && b != ix_.places.end() &&
            (a->second.module != b->second.module || a->second.place == b->second.place)) {
          d_.error(s.model_pos, "MODEL of " + s.name + " needs two different places of one module");
        }
      }
    }
  }

  void check_steps() {
    bool any_initial = false;
    for (const Step& st : c_.steps) {
      any_initial = any_initial || st.initial;
      std::set<std::pair<std::string, std::string>> seen;
      for (const Action& a : st.actions) {
        auto it = ix_.signals.find(a.target);
        if (it == ix_.signals.end() || c_.signals[it->second].role != Signal::Role::kOutput) {
          const bool known = it != ix_.signals.end();
          std::vector<std::string> outs;
          for (const Signal& s : c_.signals) {
            if (s.role == Signal::Role::kOutput) outs.push_back(s.name);
          }
          d_.error(a.target_pos,
                   known
                       ? "action target '" + a.target + "' is not an OUTPUT (actions drive outputs)"
                       : "unknown output '" + a.target + "'" + closest_name(a.target, outs),
                   len(a.target));
        }
        const bool timed = is_timed_qualifier(a.qualifier);
        if (timed && !a.seconds && a.time_signal.empty()) {
          d_.error(a.pos, "qualifier " + a.qualifier + " needs a time, e.g. '" + a.qualifier + " " +
                              a.target + " 5s'");
        } else if (!timed && a.seconds) {
          d_.error(a.time_pos, "qualifier " + a.qualifier + " takes no time (only L, D, SD, DS and SL do)");
        } else if (timed && a.seconds && *a.seconds < 0) {
          d_.error(a.time_pos, "an action time cannot be negative");
        }
        if (!seen.emplace(a.qualifier, a.target).second) {
          d_.error(a.pos,
                   "step " + st.name + " already has the action " + a.qualifier + " " + a.target);
        }
      }
      for (const NameRef& m : st.subnet) {
        if (!ix_.modules.count(m.name)) {
          std::vector<std::string> mods;
          for (const Module& mo : c_.modules) mods.push_back(mo.name);
          d_.error(m.pos, "unknown plant module '" + m.name + "'" + closest_name(m.name, mods),
                   len(m.name));
        }
      }
    }
    // SD, DS and SL keep their latch until an R: without one, they act once.
    std::set<std::string> reset;
    for (const Step& st : c_.steps) {
      for (const Action& a : st.actions) {
        if (a.qualifier == "R") reset.insert(a.target);
      }
    }
    for (const Step& st : c_.steps) {
      for (const Action& a : st.actions) {
        if ((a.qualifier == "SD" || a.qualifier == "DS" || a.qualifier == "SL") &&
            !reset.count(a.target)) {
          d_.warning(a.pos, "qualifier " + a.qualifier + " stores " + a.target + " until an 'R " +
                                a.target + "', and no step has one: it never resets",
                     len(a.qualifier));
        }
      }
    }
    if (c_.steps.empty()) {
      d_.error(c_.pos, "the program has no STEP");
    } else if (!any_initial) {
      d_.error(c_.steps[0].pos, "no step is INITIAL: write 'INITIAL STEP " + c_.steps[0].name + "'",
               len(c_.steps[0].name));
    }
  }

  bool check_step_ref(const NameRef& r) {
    if (ix_.steps.count(r.name)) return true;
    d_.error(r.pos, "unknown step '" + r.name + "'" + closest_name(r.name, step_names_),
             len(r.name));
    return false;
  }

  void check_transitions() {
    ix_.leaving.assign(c_.steps.size(), {});
    ix_.entering.assign(c_.steps.size(), {});
    for (size_t i = 0; i < c_.transitions.size(); ++i) {
      const Transition& t = c_.transitions[i];
      std::set<std::string> from_seen, to_seen;
      for (const NameRef& r : t.from) {
        if (!from_seen.insert(r.name).second)
          d_.error(r.pos, "step " + r.name + " is listed twice", len(r.name));
        if (check_step_ref(r)) ix_.leaving[ix_.steps[r.name]].push_back(i);
      }
      for (const NameRef& r : t.to) {
        if (!to_seen.insert(r.name).second)
          d_.error(r.pos, "step " + r.name + " is listed twice", len(r.name));
        if (check_step_ref(r)) ix_.entering[ix_.steps[r.name]].push_back(i);
      }
      check_condition(t.condition);
    }
    for (size_t s = 0; s < c_.steps.size(); ++s) {
      const Step& st = c_.steps[s];
      if (ix_.entering[s].empty() && !st.initial) {
        d_.warning(st.pos, "step " + st.name + " is not initial and no transition leads to it",
                   len(st.name));
      }
      if (ix_.leaving[s].empty()) {
        d_.warning(st.pos, "no transition leaves step " + st.name + ": once active it stays active",
                   len(st.name));
      }
    }
  }

  void check_condition(const Expr& e) {
    if (e.op != Expr::Op::kName) {
      for (const Expr& k : e.kids) check_condition(k);
      return;
    }
    const std::string step = step_of_flag(e.name);
    if (!step.empty()) {
      check_step_ref(NameRef{step, e.pos});
      return;
    }
    auto it = ix_.signals.find(e.name);
    if (it == ix_.signals.end()) {
      const std::string hint = ix_.steps.count(e.name)
                                   ? "; a step's active flag is written " + e.name + ".X"
                                   : closest_name(e.name, signal_names_);
      d_.error(e.pos, "unknown signal '" + e.name + "'" + hint, len(e.name));
      return;
    }
    const Signal& s = c_.signals[it->second];
    if (s.call) {
      const BlockSpec* spec = find_block(s.call->block);
      if (spec && spec->has_output && spec->out_kind == Kind::kAnalog) {
        d_.error(e.pos,
                 "a condition needs a digital signal, but " + e.name + " is analog (" +
                     s.call->block + ")",
                 len(e.name));
      }
    }
  }

  void check_place(const std::string& name, SourcePos pos) {
    if (!ix_.places.count(name)) {
      d_.error(pos, "unknown plant place '" + name + "'" + closest_name(name, place_names_),
               len(name));
    }
  }

  void check_plant() {
    for (const Module& m : c_.modules) {
      uint32_t initial = 0;
      for (const PlaceDecl& p : m.places) initial += p.initial ? 1 : 0;
      if (initial != 1) {
        d_.error(m.pos,
                 "module " + m.name + " needs exactly one initial place (marked with '*'), found " +
                     std::to_string(initial),
                 len(m.name));
      }
    }
    for (const Event& e : c_.events) {
      check_place(e.from.name, e.from.pos);
      check_place(e.to.name, e.to.pos);
      auto a = ix_.places.find(e.from.name), b = ix_.places.find(e.to.name);
      if (a != ix_.places.end() && b != ix_.places.end() && a->second.module != b->second.module) {
        d_.error(e.to.pos, "event " + e.name + " moves a token between two modules (" +
                               c_.modules[a->second.module].name + " and " +
                               c_.modules[b->second.module].name +
                               "); an event stays in its module");
      }
      for (const NameRef& r : e.reads) {
        if (!ix_.steps.count(r.name) && !ix_.places.count(r.name)) {
          std::vector<std::string> both = step_names_;
          both.insert(both.end(), place_names_.begin(), place_names_.end());
          d_.error(r.pos,
                   "WHILE names '" + r.name + "', which is neither a step nor a plant place" +
                       closest_name(r.name, both),
                   len(r.name));
        }
      }
    }
  }

  const Chart& c_;
  DiagnosticList& d_;
  ChartIndex ix_;
  std::unordered_map<std::string, std::pair<std::string, uint32_t>> owner_;
  std::vector<std::string> step_names_, signal_names_, place_names_;
};

}  // namespace

ChartIndex check_chart(const Chart& chart, DiagnosticList& diags) {
  return Checker(chart, diags).run();
}

}  // namespace rtplc::lang::sfc
