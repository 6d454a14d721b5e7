// `rtplc analyze`'s work and its two renderings (issue item 3, "Analysis"):
// P-invariants first (they bound places structurally and size the marking store),
// then the reachability graph; rendered as text for people or as JSON for tools.
//
// JSON fields (docs/petri.md lists them all): places, transitions, arcs, status,
// bounded, markings, edges, dead_markings (a count), dead_marking_examples,
// max_tokens_in_place, safe, dead_transitions (names), p_invariants, pump,
// seconds, markings_per_second, bytes_per_marking.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lang/petri/invariants.h"
#include "lang/petri/net.h"
#include "lang/petri/reachability.h"

namespace rtplc::petri {

struct AnalysisOptions {
  uint64_t max_markings = 50'000'000;
  size_t graph_limit = 0;  // keep the reachability graph up to this many markings (for DOT)
  std::function<void(const ExploreProgress&)> progress;
  unsigned threads = 0;  // 0 = one per allowed CPU, 1 = sequential (ExploreOptions::threads)
};

struct Analysis {
  InvariantResult invariants;
  std::vector<std::optional<uint64_t>> structural_bounds;
  ReachabilityResult reach;
  uint64_t max_markings = 0;
  // True / false when known, nullopt when the limit stopped the search first.
  std::optional<bool> bounded() const;
};

Analysis analyze(const Net& net, const AnalysisOptions& options = {});

std::string render_text(const Net& net, const Analysis& a);
std::string render_json(const Net& net, const Analysis& a);

}  // namespace rtplc::petri
