// The P/T net model (spec petri-sfc.md, "Petri net definitions used"):
// C = {P, T, I, O} with arc weights #(p, I(t)) and #(p, O(t)), the matrices
// B- (input), B+ (output) and B = B+ - B-, firing rules 1-3 and the state equation
// x(k+1) = x(k) + B f(k).
//
// A net is built with add_place / add_transition / add_input / add_output. A read
// arc (the paper's "reference relation" <->: a sub-PN reads a main-loop place
// without consuming it) is an input and an output of the same weight: the
// transition needs the tokens but leaves them, so its column of B is zero there.
// Nets built from other nets (compose.h, the SFC compiler) use the same calls.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "common/result.h"
#include "lang/petri/matrix.h"

namespace rtplc::petri {

using PlaceId = uint32_t;
using TransitionId = uint32_t;
using Marking = std::vector<uint32_t>;  // tokens per place, indexed by PlaceId

struct Place {
  std::string id;     // unique within the net (PNML id)
  std::string label;  // human name; empty = same as id
  uint32_t initial = 0;
};

struct Transition {
  std::string id;
  std::string label;
};

// One weighted connection between a place and a transition, seen from the transition.
struct ArcEnd {
  PlaceId place = 0;
  uint32_t weight = 1;
};

class Net {
 public:
  explicit Net(std::string name = "net") : name_(std::move(name)) {}

  // Ids must be unique among places and transitions; a repeated id is an error.
  Result<PlaceId> add_place(std::string id, uint32_t initial = 0, std::string label = "");
  Result<TransitionId> add_transition(std::string id, std::string label = "");
  // p -> t with weight w (adds to an existing arc's weight).
  void add_input(PlaceId p, TransitionId t, uint32_t w = 1);
  // t -> p with weight w.
  void add_output(TransitionId t, PlaceId p, uint32_t w = 1);
  // p <-> t: t needs w tokens in p and leaves them there.
  void add_read(PlaceId p, TransitionId t, uint32_t w = 1);
  void set_initial(PlaceId p, uint32_t tokens) { places_[p].initial = tokens; }
  void set_name(std::string n) { name_ = std::move(n); }

  // A net whose B- and B+ are the negative and positive parts of `b` (no self-loops),
  // with the given names (spec example: the sub-PN of step S1).
  static Result<Net> from_incidence(const IntMatrix& b, const std::vector<std::string>& places,
                                    const std::vector<std::string>& transitions,
                                    const Marking& initial);

  const std::string& name() const { return name_; }
  size_t place_count() const { return places_.size(); }
  size_t transition_count() const { return transitions_.size(); }
  const Place& place(PlaceId p) const { return places_[p]; }
  const Transition& transition(TransitionId t) const { return transitions_[t]; }
  const std::string& place_label(PlaceId p) const;
  const std::string& transition_label(TransitionId t) const;
  std::optional<PlaceId> find_place(std::string_view id) const;
  std::optional<TransitionId> find_transition(std::string_view id) const;

  // Pre-set and post-set of t, each place once, in order of first connection.
  const std::vector<ArcEnd>& inputs(TransitionId t) const { return pre_[t]; }
  const std::vector<ArcEnd>& outputs(TransitionId t) const { return post_[t]; }
  uint32_t pre(PlaceId p, TransitionId t) const;   // #(p, I(t))
  uint32_t post(PlaceId p, TransitionId t) const;  // #(p, O(t))
  size_t arc_count() const;

  IntMatrix input_matrix() const;   // B-
  IntMatrix output_matrix() const;  // B+
  IntMatrix incidence() const;      // B = B+ - B-
  Marking initial_marking() const;

  // Rule 1: t may fire iff mu(p) >= #(p, I(t)) for every p.
  bool enabled(const Marking& m, TransitionId t) const;
  // Rule 2: the marking after firing an enabled t (tokens saturate at UINT32_MAX).
  Marking fire(const Marking& m, TransitionId t) const;

 private:
  std::string name_;
  std::vector<Place> places_;
  std::vector<Transition> transitions_;
  std::vector<std::vector<ArcEnd>> pre_;
  std::vector<std::vector<ArcEnd>> post_;
  std::unordered_map<std::string, uint32_t> place_index_;
  std::unordered_map<std::string, uint32_t> transition_index_;
};

// The state equation x(k+1) = x(k) + B f(k) for a firing vector f of 0/1 (one entry
// per transition). Rule 3: several 1s are a sequence of single firings, which is
// order-independent exactly when x(k) >= B- f; otherwise the transitions conflict
// (they compete for the same tokens) and the error names them.
Result<Marking> state_equation_step(const Net& net, const Marking& x, const std::vector<int>& f);

// Fires a sequence of transitions from m; the error names the first one not enabled.
Result<Marking> fire_sequence(const Net& net, Marking m, const std::vector<TransitionId>& seq);

// "[1 0 2]" and "p1, p3*2" renderings of a marking.
std::string marking_vector(const Marking& m);
std::string marking_text(const Net& net, const Marking& m);

}  // namespace rtplc::petri
