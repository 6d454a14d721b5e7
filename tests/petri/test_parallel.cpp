// The parallel reachability search gives the sequential figures, and the shared
// insert of the marking table (state_store.h, "Shared insertion") survives an
// inserter preempted at its worst moment. Also the borrow test of enabledness on
// weighted arcs (reachability.cpp) against the reference BFS.
#include <sys/mman.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <map>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "lang/petri/generators.h"
#include "lang/petri/invariants.h"
#include "lang/petri/reachability.h"
#include "lang/petri/reference_bfs.h"
#include "lang/petri/state_store.h"
#include "tests/petri/test_support.h"
#include "tests/support/same_cpu_preemption.h"

namespace rtplc::petri {
namespace {

ReachabilityResult run(const Net& net, unsigned threads, uint64_t max_markings = 50'000'000,
                       size_t narrow_level = 0) {
  ExploreOptions opt;
  opt.place_bounds = structural_bounds(net, p_invariants(net));
  opt.threads = threads;
  opt.parallel_from = 0;  // from the first level on, so small nets take the parallel path too
  opt.keep_dead = 1000;
  opt.narrow_level = narrow_level;  // 0: every level by all threads
  opt.max_markings = max_markings;
  return explore(net, opt);
}

// Every figure of the search, and each dead example reached by a sequence of
// the sequential search's (shortest) length that really leads to it.
// `narrow_level` as in ExploreOptions (0: every level explored by all threads).
void expect_same(const Net& net, unsigned threads, size_t narrow_level = 0) {
  const ReachabilityResult seq = run(net, 1);
  const ReachabilityResult par = run(net, threads, 50'000'000, narrow_level);
  EXPECT_EQ(seq.threads, 1u);
  EXPECT_EQ(par.threads, threads) << net.name() << ": the parallel search did not run";
  EXPECT_EQ(par.status, seq.status) << net.name();
  EXPECT_EQ(par.markings, seq.markings) << net.name();
  EXPECT_EQ(par.edges, seq.edges) << net.name();
  EXPECT_EQ(par.dead_markings, seq.dead_markings) << net.name();
  EXPECT_EQ(par.max_tokens, seq.max_tokens) << net.name();
  EXPECT_EQ(par.fired, seq.fired) << net.name();
  ASSERT_EQ(par.dead_examples.size(), seq.dead_examples.size()) << net.name();
  std::map<Marking, size_t> shortest;
  for (const DeadMarking& d : seq.dead_examples) shortest[d.marking] = d.path.size();
  for (const DeadMarking& d : par.dead_examples) {
    ASSERT_EQ(shortest.count(d.marking), 1u)
        << net.name() << ": a dead marking the sequential search has not";
    EXPECT_EQ(d.path.size(), shortest[d.marking]) << net.name() << ": not a shortest sequence";
    const Result<Marking> end = fire_sequence(net, net.initial_marking(), d.path);
    ASSERT_TRUE(end.ok()) << net.name() << ": " << end.error();
    EXPECT_EQ(*end, d.marking) << net.name();
  }
}

TEST(ParallelReachability, kanban_3_has_the_sequential_figures) {
  expect_same(kanban(3), 2);
}

TEST(ParallelReachability, philosophers_8_and_its_deadlocks_have_the_sequential_figures) {
  const Net net = philosophers(8);
  expect_same(net, 2);
  EXPECT_EQ(run(net, 2).markings, 6561u);  // 3^8
  EXPECT_EQ(run(net, 2).dead_markings, 2u);
}

TEST(ParallelReachability, narrow_levels_by_one_thread_give_the_same_figures) {
  expect_same(kanban(3), 2, 2048);  // its levels narrower than 2,048 markings by one thread
  expect_same(philosophers(8), 2, 2048);
  expect_same(kanban(3), 2, 100'000);  // all of them
}

TEST(ParallelReachability, deadlock_net_has_the_sequential_figures) {
  expect_same(testing::deadlock_net(), 2);
}

TEST(ParallelReachability, more_threads_than_cpus_still_give_the_same_figures) {
  expect_same(kanban(2), 4);
}

TEST(ParallelReachability, stops_at_the_marking_limit) {
  const ReachabilityResult r = run(kanban(3), 2, 1000);
  EXPECT_EQ(r.status, ExploreStatus::kLimit);
  EXPECT_EQ(r.markings, 1000u);
}

TEST(ParallelReachability, wide_or_unbounded_nets_stay_sequential) {
  // Unbounded: the ancestor check needs the sequential order.
  EXPECT_EQ(run(testing::producer_net(), 2).threads, 1u);
  // 30 places of 5 tokens need two words.
  Net n;
  std::vector<PlaceId> ps;
  for (int i = 0; i < 30; ++i)
    ps.push_back(n.add_place("p" + std::to_string(i), i == 0 ? 5 : 0).value());
  for (int i = 0; i < 30; ++i) {
    const TransitionId t = n.add_transition("t" + std::to_string(i)).value();
    n.add_input(ps[static_cast<size_t>(i)], t);
    n.add_output(t, ps[static_cast<size_t>((i + 1) % 30)]);
  }
  EXPECT_EQ(run(n, 2).threads, 1u);
}

TEST(ParallelReachability, weighted_arcs_agree_with_the_reference) {
  // a + b + c = 7 (3-bit fields); t1 moves 3 tokens a -> b, t2 2 tokens b -> a, t3
  // 2 of c and 1 of a into b. d + e = 1 (1-bit fields): t4 needs 2 tokens of d and
  // can never fire; t5 moves d -> e.
  Net n("weighted");
  const PlaceId a = n.add_place("a", 6).value(), b = n.add_place("b").value(),
                c = n.add_place("c", 1).value(), d = n.add_place("d", 1).value(),
                e = n.add_place("e").value();
  const TransitionId t1 = n.add_transition("t1").value(), t2 = n.add_transition("t2").value(),
                     t3 = n.add_transition("t3").value(), t4 = n.add_transition("t4").value(),
                     t5 = n.add_transition("t5").value();
  n.add_input(a, t1, 3);
  n.add_output(t1, b, 3);
  n.add_input(b, t2, 2);
  n.add_output(t2, a, 2);
  n.add_input(c, t3, 1);
  n.add_input(a, t3, 2);
  n.add_output(t3, b, 3);
  n.add_input(d, t4, 2);
  n.add_output(t4, e, 2);
  n.add_input(d, t5);
  n.add_output(t5, e);
  const ReferenceResult ref = reference_bfs(n);
  for (unsigned threads : {1u, 2u}) {
    const ReachabilityResult r = run(n, threads);
    EXPECT_EQ(r.markings, ref.markings) << threads;
    EXPECT_EQ(r.edges, ref.edges) << threads;
    EXPECT_EQ(r.dead_markings, ref.dead_markings) << threads;
    EXPECT_TRUE(r.fired[t1] && r.fired[t2] && r.fired[t3] && r.fired[t5]);
    EXPECT_FALSE(r.fired[t4]);
  }
}

TEST(ParallelReachability, random_conservative_nets_agree_with_the_reference) {
  // Nets whose transitions move w tokens from one or two places to others (so the
  // token sum is an invariant and every place has a bound), weights 1-3: the
  // borrow test and the parallel search against the straightforward BFS.
  std::mt19937 rng(12345);
  auto pick = [&rng](uint32_t lo, uint32_t hi) {
    return std::uniform_int_distribution<uint32_t>(lo, hi)(rng);
  };
  uint64_t total = 0;
  int parallel_runs = 0;
  for (int round = 0; round < 40; ++round) {
    Net n("random" + std::to_string(round));
    const uint32_t np = pick(3, 9);
    std::vector<PlaceId> ps;
    for (uint32_t i = 0; i < np; ++i)
      ps.push_back(n.add_place("p" + std::to_string(i), i == 0 ? pick(1, 7) : pick(0, 2)).value());
    const uint32_t nt = pick(2, 10);
    for (uint32_t t = 0; t < nt; ++t) {
      const TransitionId tr = n.add_transition("t" + std::to_string(t)).value();
      const uint32_t a = pick(0, np - 1), b = pick(0, np - 1), w = pick(1, 3);
      uint32_t moved = w;
      n.add_input(ps[a], tr, w);
      if (b != a && pick(0, 1) == 1) {
        const uint32_t w2 = pick(1, 2);
        n.add_input(ps[b], tr, w2);
        moved += w2;
      }
      const uint32_t c = pick(0, np - 1), d = pick(0, np - 1);
      if (c != d && moved > 1) {
        const uint32_t part = pick(1, moved - 1);
        n.add_output(tr, ps[c], part);
        n.add_output(tr, ps[d], moved - part);
      } else {
        n.add_output(tr, ps[c], moved);
      }
    }
    const ReferenceResult ref = reference_bfs(n);
    for (unsigned threads : {1u, 2u}) {
      const ReachabilityResult r = run(n, threads);
      EXPECT_EQ(r.markings, ref.markings) << n.name() << " threads " << threads;
      EXPECT_EQ(r.edges, ref.edges) << n.name() << " threads " << threads;
      EXPECT_EQ(r.dead_markings, ref.dead_markings) << n.name() << " threads " << threads;
      if (threads > 1 && r.threads > 1) ++parallel_runs;  // not when M0 alone is dead
      total += r.markings;
    }
  }
  EXPECT_GT(total, 400u) << "the random nets are too small to test anything";
  EXPECT_GE(parallel_runs, 30) << "the parallel search ran too rarely to test anything";
  std::printf("40 random nets, %llu markings in all, %d explored in parallel\n",
              static_cast<unsigned long long>(total / 2), parallel_runs);
}

constexpr uint64_t kKey = MarkingLayout::kOccupied | 0x1234;
constexpr uint64_t kOther = MarkingLayout::kOccupied | 0x5678;
constexpr uint64_t kHome = 7;  // both keys are given the same hash: they collide

TEST(SharedMarkingTable, an_inserter_between_probe_and_claim_loses_to_the_same_key) {
  // Another insert of the same key runs in the middle of the first one, after it
  // saw the empty slot and before it claims it (what a preempting thread does).
  MarkingTable table(1, false, 64);
  bool inner = false;
  const bool outer = table.insert_shared(kKey, kHome, [&] {
    if (!inner) inner = table.insert_shared(kKey, kHome);
  });
  EXPECT_TRUE(inner);
  EXPECT_FALSE(outer) << "the key was inserted twice";
  EXPECT_FALSE(table.insert_shared(kKey, kHome));
}

TEST(SharedMarkingTable, an_inserter_between_probe_and_claim_moves_past_another_key) {
  MarkingTable table(1, false, 64);
  bool inner = false;
  const bool outer = table.insert_shared(kKey, kHome, [&] {
    if (!inner) inner = table.insert_shared(kOther, kHome);
  });
  EXPECT_TRUE(inner);
  EXPECT_TRUE(outer) << "the key lost its place to a different key";
  EXPECT_FALSE(table.insert_shared(kKey, kHome));
  EXPECT_FALSE(table.insert_shared(kOther, kHome));
}

TEST(SharedMarkingTable, a_preempting_inserter_on_the_same_cpu_finishes_at_once) {
  // The writer (FIFO 10) is preempted by the reader (FIFO 20) on CPU 0 between
  // seeing the empty slot and claiming it. The reader inserts the same key and a
  // colliding one without waiting for the writer; the writer then finds the key.
  MarkingTable table(1, false, 64);
  void* mem = mmap(nullptr, sizeof(std::atomic<int>), PROT_READ | PROT_WRITE,
                   MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(mem, MAP_FAILED);
  auto* writer_inserted = new (mem) std::atomic<int>(-1);
  auto r = rtplc::testing::run_preempting_reader(
      [&](const std::function<void()>& preempt) {
        bool once = false;
        const bool ins = table.insert_shared(kKey, kHome, [&] {
          if (!once) {
            once = true;
            preempt();
          }
        });
        writer_inserted->store(ins ? 1 : 0);
      },
      [&] {
        return table.insert_shared(kKey, kHome) && table.insert_shared(kOther, kHome) &&
               !table.insert_shared(kKey, kHome);
      });
  if (!r.ran) {
    munmap(mem, sizeof(std::atomic<int>));
    GTEST_SKIP() << r.why;
  }
  EXPECT_TRUE(r.reader_preempted_writer);
  EXPECT_TRUE(r.read_ok);
  EXPECT_EQ(writer_inserted->load(), 0) << "the writer inserted the key a second time";
  munmap(mem, sizeof(std::atomic<int>));
}

}  // namespace
}  // namespace rtplc::petri
