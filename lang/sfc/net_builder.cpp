// SFC chart -> hierarchical Petri net (see net_builder.h; spec petri-sfc.md,
// "SFC -> hierarchical PN" and "Composition").
#include "lang/sfc/net_builder.h"

#include <algorithm>
#include <set>
#include <sstream>

#include "lang/sfc/builder.h"

namespace rtplc::lang::sfc {
namespace {

constexpr size_t kMaxAlternatives = 64;

// A condition in disjunctive normal form: alternatives of conjunctions of
// place reads. nullopt = more than kMaxAlternatives.
using Conjunction = std::set<std::string>;  // places read
using Dnf = std::vector<Conjunction>;

class NetBuilder {
 public:
  NetBuilder(const Chart& c, const ChartIndex& ix, DiagnosticList& d) : c_(c), ix_(ix), d_(d) {}

  std::optional<SfcNet> run() {
    SfcNet out;
    out.hierarchy = petri::HierarchicalNet(c_.name.empty() ? "sfc" : c_.name);
    petri::HierarchicalNet& h = out.hierarchy;
    // Rule 1: steps, then main-loop modules.
    for (const Step& st : c_.steps) step_place_.push_back(h.add_step(st.name, st.initial).value());
    for (const Module& m : c_.modules) {
      if (!m.main) continue;
      for (const PlaceDecl& p : m.places)
        main_places_.push_back(h.add_main_place(p.name, p.initial ? 1 : 0).value());
    }
    // Rule 2: one sub-PN per step; a plant module's places belong to the
    // first step that lists it (HierarchicalNet keeps each place in one sub).
    std::vector<std::vector<size_t>> members = sub_members();
    std::vector<size_t> subs;
    for (size_t s = 0; s < c_.steps.size(); ++s)
      subs.push_back(h.add_subnet("sub." + c_.steps[s].name, step_place_[s]));
    std::vector<bool> placed(c_.modules.size(), false);
    for (size_t s = 0; s < c_.steps.size(); ++s) {
      for (size_t m : members[s]) {
        if (placed[m] || c_.modules[m].main) continue;
        placed[m] = true;
        for (const PlaceDecl& p : c_.modules[m].places)
          h.add_sub_place(subs[s], p.name, p.initial ? 1 : 0).value();
      }
    }
    for (size_t m = 0; m < c_.modules.size(); ++m) {
      if (placed[m] || c_.modules[m].main) continue;
      for (const PlaceDecl& p : c_.modules[m].places)
        h.net().add_place(p.name, p.initial ? 1 : 0).value();
    }
    petri::Net& net = h.net();
    // Rule 1 and 4: main-loop transitions reading their conditions' places.
    for (const Transition& t : c_.transitions) {
      std::optional<Dnf> dnf = to_dnf(t.condition);
      if (!dnf) {
        d_.error(t.condition.pos, "condition of " + t.name + " has more than " +
                                      std::to_string(kMaxAlternatives) +
                                      " alternatives: too large for the net");
        return std::nullopt;
      }
      const size_t source_sub = subs[ix_.steps.at(t.from[0].name)];
      for (size_t a = 0; a < dnf->size(); ++a) {
        const std::string id = a == 0 ? t.name : t.name + "." + std::to_string(a + 1);
        auto tr = h.add_step_transition(id);
        if (!tr) {
          d_.error(t.pos, tr.error());
          return std::nullopt;
        }
        for (const NameRef& r : t.from) h.leave(step_place_[ix_.steps.at(r.name)], *tr);
        for (const NameRef& r : t.to) h.enter(*tr, step_place_[ix_.steps.at(r.name)]);
        for (const std::string& place : (*dnf)[a]) {
          const petri::PlaceId p = *net.find_place(place);
          // A step's own place is already an input; reading it again would double the weight.
          if (net.pre(p, *tr) != 0) continue;
          h.finishes(source_sub, p, *tr);
        }
      }
    }
    // Rule 3: plant events, reading steps (the sub-PN starts when its step is marked) and places.
    for (const Event& e : c_.events) {
      // HierarchicalNet keeps transitions in one list; the sub-PN an event
      // belongs to is decided by its module (events_of below).
      auto tr = h.add_sub_transition(0, e.name);
      if (!tr) {
        d_.error(e.pos, tr.error());
        return std::nullopt;
      }
      net.add_input(*net.find_place(e.from.name), *tr);
      net.add_output(*tr, *net.find_place(e.to.name));
      for (const NameRef& r : e.reads) {
        auto st = ix_.steps.find(r.name);
        if (st != ix_.steps.end()) {
          h.starts_on(subs[st->second], *tr);
        } else {
          const petri::PlaceId p = *net.find_place(r.name);
          if (net.pre(p, *tr) == 0 && net.post(p, *tr) == 0) net.add_read(p, *tr);
        }
      }
    }
    // The paper's sub-PN matrices and the composition modules.
    const petri::IntMatrix whole = net.incidence();
    out.modules.push_back(main_module(net, whole));
    std::vector<bool> listed(c_.modules.size(), false);
    for (size_t s = 0; s < c_.steps.size(); ++s) {
      SubNet sn;
      sn.step = c_.steps[s].name;
      std::vector<size_t> mods;
      for (size_t m : members[s]) {
        if (!c_.modules[m].main) mods.push_back(m);
      }
      for (size_t m : mods) {
        sn.modules.push_back(c_.modules[m].name);
        listed[m] = true;
        out.modules.push_back(device_module(net, whole, m));
      }
      fill_subnet(net, whole, mods, sn);
      out.subnets.push_back(std::move(sn));
    }
    for (size_t m = 0; m < c_.modules.size(); ++m) {
      if (!listed[m] && !c_.modules[m].main) out.modules.push_back(device_module(net, whole, m));
    }
    return out;
  }

 private:
  std::vector<petri::PlaceId> main_loop_places() const {
    std::vector<petri::PlaceId> v = step_place_;
    v.insert(v.end(), main_places_.begin(), main_places_.end());
    return v;
  }

  // The main loop's block of B: its places and the transitions that move
  // their tokens (sub-PN events only read them: zero columns, left out).
  petri::Module main_module(const petri::Net& net, const petri::IntMatrix& whole) const {
    petri::Module mod;
    mod.name = "main";
    const std::vector<petri::PlaceId> ps = main_loop_places();
    std::vector<petri::TransitionId> ts;
    for (petri::TransitionId t = 0; t < net.transition_count(); ++t) {
      bool moves = false;
      for (petri::PlaceId p : ps) moves = moves || whole(p, t) != 0;
      if (moves) ts.push_back(t);
    }
    mod.b = petri::IntMatrix(ps.size(), ts.size());
    for (size_t i = 0; i < ps.size(); ++i) {
      mod.places.push_back(net.place(ps[i]).id);
      for (size_t j = 0; j < ts.size(); ++j) mod.b(i, j) = whole(ps[i], ts[j]);
    }
    for (petri::TransitionId t : ts) mod.transitions.push_back(net.transition(t).id);
    return mod;
  }

  size_t module_of_place(const std::string& place) const { return ix_.places.at(place).module; }

  // Rule 2: a step's SUBNET, or by default the modules its events and leaving transitions touch.
  std::vector<std::vector<size_t>> sub_members() const {
    std::vector<std::vector<size_t>> out(c_.steps.size());
    for (size_t s = 0; s < c_.steps.size(); ++s) {
      const Step& st = c_.steps[s];
      std::vector<size_t>& v = out[s];
      auto add = [&v](size_t m) {
        if (std::find(v.begin(), v.end(), m) == v.end()) v.push_back(m);
      };
      if (!st.subnet.empty()) {
        for (const NameRef& r : st.subnet) add(ix_.modules.at(r.name));
        continue;
      }
      for (const Event& e : c_.events) {
        for (const NameRef& r : e.reads) {
          if (r.name == st.name) add(module_of_place(e.from.name));
        }
      }
      for (size_t t : ix_.leaving[s]) {
        std::optional<Dnf> dnf = to_dnf(c_.transitions[t].condition);
        if (!dnf) continue;
        for (const Conjunction& cj : *dnf) {
          for (const std::string& p : cj) {
            if (ix_.places.count(p)) add(module_of_place(p));
          }
        }
      }
    }
    return out;
  }

  std::vector<petri::TransitionId> events_of(const petri::Net& net,
                                             const std::vector<size_t>& mods) const {
    std::vector<petri::TransitionId> ts;
    for (const Event& e : c_.events) {
      const size_t m = module_of_place(e.from.name);
      if (std::find(mods.begin(), mods.end(), m) != mods.end())
        ts.push_back(*net.find_transition(e.name));
    }
    std::sort(ts.begin(), ts.end());
    return ts;
  }

  std::vector<petri::PlaceId> places_of(const petri::Net& net,
                                        const std::vector<size_t>& mods) const {
    std::vector<petri::PlaceId> ps;
    for (size_t m : mods) {
      for (const PlaceDecl& p : c_.modules[m].places) ps.push_back(*net.find_place(p.name));
    }
    return ps;
  }

  petri::Module device_module(const petri::Net& net, const petri::IntMatrix& whole,
                              size_t m) const {
    petri::Module mod;
    mod.name = c_.modules[m].name;
    const std::vector<petri::PlaceId> ps = places_of(net, {m});
    const std::vector<petri::TransitionId> ts = events_of(net, {m});
    mod.b = petri::IntMatrix(ps.size(), ts.size());
    for (size_t i = 0; i < ps.size(); ++i) {
      mod.places.push_back(net.place(ps[i]).id);
      for (size_t j = 0; j < ts.size(); ++j) mod.b(i, j) = whole(ps[i], ts[j]);
    }
    for (petri::TransitionId t : ts) mod.transitions.push_back(net.transition(t).id);
    return mod;
  }

  void fill_subnet(const petri::Net& net, const petri::IntMatrix& whole,
                   const std::vector<size_t>& mods, SubNet& sn) const {
    const std::vector<petri::PlaceId> ps = places_of(net, mods);
    const std::vector<petri::TransitionId> ts = events_of(net, mods);
    sn.b = petri::IntMatrix(ps.size(), ts.size());
    for (size_t i = 0; i < ps.size(); ++i) {
      sn.places.push_back(net.place(ps[i]).id);
      sn.initial.push_back(net.place(ps[i]).initial);
      for (size_t j = 0; j < ts.size(); ++j) sn.b(i, j) = whole(ps[i], ts[j]);
    }
    for (petri::TransitionId t : ts) sn.transitions.push_back(net.transition(t).id);
  }

  // The literal `name` (or its negation) as the place it reads; "" = free.
  std::string literal_place(const std::string& name, bool positive) const {
    const std::string step = step_of_flag(name);
    if (!step.empty()) return positive ? step : "";
    auto it = ix_.signals.find(name);
    if (it == ix_.signals.end()) return "";
    const Signal& s = c_.signals[it->second];
    if (s.model_on.empty()) return "";
    return positive ? s.model_on : s.model_off;
  }

  std::optional<Dnf> to_dnf(const Expr& e, bool positive = true) const {
    switch (e.op) {
      case Expr::Op::kTrue:
      case Expr::Op::kFalse:
        if ((e.op == Expr::Op::kTrue) == positive) return Dnf{Conjunction{}};
        return Dnf{};
      case Expr::Op::kName: {
        const std::string p = literal_place(e.name, positive);
        return Dnf{p.empty() ? Conjunction{} : Conjunction{p}};
      }
      case Expr::Op::kNot:
        return to_dnf(e.kids[0], !positive);
      case Expr::Op::kAnd:
      case Expr::Op::kOr: {
        // De Morgan: a negated AND is an OR of negations and vice versa.
        const bool is_or = (e.op == Expr::Op::kOr) == positive;
        Dnf acc = is_or ? Dnf{} : Dnf{Conjunction{}};
        for (const Expr& k : e.kids) {
          std::optional<Dnf> d = to_dnf(k, positive);
          if (!d) return std::nullopt;
          if (is_or) {
            acc.insert(acc.end(), d->begin(), d->end());
          } else {
            Dnf next;
            for (const Conjunction& a : acc) {
              for (const Conjunction& b : *d) {
                Conjunction c = a;
                c.insert(b.begin(), b.end());
                next.push_back(std::move(c));
                if (next.size() > kMaxAlternatives) return std::nullopt;
              }
            }
            acc = std::move(next);
          }
          if (acc.size() > kMaxAlternatives) return std::nullopt;
        }
        // Identical alternatives are one transition.
        std::sort(acc.begin(), acc.end());
        acc.erase(std::unique(acc.begin(), acc.end()), acc.end());
        return acc;
      }
    }
    return Dnf{};
  }

  const Chart& c_;
  const ChartIndex& ix_;
  DiagnosticList& d_;
  std::vector<petri::PlaceId> step_place_;
  std::vector<petri::PlaceId> main_places_;
};

}  // namespace

petri::Net SubNet::as_net() const {
  auto n = petri::Net::from_incidence(b, places, transitions, initial);
  return n ? std::move(n).value() : petri::Net("sub." + step);
}

std::optional<SfcNet> build_net(const Chart& chart, const ChartIndex& index,
                                DiagnosticList& diags) {
  return NetBuilder(chart, index, diags).run();
}

std::optional<SfcNet> sfc_source_to_net(std::string_view source, DiagnosticList& diags) {
  ChartIndex index;
  bool ok = false;
  Chart chart = parse_chart(source, diags, &index, &ok);
  if (!ok) return std::nullopt;
  return build_net(chart, index, diags);
}

std::string render_hierarchy(const SfcNet& n) {
  std::ostringstream o;
  const petri::Net& net = n.flat();
  o << "SFC " << net.name() << " as a hierarchical Petri net (rules 1-4)\n";
  o << "  main loop: " << n.modules.front().places.size() << " places, "
    << n.modules.front().transitions.size() << " transitions\n";
  for (const SubNet& s : n.subnets) {
    if (s.places.empty()) continue;
    o << "  sub-PN of step " << s.step << " (";
    for (size_t i = 0; i < s.modules.size(); ++i) o << (i ? ", " : "") << s.modules[i];
    o << "): " << s.places.size() << " x " << s.transitions.size() << ", initial "
      << petri::marking_vector(s.initial) << "\n";
    std::istringstream rows(s.b.to_string(s.places, s.transitions));
    for (std::string line; std::getline(rows, line);) o << "    " << line << "\n";
  }
  auto composed = petri::compose(n.modules, petri::place_ids(net), petri::transition_ids(net));
  o << "  composition B = sum B^_ik / D over " << n.modules.size() << " modules: ";
  if (!composed) {
    o << "failed: " << composed.error() << "\n";
  } else {
    o << (*composed == net.incidence() ? "equals" : "DIFFERS FROM") << " the flat net's "
      << net.place_count() << " x " << net.transition_count() << " incidence matrix\n";
  }
  o << "\n";
  return o.str();
}

}  // namespace rtplc::lang::sfc
