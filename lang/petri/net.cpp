// The P/T net model: construction, B-, B+, B, firing rules 1-3 and the state
// equation (spec petri-sfc.md, "Petri net definitions used").
#include "lang/petri/net.h"

#include <algorithm>
#include <limits>

namespace rtplc::petri {

Result<PlaceId> Net::add_place(std::string id, uint32_t initial, std::string label) {
  if (place_index_.count(id) || transition_index_.count(id)) {
    return make_error("the id '" + id + "' is used twice");
  }
  const auto p = static_cast<PlaceId>(places_.size());
  place_index_.emplace(id, p);
  places_.push_back(Place{std::move(id), std::move(label), initial});
  return p;
}

Result<TransitionId> Net::add_transition(std::string id, std::string label) {
  if (place_index_.count(id) || transition_index_.count(id)) {
    return make_error("the id '" + id + "' is used twice");
  }
  const auto t = static_cast<TransitionId>(transitions_.size());
  transition_index_.emplace(id, t);
  transitions_.push_back(Transition{std::move(id), std::move(label)});
  pre_.emplace_back();
  post_.emplace_back();
  return t;
}

namespace {
void add_weight(std::vector<ArcEnd>& ends, PlaceId p, uint32_t w) {
  for (ArcEnd& e : ends) {
    if (e.place == p) {
      const uint64_t sum = uint64_t{e.weight} + w;
      e.weight = sum > std::numeric_limits<uint32_t>::max() ? std::numeric_limits<uint32_t>::max()
                                                            : static_cast<uint32_t>(sum);
      return;
    }
  }
  ends.push_back(ArcEnd{p, w});
}
}  // namespace

void Net::add_input(PlaceId p, TransitionId t, uint32_t w) {
  add_weight(pre_[t], p, w);
}
void Net::add_output(TransitionId t, PlaceId p, uint32_t w) {
  add_weight(post_[t], p, w);
}
void Net::add_read(PlaceId p, TransitionId t, uint32_t w) {
  add_input(p, t, w);
  add_output(t, p, w);
}

Result<Net> Net::from_incidence(const IntMatrix& b, const std::vector<std::string>& places,
                                const std::vector<std::string>& transitions,
                                const Marking& initial) {
  if (b.rows() != places.size() || b.cols() != transitions.size() ||
      initial.size() != places.size()) {
    return make_error("the incidence matrix, the names and the marking disagree in size");
  }
  Net net;
  for (size_t i = 0; i < places.size(); ++i) {
    auto p = net.add_place(places[i], initial[i]);
    if (!p) return make_error(p.error());
  }
  for (const std::string& name : transitions) {
    auto t = net.add_transition(name);
    if (!t) return make_error(t.error());
  }
  for (size_t i = 0; i < b.rows(); ++i) {
    for (size_t j = 0; j < b.cols(); ++j) {
      const int64_t v = b(i, j);
      if (v < 0)
        net.add_input(static_cast<PlaceId>(i), static_cast<TransitionId>(j),
                      static_cast<uint32_t>(-v));
      if (v > 0)
        net.add_output(static_cast<TransitionId>(j), static_cast<PlaceId>(i),
                       static_cast<uint32_t>(v));
    }
  }
  return net;
}

const std::string& Net::place_label(PlaceId p) const {
  return places_[p].label.empty() ? places_[p].id : places_[p].label;
}
const std::string& Net::transition_label(TransitionId t) const {
  return transitions_[t].label.empty() ? transitions_[t].id : transitions_[t].label;
}

std::optional<PlaceId> Net::find_place(std::string_view id) const {
  auto it = place_index_.find(std::string(id));
  if (it == place_index_.end()) return std::nullopt;
  return it->second;
}
std::optional<TransitionId> Net::find_transition(std::string_view id) const {
  auto it = transition_index_.find(std::string(id));
  if (it == transition_index_.end()) return std::nullopt;
  return it->second;
}

uint32_t Net::pre(PlaceId p, TransitionId t) const {
  for (const ArcEnd& e : pre_[t]) {
    if (e.place == p) return e.weight;
  }
  return 0;
}
uint32_t Net::post(PlaceId p, TransitionId t) const {
  for (const ArcEnd& e : post_[t]) {
    if (e.place == p) return e.weight;
  }
  return 0;
}

size_t Net::arc_count() const {
  size_t n = 0;
  for (size_t t = 0; t < transitions_.size(); ++t) n += pre_[t].size() + post_[t].size();
  return n;
}

IntMatrix Net::input_matrix() const {
  IntMatrix m(places_.size(), transitions_.size());
  for (size_t t = 0; t < transitions_.size(); ++t) {
    for (const ArcEnd& e : pre_[t]) m(e.place, t) = e.weight;
  }
  return m;
}
IntMatrix Net::output_matrix() const {
  IntMatrix m(places_.size(), transitions_.size());
  for (size_t t = 0; t < transitions_.size(); ++t) {
    for (const ArcEnd& e : post_[t]) m(e.place, t) = e.weight;
  }
  return m;
}
IntMatrix Net::incidence() const {
  IntMatrix m(places_.size(), transitions_.size());
  for (size_t t = 0; t < transitions_.size(); ++t) {
    for (const ArcEnd& e : post_[t]) m(e.place, t) += e.weight;
    for (const ArcEnd& e : pre_[t]) m(e.place, t) -= e.weight;
  }
  return m;
}

Marking Net::initial_marking() const {
  Marking m(places_.size());
  for (size_t p = 0; p < places_.size(); ++p) m[p] = places_[p].initial;
  return m;
}

bool Net::enabled(const Marking& m, TransitionId t) const {
  for (const ArcEnd& e : pre_[t]) {
    if (m[e.place] < e.weight) return false;
  }
  return true;
}

Marking Net::fire(const Marking& m, TransitionId t) const {
  Marking out = m;
  for (const ArcEnd& e : pre_[t]) out[e.place] -= e.weight;
  for (const ArcEnd& e : post_[t]) {
    const uint64_t v = uint64_t{out[e.place]} + e.weight;
    out[e.place] = v > std::numeric_limits<uint32_t>::max() ? std::numeric_limits<uint32_t>::max()
                                                            : static_cast<uint32_t>(v);
  }
  return out;
}

Result<Marking> state_equation_step(const Net& net, const Marking& x, const std::vector<int>& f) {
  if (x.size() != net.place_count() || f.size() != net.transition_count()) {
    return make_error("the marking or the firing vector has the wrong length");
  }
  // Rule 1 for each transition on its own, then jointly (x >= B- f).
  std::vector<uint64_t> need(net.place_count(), 0);
  std::vector<TransitionId> firing;
  for (size_t j = 0; j < f.size(); ++j) {
    if (f[j] == 0) continue;
    if (f[j] != 1) return make_error("a firing vector holds only 0 and 1");
    const auto t = static_cast<TransitionId>(j);
    if (!net.enabled(x, t)) {
      return make_error("transition " + net.transition_label(t) + " is not enabled");
    }
    firing.push_back(t);
    for (const ArcEnd& e : net.inputs(t)) need[e.place] += e.weight;
  }
  for (size_t p = 0; p < need.size(); ++p) {
    if (need[p] <= x[p]) continue;
    std::string who;
    for (TransitionId t : firing) {
      if (net.pre(static_cast<PlaceId>(p), t) == 0) continue;
      who += (who.empty() ? "" : ", ") + net.transition_label(t);
    }
    return make_error("transitions " + who + " conflict over place " +
                      net.place_label(static_cast<PlaceId>(p)) +
                      ": their order matters, so they cannot fire in one step (rule 3)");
  }
  const IntMatrix b = net.incidence();
  Marking out = x;
  for (size_t p = 0; p < out.size(); ++p) {
    int64_t v = x[p];
    for (TransitionId t : firing) v += b(p, t);
    out[p] = static_cast<uint32_t>(std::clamp<int64_t>(v, 0, std::numeric_limits<uint32_t>::max()));
  }
  return out;
}

Result<Marking> fire_sequence(const Net& net, Marking m, const std::vector<TransitionId>& seq) {
  for (size_t i = 0; i < seq.size(); ++i) {
    if (!net.enabled(m, seq[i])) {
      return make_error("step " + std::to_string(i + 1) + ": transition " +
                        net.transition_label(seq[i]) + " is not enabled");
    }
    m = net.fire(m, seq[i]);
  }
  return m;
}

std::string marking_vector(const Marking& m) {
  std::string s = "[";
  for (size_t i = 0; i < m.size(); ++i) {
    if (i) s += ' ';
    s += std::to_string(m[i]);
  }
  return s + "]";
}

std::string marking_text(const Net& net, const Marking& m) {
  std::string s;
  for (size_t p = 0; p < m.size(); ++p) {
    if (m[p] == 0) continue;
    if (!s.empty()) s += ", ";
    s += net.place_label(static_cast<PlaceId>(p));
    if (m[p] != 1) s += "*" + std::to_string(m[p]);
  }
  return s.empty() ? "(empty)" : s;
}

}  // namespace rtplc::petri
