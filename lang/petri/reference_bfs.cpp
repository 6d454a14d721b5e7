// The std::unordered_set<std::vector<int>> BFS reference (see reference_bfs.h).
#include "lang/petri/reference_bfs.h"

#include <chrono>
#include <deque>
#include <unordered_set>
#include <vector>

namespace rtplc::petri {
namespace {

struct VectorHash {
  size_t operator()(const std::vector<int>& v) const {
    uint64_t h = 1469598103934665603ULL;  // FNV-1a over the token counts
    for (int x : v) h = (h ^ static_cast<uint32_t>(x)) * 1099511628211ULL;
    return static_cast<size_t>(h);
  }
};

}  // namespace

ReferenceResult reference_bfs(const Net& net, uint64_t max_markings) {
  const auto start = std::chrono::steady_clock::now();
  ReferenceResult r;
  std::unordered_set<std::vector<int>, VectorHash> seen;
  std::deque<const std::vector<int>*> queue;
  std::vector<int> m0(net.place_count());
  for (PlaceId p = 0; p < net.place_count(); ++p) m0[p] = static_cast<int>(net.place(p).initial);
  queue.push_back(&*seen.insert(m0).first);
  while (!queue.empty()) {
    const std::vector<int>& m = *queue.front();
    queue.pop_front();
    bool any = false;
    for (TransitionId t = 0; t < net.transition_count(); ++t) {
      bool enabled = true;
      for (const ArcEnd& e : net.inputs(t))
        enabled = enabled && m[e.place] >= static_cast<int>(e.weight);
      if (!enabled) continue;
      any = true;
      ++r.edges;
      std::vector<int> next = m;
      for (const ArcEnd& e : net.inputs(t)) next[e.place] -= static_cast<int>(e.weight);
      for (const ArcEnd& e : net.outputs(t)) next[e.place] += static_cast<int>(e.weight);
      auto [it, fresh] = seen.insert(std::move(next));
      if (fresh) {
        if (seen.size() > max_markings) {
          r.stopped = true;
          queue.clear();
          break;
        }
        queue.push_back(&*it);
      }
    }
    if (!any) ++r.dead_markings;
  }
  r.markings = seen.size();
  // Each node: the vector's heap block, the vector itself, the next pointer and the
  // cached hash; plus one bucket pointer per bucket.
  const size_t node =
      sizeof(std::vector<int>) + 2 * sizeof(void*) + net.place_count() * sizeof(int);
  r.approx_bytes = seen.size() * node + seen.bucket_count() * sizeof(void*);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace rtplc::petri
