// The straightforward reachability search the packed store is measured against
// (issue item 4): a breadth-first search over std::vector<int> markings kept in a
// std::unordered_set, with a std::deque as the queue. Counts only; no limits but
// the caller's. Tests use it as an independent check of explore().
#pragma once

#include <cstddef>
#include <cstdint>

#include "lang/petri/net.h"

namespace rtplc::petri {

struct ReferenceResult {
  uint64_t markings = 0;
  uint64_t edges = 0;
  uint64_t dead_markings = 0;
  double seconds = 0;
  size_t approx_bytes = 0;  // estimated heap bytes of the set and its vectors
  bool stopped = false;     // max_markings reached
};

ReferenceResult reference_bfs(const Net& net, uint64_t max_markings = 100'000'000);

}  // namespace rtplc::petri
