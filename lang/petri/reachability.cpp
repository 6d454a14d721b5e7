// Breadth-first reachability over bit-packed markings (see reachability.h; issue
// items 3 and 4).
//
// Markings are numbered in the order they are found. The queue is the array of
// packed keys itself (marking i is explored after marking i-1), so BFS needs no
// other queue; parent_[i] and via_[i] record the edge that found marking i, which
// gives the shortest firing sequence to it.
#include "lang/petri/reachability.h"

#include <algorithm>
#include <array>
#include <chrono>

#include "lang/petri/state_store.h"

namespace rtplc::petri {
namespace {

constexpr uint32_t kNoParent = UINT32_MAX;

// What firing one transition does to a packed key.
struct PackedTransition {
  struct Need {
    uint32_t word;
    uint32_t shift;
    uint64_t mask;
    uint64_t weight;
  };
  struct Delta {
    uint32_t word;
    uint64_t sub;
    uint64_t add;
  };
  struct Grow {  // an output place without a structural bound: check it fits
    uint32_t place;
    uint64_t limit;  // the field must hold at most this before firing
  };
  std::vector<Need> needs;
  std::vector<Delta> deltas;
  std::vector<Grow> grows;
};

class Explorer {
 public:
  Explorer(const Net& net, const ExploreOptions& opt) : net_(net), opt_(opt) {}
  ReachabilityResult run();

 private:
  std::vector<TransitionId> path_to(uint32_t id) const;
  Marking unpack(uint32_t id) const;
  bool covers_ancestor(uint32_t id, uint32_t* ancestor) const;
  Pump make_pump(uint32_t ancestor, uint32_t id) const;

  const Net& net_;
  const ExploreOptions& opt_;
  MarkingLayout layout_;
  size_t words_ = 1;
  ChunkedArray<uint64_t> keys_;
  ChunkedArray<uint32_t> parent_;
  ChunkedArray<uint32_t> via_;
};

Marking Explorer::unpack(uint32_t id) const {
  Marking m(net_.place_count());
  layout_.unpack(keys_.at(id), m.data());
  return m;
}

std::vector<TransitionId> Explorer::path_to(uint32_t id) const {
  std::vector<TransitionId> path;
  while (parent_[id] != kNoParent) {
    path.push_back(via_[id]);
    id = parent_[id];
  }
  std::reverse(path.begin(), path.end());
  return path;
}

// True when marking `id` is >= some BFS ancestor in every place (and differs, as
// every stored marking does).
bool Explorer::covers_ancestor(uint32_t id, uint32_t* ancestor) const {
  const uint64_t* k = keys_.at(id);
  for (uint32_t a = parent_[id]; a != kNoParent; a = parent_[a]) {
    const uint64_t* ka = keys_.at(a);
    bool ge = true;
    for (size_t p = 0; p < layout_.places() && ge; ++p)
      ge = layout_.get(k, p) >= layout_.get(ka, p);
    if (ge) {
      *ancestor = a;
      return true;
    }
  }
  return false;
}

Pump Explorer::make_pump(uint32_t ancestor, uint32_t id) const {
  Pump pump;
  pump.prefix = path_to(ancestor);
  const std::vector<TransitionId> full = path_to(id);
  pump.cycle.assign(full.begin() + static_cast<std::ptrdiff_t>(pump.prefix.size()), full.end());
  pump.start = unpack(ancestor);
  pump.end = unpack(id);
  for (size_t p = 0; p < pump.start.size(); ++p) {
    if (pump.end[p] > pump.start[p]) pump.growing.push_back(static_cast<PlaceId>(p));
  }
  return pump;
}

ReachabilityResult Explorer::run() {
  const auto start_time = std::chrono::steady_clock::now();
  const size_t np = net_.place_count();
  const size_t nt = net_.transition_count();
  ReachabilityResult r;
  r.max_tokens.assign(np, 0);
  r.fired.assign(nt, false);

  // Field widths: a structural bound gives the exact width; elsewhere leave
  // room to grow (and check every growth against the field).
  const Marking m0 = net_.initial_marking();
  std::vector<uint32_t> bits(np);
  std::vector<bool> bounded(np, false);
  bool all_bounded = true;
  for (size_t p = 0; p < np; ++p) {
    if (p < opt_.place_bounds.size() && opt_.place_bounds[p] &&
        *opt_.place_bounds[p] < (1ULL << 32)) {
      bits[p] = bits_for(std::max<uint64_t>(*opt_.place_bounds[p], m0[p]));
      bounded[p] = true;
    } else {
      bits[p] = std::min<uint32_t>(32, std::max<uint32_t>(16, bits_for(m0[p]) + 8));
      all_bounded = false;
    }
  }
  layout_ = MarkingLayout(bits);
  words_ = layout_.words();
  keys_ = ChunkedArray<uint64_t>(words_);
  r.key_words = words_;
  r.key_bits = layout_.total_bits();

  std::vector<PackedTransition> packed(nt);
  for (size_t t = 0; t < nt; ++t) {
    PackedTransition& pt = packed[t];
    auto delta = [&pt](uint32_t word) -> PackedTransition::Delta& {
      for (auto& d : pt.deltas) {
        if (d.word == word) return d;
      }
      pt.deltas.push_back({word, 0, 0});
      return pt.deltas.back();
    };
    for (const ArcEnd& e : net_.inputs(static_cast<TransitionId>(t))) {
      const auto& f = layout_.field(e.place);
      pt.needs.push_back({f.word, f.shift, f.mask, e.weight});
      delta(f.word).sub += uint64_t{e.weight} << f.shift;
    }
    for (const ArcEnd& e : net_.outputs(static_cast<TransitionId>(t))) {
      const auto& f = layout_.field(e.place);
      delta(f.word).add += uint64_t{e.weight} << f.shift;
      const uint32_t in = net_.pre(e.place, static_cast<TransitionId>(t));
      if (!bounded[e.place] && e.weight > in) {
        const uint64_t gain = e.weight - in;
        pt.grows.push_back({e.place, gain > f.mask ? 0 : f.mask - gain});
        if (gain > f.mask) pt.grows.back().limit = UINT64_MAX;  // never fits: flagged below
      }
    }
  }

  // Markings whose first M0 token count does not fit are caught here.
  for (size_t p = 0; p < np; ++p) {
    if (m0[p] > layout_.max_tokens(p)) {
      r.status = ExploreStatus::kTooManyTokens;
      r.overflow_place = net_.place_label(static_cast<PlaceId>(p));
      return r;
    }
  }

  // The enabledness tests of every transition in one flat array (fewer cache
  // lines than a vector per transition), word-0 one-bit weight-1 inputs as a mask.
  std::vector<PackedTransition::Need> needs;
  std::vector<uint32_t> need_begin(nt + 1, 0);
  std::vector<uint64_t> all_set(nt, 0);
  for (size_t t = 0; t < nt; ++t) {
    need_begin[t] = static_cast<uint32_t>(needs.size());
    for (const auto& n : packed[t].needs) {
      if (n.word == 0 && n.mask == 1 && n.weight == 1) {
        all_set[t] |= uint64_t{1} << n.shift;
      } else {
        needs.push_back(n);
      }
    }
  }
  need_begin[nt] = static_cast<uint32_t>(needs.size());

  const bool keep_ids = opt_.graph_limit > 0;
  MarkingTable table(words_, keep_ids);
  std::vector<uint64_t> key(words_);
  layout_.pack(m0.data(), key.data());
  (void)table.insert(key.data(), 0);
  keys_.push_back(key.data());
  parent_.push_back(kNoParent);
  via_.push_back(uint32_t{0});

  bool recording = keep_ids;
  ReachabilityGraph graph;
  // Markings are explored in batches: the successors of a whole batch are
  // computed and their table slots prefetched before any is looked up, so the
  // cache misses of the lookups overlap. Insertion keeps the plain BFS order.
  constexpr size_t kBatch = 16;
  std::vector<uint64_t> succ(kBatch * nt * words_);
  std::vector<uint32_t> succ_t(kBatch * nt);
  std::vector<uint64_t> succ_h(kBatch * nt);
  std::array<size_t, kBatch + 1> first{};
  auto store_bytes = [&] { return table.bytes() + keys_.bytes() + parent_.bytes() + via_.bytes(); };
  size_t peak_bytes = 0;

  bool stop = false;
  uint64_t edges = 0;
  size_t next_progress = 0;
  for (size_t base = 0, end = 0; base < parent_.size() && !stop; base = end) {
    end = std::min(base + kBatch, parent_.size());
    size_t ns = 0;
    for (size_t id = base; id < end && !stop; ++id) {
      first[id - base] = ns;
      const uint64_t* cur = keys_.at(id);
      for (size_t t = 0; t < nt; ++t) {
        // Safe input places with weight 1 are tested all at once; the rest field by field.
        if ((cur[0] & all_set[t]) != all_set[t]) continue;
        bool en = true;
        for (uint32_t i = need_begin[t]; i < need_begin[t + 1]; ++i) {
          const PackedTransition::Need& n = needs[i];
          if (((cur[n.word] >> n.shift) & n.mask) < n.weight) {
            en = false;
            break;
          }
        }
        if (!en) continue;
        const PackedTransition& pt = packed[t];
        for (const auto& g : pt.grows) {
          if (g.limit == UINT64_MAX || layout_.get(cur, g.place) > g.limit) {
            r.status = ExploreStatus::kTooManyTokens;
            r.overflow_place = net_.place_label(g.place);
            stop = true;
          }
        }
        uint64_t* next = &succ[ns * words_];
        std::copy_n(cur, words_, next);
        for (const auto& d : pt.deltas) next[d.word] = next[d.word] - d.sub + d.add;
        succ_h[ns] = table.hash(next);
        table.prefetch(succ_h[ns]);
        succ_t[ns++] = static_cast<uint32_t>(t);
      }
    }
    if (stop) break;
    first[end - base] = ns;
    for (size_t id = base; id < end && !stop; ++id) {
      const size_t from = first[id - base], to = first[id - base + 1];
      edges += to - from;
      for (size_t k = from; k < to && !stop; ++k) {
        const uint64_t* next = &succ[k * words_];
        const uint32_t t = succ_t[k];
        r.fired[t] = true;
        const auto new_id = static_cast<uint32_t>(parent_.size());
        const MarkingTable::Found f = table.insert(next, succ_h[k], new_id);
        uint32_t target = new_id;
        if (f.inserted) {
          keys_.push_back(next);
          parent_.push_back(static_cast<uint32_t>(id));
          via_.push_back(t);
          uint32_t anc = 0;
          if (!all_bounded && covers_ancestor(new_id, &anc)) {
            r.pump = make_pump(anc, new_id);
            r.status = ExploreStatus::kUnbounded;
            stop = true;
          }
          if (parent_.size() >= opt_.max_markings && !stop) {
            r.status = ExploreStatus::kLimit;
            stop = true;
          }
          if (recording && parent_.size() > opt_.graph_limit) {
            recording = false;
            graph = {};
          }
        } else if (recording) {
          target = table.id_at(f.slot);
        }
        if (recording) graph.edges.push_back({static_cast<uint32_t>(id), target, t});
      }
      if (from == to) {
        ++r.dead_markings;
        if (r.dead_examples.size() < opt_.keep_dead) {
          r.dead_examples.push_back(
              DeadMarking{unpack(static_cast<uint32_t>(id)), path_to(static_cast<uint32_t>(id))});
        }
      }
    }
    if (end >= next_progress) {
      next_progress = end + 0x10000;
      peak_bytes = std::max(peak_bytes, store_bytes());
      if (opt_.progress) {
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
        opt_.progress(ExploreProgress{parent_.size(), end, edges, s});
      }
    }
  }

  // The most tokens per place: one sequential pass, cheaper than in the loop above.
  for (size_t i = 0; i < keys_.size(); ++i) {
    const uint64_t* k = keys_.at(i);
    for (size_t p = 0; p < np; ++p) r.max_tokens[p] = std::max(r.max_tokens[p], layout_.get(k, p));
  }
  r.markings = parent_.size();
  r.edges = edges;
  for (uint32_t v : r.max_tokens) r.max_tokens_in_place = std::max(r.max_tokens_in_place, v);
  if (recording && r.status == ExploreStatus::kComplete) {
    for (uint32_t i = 0; i < parent_.size(); ++i) graph.markings.push_back(unpack(i));
    r.graph = std::move(graph);
  }
  r.store_bytes = std::max(peak_bytes, store_bytes());
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return r;
}

}  // namespace

ReachabilityResult explore(const Net& net, const ExploreOptions& options) {
  Explorer e(net, options);
  return e.run();
}

std::string sequence_text(const Net& net, const std::vector<TransitionId>& seq) {
  if (seq.empty()) return "(none: M0 itself)";
  std::string s;
  for (TransitionId t : seq) {
    if (!s.empty()) s += ' ';
    s += net.transition_label(t);
  }
  return s;
}

}  // namespace rtplc::petri
