// The reachability graph of a P/T net, explored breadth-first over bit-packed
// markings (issue items 3 and 4; spec petri-sfc.md, "What the product does").
//
// Reports the number of markings and of edges (pairs of a marking and a
// transition enabled in it), the dead markings (deadlocks) with the shortest
// firing sequence to each (BFS parent pointers), the most tokens seen in each
// place, and the transitions that never fire.
//
// Unboundedness: a place without a structural bound (from a P-invariant) may
// grow without limit. For such nets every new marking is compared with its BFS
// ancestors; a new marking M' that strictly covers an ancestor M proves the net
// unbounded (the sequence M -> M' can be repeated forever, pumping the places
// where M' > M: M's omega marking), and exploration stops with that sequence.
// By Dickson's lemma every unbounded net has such a pair on some BFS path, so the
// search ends on every net, given the marking limit as the last resort.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lang/petri/net.h"

namespace rtplc::petri {

struct ExploreProgress {
  uint64_t markings = 0;  // stored so far
  uint64_t explored = 0;  // markings whose successors are done
  uint64_t edges = 0;
  double seconds = 0;
};

struct ExploreOptions {
  uint64_t max_markings = 50'000'000;
  size_t keep_dead = 10;   // dead markings kept with their firing sequences
  size_t graph_limit = 0;  // keep the whole graph while it has at most this many markings
  // Called about every 65,536 explored markings.
  std::function<void(const ExploreProgress&)> progress;
  // Structural bound of each place (P-invariants), empty or nullopt where unknown.
  std::vector<std::optional<uint64_t>> place_bounds;
  // Threads of the search: 0 = one per CPU this process may use, 1 = sequential.
  // The parallel search takes over at the first BFS level that starts with at
  // least `parallel_from` markings stored, when the net is structurally bounded,
  // its markings fit one 64-bit word and no graph is being kept. Its figures are
  // the sequential ones (markings, edges, dead markings, bounds, dead transitions;
  // each dead example still with a shortest sequence, though which examples and
  // which of several shortest sequences may differ from run to run).
  unsigned threads = 0;
  uint64_t parallel_from = 100'000;
  // Once parallel, a level of fewer markings than this is explored by one thread
  // while the others wait (two barriers would cost more than the level's work).
  size_t narrow_level = 2048;
};

enum class ExploreStatus : uint8_t {
  kComplete,      // every reachable marking seen: the figures are exact
  kLimit,         // max_markings reached: the figures are lower bounds
  kUnbounded,     // a pumping sequence was found
  kTooManyTokens  // a place without a structural bound outgrew its storage field
};

struct DeadMarking {
  Marking marking;
  std::vector<TransitionId> path;  // a shortest firing sequence from M0
};

// Proof of unboundedness: M0 --prefix--> start --cycle--> end with end > start.
struct Pump {
  std::vector<TransitionId> prefix;
  std::vector<TransitionId> cycle;
  Marking start;
  Marking end;
  std::vector<PlaceId> growing;  // places where end > start: omega in the coverability graph
};

struct ReachabilityGraph {
  struct Edge {
    uint32_t from;
    uint32_t to;
    TransitionId transition;
  };
  std::vector<Marking> markings;  // index = marking number, 0 = M0
  std::vector<Edge> edges;
};

struct ReachabilityResult {
  ExploreStatus status = ExploreStatus::kComplete;
  uint64_t markings = 0;
  uint64_t edges = 0;
  uint64_t dead_markings = 0;
  std::vector<DeadMarking> dead_examples;  // the first found, so the nearest to M0
  std::vector<uint32_t> max_tokens;        // per place, over the markings seen
  uint32_t max_tokens_in_place = 0;
  std::vector<bool> fired;  // per transition: enabled in some marking seen
  std::optional<Pump> pump;
  std::optional<ReachabilityGraph> graph;  // when it stayed within graph_limit
  std::string overflow_place;              // kTooManyTokens: which place
  double seconds = 0;
  size_t store_bytes = 0;  // peak bytes of the marking store (table + queue + parents)
  size_t key_words = 1;    // 64-bit words per packed marking
  size_t key_bits = 0;     // bits of a marking's fields
  unsigned threads = 1;    // threads that explored (more than 1: the parallel search ran)

  bool exact() const { return status == ExploreStatus::kComplete; }
  bool safe() const { return max_tokens_in_place <= 1; }
  double bytes_per_marking() const {
    return markings ? static_cast<double>(store_bytes) / static_cast<double>(markings) : 0;
  }
};

ReachabilityResult explore(const Net& net, const ExploreOptions& options = {});

std::string sequence_text(const Net& net, const std::vector<TransitionId>& seq);

}  // namespace rtplc::petri
