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
#include <atomic>
#include <barrier>
#include <chrono>
#include <exception>
#include <string>

#include "kernel_rt/rt_thread.h"
#include "lang/petri/state_store.h"

namespace rtplc::petri {
namespace {

constexpr uint32_t kNoParent = UINT32_MAX;

// What firing one transition does to a packed key.
struct PackedTransition {
  struct Delta {
    uint32_t word;
    uint64_t sub;
    uint64_t add;
  };
  struct Grow {  // an output place without a structural bound: check it fits
    uint32_t place;
    uint64_t limit;  // the field must hold at most this before firing
  };
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

  // Firing on the packed words. Per transition and touched word, `sub` holds the
  // input weights and `add` the output weights at their fields' offsets. The
  // transition is enabled when the word minus `sub` borrows out of no field: the
  // borrow out of each bit of a - b = d is (~a & b) | (~(a ^ b) & d), and the
  // lowest field that lacks tokens borrows out of its top bit, so one test of the
  // fields' top bits decides every input of the word at once. Then the successor
  // word is d + add (no field can carry: bounded fields hold their bound, the
  // others are checked through `grows` first). A weight above its field's maximum
  // can never be met: such a transition is never enabled.
  std::vector<uint64_t> tops(words_, 0);
  for (size_t p = 0; p < np; ++p) {
    const auto& f = layout_.field(p);
    tops[f.word] |= ((f.mask + 1) >> 1) << f.shift;
  }
  std::vector<bool> never(nt, false);
  for (size_t t = 0; t < nt; ++t) {
    for (const ArcEnd& e : net_.inputs(static_cast<TransitionId>(t))) {
      if (net_.pre(e.place, static_cast<TransitionId>(t)) > layout_.max_tokens(e.place))
        never[t] = true;
    }
  }
  // One-word markings: sub/add per transition in two flat arrays; wider ones: the
  // touched words of every transition in one flat array.
  std::vector<uint32_t> live;  // transitions that may ever be enabled
  for (size_t t = 0; t < nt; ++t) {
    if (!never[t]) live.push_back(static_cast<uint32_t>(t));
  }
  std::vector<uint64_t> sub1(nt, 0), add1(nt, 0);
  std::vector<PackedTransition::Delta> deltas;
  std::vector<uint32_t> delta_begin(nt + 1, 0);
  std::vector<bool> has_grows(nt, false);
  for (size_t t = 0; t < nt; ++t) {
    delta_begin[t] = static_cast<uint32_t>(deltas.size());
    for (const auto& d : packed[t].deltas) deltas.push_back(d);
    if (words_ == 1 && !packed[t].deltas.empty()) {
      sub1[t] = packed[t].deltas[0].sub;
      add1[t] = packed[t].deltas[0].add;
    }
    has_grows[t] = !packed[t].grows.empty();
  }
  delta_begin[nt] = static_cast<uint32_t>(deltas.size());
  const uint64_t top1 = tops[0];
  // Writes the successors of `cur` to out[] (words_ each) and their transitions to
  // out_t[]; returns how many. A transition that would overflow a field sets `stop`.
  auto successors = [&](const uint64_t* cur, uint64_t* out, uint32_t* out_t, bool* stop) {
    size_t n = 0;
    if (words_ == 1) {
      const uint64_t c = cur[0];
      for (const uint32_t t : live) {
        const uint64_t sb = sub1[t];
        const uint64_t d = c - sb;
        const uint64_t borrow = (~c & sb) | (~(c ^ sb) & d);
        // Written either way and kept only when enabled: no branch to mispredict.
        out[n] = d + add1[t];
        out_t[n] = t;
        n += (borrow & top1) == 0 ? 1 : 0;
      }
    } else {
      for (const uint32_t t : live) {
        uint64_t* next = out + n * words_;
        bool en = true;
        for (uint32_t i = delta_begin[t]; i < delta_begin[t + 1] && en; ++i) {
          const PackedTransition::Delta& dl = deltas[i];
          const uint64_t c = cur[dl.word];
          const uint64_t d = c - dl.sub;
          en = (((~c & dl.sub) | (~(c ^ dl.sub) & d)) & tops[dl.word]) == 0;
        }
        if (!en) continue;
        for (size_t k = 0; k < words_; ++k) next[k] = cur[k];
        for (uint32_t i = delta_begin[t]; i < delta_begin[t + 1]; ++i) {
          const PackedTransition::Delta& dl = deltas[i];
          next[dl.word] = next[dl.word] - dl.sub + dl.add;
        }
        out_t[n++] = t;
      }
    }
    if (!all_bounded) {
      for (size_t k = 0; k < n; ++k) {
        if (!has_grows[out_t[k]]) continue;
        for (const auto& g : packed[out_t[k]].grows) {
          if (g.limit == UINT64_MAX || layout_.get(cur, g.place) > g.limit) {
            r.status = ExploreStatus::kTooManyTokens;
            r.overflow_place = net_.place_label(g.place);
            *stop = true;
          }
        }
      }
    }
    return n;
  };

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
  // BFS levels: markings [level_begin, level_end) are those at the current
  // distance from M0. A batch never spans two levels, so the search can hand over
  // to the parallel one exactly at a level's start.
  const unsigned threads =
      opt_.threads > 0 ? opt_.threads : std::max(1u, kernel_rt::allowed_cpu_count());
  const bool may_go_parallel = threads > 1 && words_ == 1 && all_bounded;
  bool go_parallel = false;
  size_t level_begin = 0, level_end = 1;
  for (size_t base = 0, end = 0; base < parent_.size() && !stop; base = end) {
    if (base == level_end) {
      level_begin = level_end;
      level_end = parent_.size();
      if (may_go_parallel && !recording && parent_.size() >= opt_.parallel_from) {
        go_parallel = true;
        break;
      }
    }
    end = std::min({base + kBatch, parent_.size(), level_end});
    size_t ns = 0;
    for (size_t id = base; id < end && !stop; ++id) {
      first[id - base] = ns;
      const size_t n = successors(keys_.at(id), &succ[ns * words_], &succ_t[ns], &stop);
      for (size_t k = ns; k < ns + n; ++k) {
        succ_h[k] = table.hash(&succ[k * words_]);
        table.prefetch(succ_h[k]);
      }
      ns += n;
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

  // The parallel BFS, one level at a time (level-synchronous). The threads take
  // chunks of the level's markings from a shared counter, insert the successors
  // into the shared table (MarkingTable::insert_shared, lock-free; see
  // state_store.h for the protocol) and keep what was new in their own lists. At
  // the level's end a barrier's completion step, run by one thread while the
  // others wait, numbers the new markings (appends them to keys_/parent_/via_),
  // counts edges and dead markings and starts the next level. A marking's parent
  // is always from the level before its own, so every path_to() is still a
  // shortest firing sequence; which of several parents of the same level a
  // marking gets, and the order of numbers within a level, depend on the race.
  // The table is grown between barriers too, before inserts could pass its 3/4
  // load: one thread makes the doubled array, all of them move the old slots.
  if (go_parallel && !stop) {
    struct Fresh {
      uint64_t key;
      uint32_t parent;
      uint32_t via;
    };
    struct Worker {
      std::vector<Fresh> fresh;
      std::vector<uint32_t> dead;  // dead markings of this level, while examples are wanted
      uint64_t dead_count = 0;
      uint64_t edges = 0;
      std::vector<uint8_t> fired;
      std::vector<uint64_t> sk, sh;  // a batch's successors and their hashes
      std::vector<uint32_t> st;      // and their transitions
    };
    std::vector<Worker> workers(threads);
    for (Worker& w : workers) {
      w.fired.assign(nt, 0);
      w.sk.resize(kBatch * nt);
      w.sh.resize(kBatch * nt);
      w.st.resize(kBatch * nt);
    }
    const size_t chunk = std::clamp<size_t>(65536 / std::max<size_t>(nt, 1), 1, 256);
    // Keys a thread may insert between two looks at the load: one chunk's successors.
    const size_t reserve = 2 * size_t{threads} * chunk * std::max<size_t>(nt, 1);
    std::atomic<size_t> next{level_begin};
    std::atomic<size_t> inserted{0};  // since the last barrier, added after each chunk
    std::atomic<bool> need_grow{false};
    const size_t narrow = opt_.narrow_level;  // levels of fewer markings: one thread
    std::atomic<size_t> rehash_next{0};       // next old slot to move while growing
    bool growing = false;                     // written only in the completion step
    size_t hi = level_end;  // written only in the completion step (the barrier orders it)
    bool done = false;
    bool want_dead = r.dead_examples.size() < opt_.keep_dead;
    std::exception_ptr failure;
    table.grow_to_fit(reserve);
    // Explores chunks of [next, hi) until none is left or the table needs room.
    auto process = [&](Worker& w) {
      std::vector<uint64_t>& sk = w.sk;
      std::vector<uint32_t>& st = w.st;
      std::vector<uint64_t>& sh = w.sh;
      std::array<size_t, kBatch + 1> at{};
      bool no_stop = false;
      while (!need_grow.load(std::memory_order_relaxed)) {
        if (table.needs_room(inserted.load(std::memory_order_relaxed) + reserve)) {
          need_grow.store(true, std::memory_order_relaxed);
          break;
        }
        const size_t c = next.fetch_add(chunk, std::memory_order_relaxed);
        if (c >= hi) break;
        const size_t c_end = std::min(c + chunk, hi);
        size_t fresh = 0;
        for (size_t b = c; b < c_end; b += kBatch) {
          const size_t e = std::min(b + kBatch, c_end);
          size_t ns = 0;
          for (size_t id = b; id < e; ++id) {
            at[id - b] = ns;
            const size_t n = successors(keys_.at(id), &sk[ns], &st[ns], &no_stop);
            for (size_t k = ns; k < ns + n; ++k) {
              sh[k] = MarkingTable::hash(&sk[k], 1);
              table.prefetch(sh[k]);
            }
            ns += n;
          }
          at[e - b] = ns;
          for (size_t id = b; id < e; ++id) {
            const size_t from = at[id - b], to = at[id - b + 1];
            w.edges += to - from;
            if (from == to) {
              ++w.dead_count;
              if (want_dead && w.dead.size() < opt_.keep_dead)
                w.dead.push_back(static_cast<uint32_t>(id));
            }
            for (size_t k = from; k < to; ++k) {
              w.fired[st[k]] = 1;
              if (table.insert_shared(sk[k], sh[k])) {
                w.fresh.push_back(Fresh{sk[k], static_cast<uint32_t>(id), st[k]});
                ++fresh;
              }
            }
          }
        }
        inserted.fetch_add(fresh, std::memory_order_relaxed);
      }
    };
    auto step = [&]() noexcept {
      try {
        table.add_shared_inserts(inserted.exchange(0, std::memory_order_relaxed));
        if (growing) {  // every thread has moved its share of the old slots
          table.end_shared_grow();
          growing = false;
          return;
        }
        if (need_grow.load(std::memory_order_relaxed)) {
          table.begin_shared_grow();
          rehash_next.store(0, std::memory_order_relaxed);
          growing = true;
          need_grow.store(false, std::memory_order_relaxed);
          return;
        }
        // The level is done: number its new markings, worker by worker. A narrow
        // next level is explored right here by this thread (the others wait at the
        // barrier): for a few markings two barriers would cost more than they save.
        for (;;) {
          std::vector<uint32_t> dead;
          size_t fresh_bytes = 0;
          for (Worker& w : workers) {
            fresh_bytes += w.fresh.capacity() * sizeof(Fresh);
            for (const Fresh& f : w.fresh) {
              if (parent_.size() >= opt_.max_markings) {
                r.status = ExploreStatus::kLimit;
                break;
              }
              keys_.push_back(&f.key);
              parent_.push_back(f.parent);
              via_.push_back(f.via);
            }
            w.fresh.clear();
            r.dead_markings += w.dead_count;
            w.dead_count = 0;
            dead.insert(dead.end(), w.dead.begin(), w.dead.end());
            w.dead.clear();
            edges += w.edges;
            w.edges = 0;
          }
          std::sort(dead.begin(), dead.end());
          for (uint32_t id : dead) {
            if (r.dead_examples.size() >= opt_.keep_dead) break;
            r.dead_examples.push_back(DeadMarking{unpack(id), path_to(id)});
          }
          want_dead = r.dead_examples.size() < opt_.keep_dead;
          if (parent_.size() >= opt_.max_markings) r.status = ExploreStatus::kLimit;
          peak_bytes = std::max(peak_bytes, store_bytes() + fresh_bytes);
          if (opt_.progress) {
            const double s =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time)
                    .count();
            opt_.progress(ExploreProgress{parent_.size(), hi, edges, s});
          }
          const size_t lo = hi;
          hi = parent_.size();
          next.store(lo, std::memory_order_relaxed);
          done = lo == hi || r.status != ExploreStatus::kComplete;
          if (done || hi - lo >= narrow) break;
          for (;;) {
            process(workers[0]);
            if (!need_grow.load(std::memory_order_relaxed)) break;
            table.add_shared_inserts(inserted.exchange(0, std::memory_order_relaxed));
            table.grow_to_fit(reserve);
            need_grow.store(false, std::memory_order_relaxed);
          }
          table.add_shared_inserts(inserted.exchange(0, std::memory_order_relaxed));
        }
      } catch (...) {
        failure = std::current_exception();
        done = true;
      }
    };
    std::barrier sync(static_cast<std::ptrdiff_t>(threads), step);
    auto work = [&](Worker& w) {
      for (;;) {
        process(w);
        sync.arrive_and_wait();
        while (growing) {
          constexpr size_t kMove = 4096;
          const size_t old_cap = table.old_capacity();
          for (;;) {
            const size_t c = rehash_next.fetch_add(kMove, std::memory_order_relaxed);
            if (c >= old_cap) break;
            table.rehash_shared(c, std::min(c + kMove, old_cap));
          }
          sync.arrive_and_wait();
        }
        if (done) return;
      }
    };
    std::vector<kernel_rt::RtThread> helpers;
    unsigned started = 1;
    for (unsigned i = 1; i < threads; ++i) {
      kernel_rt::ThreadSpec spec;
      spec.name = "rtplc-bfs-" + std::to_string(i);
      Worker* w = &workers[i];
      auto t = kernel_rt::start_thread(spec, [&work, w] { work(*w); });
      if (t) {
        helpers.push_back(std::move(*t));
        ++started;
      } else {
        (void)sync.arrive_and_drop();  // one participant fewer, from this phase on
      }
    }
    r.threads = started;
    work(workers[0]);
    helpers.clear();  // joins
    if (failure) std::rethrow_exception(failure);
    for (const Worker& w : workers) {
      for (size_t t = 0; t < nt; ++t) {
        if (w.fired[t]) r.fired[t] = true;
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
