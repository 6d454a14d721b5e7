// Modules and hierarchical nets (spec petri-sfc.md, "SFC -> hierarchical PN" and
// "Composition"; issue item 2).
//
// A module is one block of the whole net's incidence matrix: b_ij(x*y) for x
// places and y transitions, named by their ids (Definition 1). compose() places
// each module's block in the whole m x n matrix (B^_ik, Definition 2), adds them up,
// and divides each module's sum by D, the number of times that module was listed
// (Definitions 3-4): B = sum_k B^_ik / D. Distinct modules must not both define
// the same entry; the caller compares the result with the flat net's B.
//
// HierarchicalNet builds a net by the paper's rules so the SFC compiler can use it:
//   rule 1  add_step / add_step_transition / leave / enter: the main loop, where the token moves
//   rule 2  add_subnet: the sub-PN of a step's actions
//   rule 3  starts_on: a sub-PN transition reads the step's place (read arc, "<->")
//   rule 4  finishes: the sub-PN's output place is read by the main-loop transition
// Tokens never cross between the main loop and a sub-PN: every connection between
// them is a read arc. flat() is the whole net; modules() its main loop and sub-PNs.
#pragma once

#include <string>
#include <vector>

#include "common/result.h"
#include "lang/petri/invariants.h"
#include "lang/petri/matrix.h"
#include "lang/petri/net.h"

namespace rtplc::petri {

struct Module {
  std::string name;
  std::vector<std::string> places;       // row ids
  std::vector<std::string> transitions;  // column ids
  IntMatrix b;                           // places.size() x transitions.size()
};

Result<IntMatrix> compose(const std::vector<Module>& modules,
                          const std::vector<std::string>& places,
                          const std::vector<std::string>& transitions);

// The block of `net` for the given places and every transition connected to them.
Module module_of(const Net& net, std::string name, const std::vector<PlaceId>& places);

// Cai et al.'s split: one module per P-invariant (a token loop), taking the
// invariants in order and skipping any that shares a place with one already
// taken; an error names a place that no taken invariant covers.
Result<std::vector<Module>> modules_from_invariants(const Net& net, const InvariantResult& inv);

std::vector<std::string> place_ids(const Net& net);
std::vector<std::string> transition_ids(const Net& net);

class HierarchicalNet {
 public:
  explicit HierarchicalNet(std::string name) : net_(std::move(name)) {}

  // Rule 1: the main loop.
  Result<PlaceId> add_step(std::string id, bool initial = false);
  Result<TransitionId> add_step_transition(std::string id);
  // The token moves from step `from` through t, or from t to step `to`.
  void leave(PlaceId from, TransitionId t) { net_.add_input(from, t); }
  void enter(TransitionId t, PlaceId to) { net_.add_output(t, to); }
  // Main-loop places that are not steps (e.g. the operator's push button P0/P1).
  Result<PlaceId> add_main_place(std::string id, uint32_t initial = 0);

  // Rule 2: a sub-PN for step `step`; returns its number.
  size_t add_subnet(std::string name, PlaceId step);
  Result<PlaceId> add_sub_place(size_t sub, std::string id, uint32_t initial = 0);
  Result<TransitionId> add_sub_transition(size_t sub, std::string id);
  // Rule 3: sub-PN transition t may fire only while the sub-PN's step is marked.
  void starts_on(size_t sub, TransitionId t);
  // Rule 4: main-loop transition t needs the sub-PN's output place marked.
  void finishes(size_t sub, PlaceId output, TransitionId t);

  Net& net() { return net_; }  // arcs inside one module go through here
  const Net& flat() const { return net_; }
  std::vector<Module> modules() const;

 private:
  struct Sub {
    std::string name;
    PlaceId step;
    std::vector<PlaceId> places;
  };
  Net net_;
  std::vector<PlaceId> main_places_;
  std::vector<Sub> subs_;
};

}  // namespace rtplc::petri
