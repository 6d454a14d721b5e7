// P-invariants (the "S-invariants" of Cai et al. used to split a net into modules;
// spec petri-sfc.md, "What the product does"): vectors y >= 0, y != 0, with
// y^T B = 0, so y . M is the same in every reachable marking M.
//
// Computed with the Farkas algorithm over the integers: start from [B | I], and
// for each transition column combine every pair of rows with opposite signs to
// cancel it, keeping only rows of minimal support. The result is the set of
// minimal-support semi-positive invariants (each divided by the gcd of its
// entries). The number of rows can grow exponentially; past a cap the
// computation stops and says so.
//
// A place in the support of an invariant y is structurally bounded by
// floor(y . M0 / y_p): that bound sizes the place's field in the marking store.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lang/petri/net.h"

namespace rtplc::petri {

struct PInvariant {
  std::vector<int64_t> weights;  // one per place, >= 0
  int64_t token_sum = 0;         // y . M0, the same in every reachable marking
};

struct InvariantResult {
  std::vector<PInvariant> invariants;
  bool complete = true;  // false when the row cap stopped the computation
  bool covered = false;  // every place lies in the support of some invariant
};

InvariantResult p_invariants(const Net& net, size_t max_rows = 20000);

// Structural bound of each place from the invariants (nullopt where none covers it).
std::vector<std::optional<uint64_t>> structural_bounds(const Net& net, const InvariantResult& inv);

// "Think_1 + Eat_1 + 2*Fork_2 = 3".
std::string invariant_text(const Net& net, const PInvariant& y);

}  // namespace rtplc::petri
