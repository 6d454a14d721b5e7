// Module composition B = sum_k B^_ik / D and the hierarchical net builder
// (see compose.h; spec petri-sfc.md, "Composition").
#include "lang/petri/compose.h"

#include <map>
#include <unordered_map>

namespace rtplc::petri {

Result<IntMatrix> compose(const std::vector<Module>& modules,
                          const std::vector<std::string>& places,
                          const std::vector<std::string>& transitions) {
  std::unordered_map<std::string, size_t> row, col;
  for (size_t i = 0; i < places.size(); ++i) row[places[i]] = i;
  for (size_t j = 0; j < transitions.size(); ++j) col[transitions[j]] = j;
  // Sum of B^_ik over the occurrences of each module name, and D per name.
  std::map<std::string, std::pair<IntMatrix, int64_t>> per_module;
  for (const Module& m : modules) {
    if (m.b.rows() != m.places.size() || m.b.cols() != m.transitions.size()) {
      return make_error("module " + m.name + ": its matrix is not places x transitions");
    }
    auto [it, fresh] =
        per_module.try_emplace(m.name, IntMatrix(places.size(), transitions.size()), 0);
    IntMatrix& sum = it->second.first;
    ++it->second.second;
    for (size_t i = 0; i < m.places.size(); ++i) {
      auto r = row.find(m.places[i]);
      if (r == row.end())
        return make_error("module " + m.name + ": place " + m.places[i] + " is not in the net");
      for (size_t j = 0; j < m.transitions.size(); ++j) {
        auto c = col.find(m.transitions[j]);
        if (c == col.end()) {
          return make_error("module " + m.name + ": transition " + m.transitions[j] +
                            " is not in the net");
        }
        sum(r->second, c->second) += m.b(i, j);
      }
    }
  }
  IntMatrix b(places.size(), transitions.size());
  std::vector<const std::string*> owner(places.size() * transitions.size(), nullptr);
  for (const auto& [name, entry] : per_module) {
    const auto& [sum, d] = entry;
    for (size_t i = 0; i < places.size(); ++i) {
      for (size_t j = 0; j < transitions.size(); ++j) {
        if (sum(i, j) == 0) continue;
        if (sum(i, j) % d != 0) {
          return make_error("module " + name + " is listed " + std::to_string(d) +
                            " times with different entries at (" + places[i] + ", " +
                            transitions[j] + ")");
        }
        const std::string*& who = owner[i * transitions.size() + j];
        if (who) {
          return make_error("modules " + *who + " and " + name + " both define the entry (" +
                            places[i] + ", " + transitions[j] + ")");
        }
        who = &name;
        b(i, j) = sum(i, j) / d;
      }
    }
  }
  return b;
}

Module module_of(const Net& net, std::string name, const std::vector<PlaceId>& places) {
  Module m;
  m.name = std::move(name);
  std::vector<TransitionId> ts;
  for (TransitionId t = 0; t < net.transition_count(); ++t) {
    bool touches = false;
    for (PlaceId p : places) touches = touches || net.pre(p, t) != 0 || net.post(p, t) != 0;
    if (touches) ts.push_back(t);
  }
  const IntMatrix whole = net.incidence();
  m.b = IntMatrix(places.size(), ts.size());
  for (size_t i = 0; i < places.size(); ++i) {
    m.places.push_back(net.place(places[i]).id);
    for (size_t j = 0; j < ts.size(); ++j) m.b(i, j) = whole(places[i], ts[j]);
  }
  for (TransitionId t : ts) m.transitions.push_back(net.transition(t).id);
  return m;
}

Result<std::vector<Module>> modules_from_invariants(const Net& net, const InvariantResult& inv) {
  std::vector<bool> taken(net.place_count(), false);
  std::vector<Module> out;
  for (size_t k = 0; k < inv.invariants.size(); ++k) {
    std::vector<PlaceId> support;
    bool overlaps = false;
    for (size_t p = 0; p < net.place_count(); ++p) {
      if (inv.invariants[k].weights[p] == 0) continue;
      overlaps = overlaps || taken[p];
      support.push_back(static_cast<PlaceId>(p));
    }
    if (overlaps) continue;
    for (PlaceId p : support) taken[p] = true;
    out.push_back(module_of(net, "invariant" + std::to_string(k + 1), support));
  }
  for (size_t p = 0; p < net.place_count(); ++p) {
    if (!taken[p]) {
      return make_error("place " + net.place(static_cast<PlaceId>(p)).id +
                        " lies in no invariant disjoint from the others taken");
    }
  }
  return out;
}

std::vector<std::string> place_ids(const Net& net) {
  std::vector<std::string> v;
  for (PlaceId p = 0; p < net.place_count(); ++p) v.push_back(net.place(p).id);
  return v;
}
std::vector<std::string> transition_ids(const Net& net) {
  std::vector<std::string> v;
  for (TransitionId t = 0; t < net.transition_count(); ++t) v.push_back(net.transition(t).id);
  return v;
}

Result<PlaceId> HierarchicalNet::add_step(std::string id, bool initial) {
  return add_main_place(std::move(id), initial ? 1 : 0);
}

Result<PlaceId> HierarchicalNet::add_main_place(std::string id, uint32_t initial) {
  auto p = net_.add_place(std::move(id), initial);
  if (p) main_places_.push_back(*p);
  return p;
}

Result<TransitionId> HierarchicalNet::add_step_transition(std::string id) {
  return net_.add_transition(std::move(id));
}

size_t HierarchicalNet::add_subnet(std::string name, PlaceId step) {
  subs_.push_back(Sub{std::move(name), step, {}});
  return subs_.size() - 1;
}

Result<PlaceId> HierarchicalNet::add_sub_place(size_t sub, std::string id, uint32_t initial) {
  auto p = net_.add_place(std::move(id), initial);
  if (p) subs_[sub].places.push_back(*p);
  return p;
}

Result<TransitionId> HierarchicalNet::add_sub_transition(size_t /*sub*/, std::string id) {
  return net_.add_transition(std::move(id));
}

void HierarchicalNet::starts_on(size_t sub, TransitionId t) {
  net_.add_read(subs_[sub].step, t);
}

void HierarchicalNet::finishes(size_t /*sub*/, PlaceId output, TransitionId t) {
  net_.add_read(output, t);
}

std::vector<Module> HierarchicalNet::modules() const {
  std::vector<Module> out;
  out.push_back(module_of(net_, "main", main_places_));
  for (const Sub& s : subs_) out.push_back(module_of(net_, s.name, s.places));
  return out;
}

}  // namespace rtplc::petri
