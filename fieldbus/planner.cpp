// Window scheduling and the seed's bandwidth conditions (see planner.h and
// docs/fieldbus.md, "How the planner decides").
#include "fieldbus/planner.h"

#include <algorithm>
#include <cstdio>
#include <numeric>

namespace rtplc::fieldbus {
namespace {

constexpr int kPacketsPerSample = 2;  // the sensor's and the controller's

std::string t(Nanos x) {
  return format_time(x);
}

std::string per_frame(int64_t num, int64_t den) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", static_cast<double>(num) / static_cast<double>(den));
  return buf;
}

void fail(Plan& p, Condition c, std::string loop, std::string msg, Nanos shortfall = 0) {
  p.failures.push_back(Failure{c, std::move(loop), std::move(msg), shortfall});
}

// T_1: the shortest fixed period when the file fixes any (the user's fastest
// rate is the frame), else half the tightest delay bound (a loop sampled every
// frame has D_i <= T_1 + W <= 2 T_1).
Nanos choose_frame(const Design& d) {
  if (d.frame) return *d.frame;
  Nanos fixed = 0, bound = 0;
  for (const LoopSpec& l : d.loops) {
    if (l.period) fixed = fixed ? std::min(fixed, *l.period) : *l.period;
    if (l.max_delay) bound = bound ? std::min(bound, *l.max_delay / 2) : *l.max_delay / 2;
  }
  return fixed ? fixed : bound;
}

// Period of one loop: the fixed one if it is T_1 * 2^k, else the longest
// T_1 * 2^k whose bound (2^k + 1) T_1 stays within Phi_i (W <= T_1 in every
// design that passes C1, so the bound chosen here holds whenever the plan does).
void choose_period(const Design& d, const LoopSpec& l, Nanos t1, LoopPlan& lp, Plan& p) {
  lp.shift = 0;
  if (l.period) {
    lp.fixed = true;
    const Nanos per = *l.period;
    int k = 0;
    while (k <= kMaxPeriodShift && (t1 << k) < per) ++k;
    if (k > kMaxPeriodShift || (t1 << k) != per) {
      fail(p, Condition::kPeriod, l.name,
           "period " + t(per) + " of loop " + l.name + " is not T_1 * 2^k (T_1 = " + t(t1) +
               ", so " + t(t1) + ", " + t(2 * t1) + ", " + t(4 * t1) + " ... up to " +
               t(t1 << kMaxPeriodShift) + "); give it max_delay instead to let the planner choose");
      k = 0;
      while (k < kMaxPeriodShift && (t1 << (k + 1)) <= per) ++k;
    }
    lp.shift = k;
  } else if (l.max_delay) {
    while (lp.shift < kMaxPeriodShift && ((Nanos{1} << (lp.shift + 1)) + 1) * t1 <= *l.max_delay) {
      ++lp.shift;
    }
  }
  (void)d;
  lp.period = t1 << lp.shift;
}

// Places each loop's samples (sensor and controller packet, same frame) at an
// offset of its period. Loops go in order of increasing period; each takes the
// offset whose frames are least loaded, among those where neither of its nodes
// already sends. With harmonic periods and no node conflicts this greedy meets
// the lower bound exactly: all frames of one residue class carry the same load
// when a loop is placed, and the class loads never differ by more than one.
void place_loops(const Design& d, Plan& p) {
  int max_shift = 0;
  for (const LoopPlan& lp : p.loops) max_shift = std::max(max_shift, lp.shift);
  const int64_t h = int64_t{1} << max_shift;
  p.hyperperiod = h;
  p.frame_load.assign(static_cast<size_t>(h), 0);
  std::vector<std::vector<uint8_t>> busy(static_cast<size_t>(d.nodes),
                                         std::vector<uint8_t>(static_cast<size_t>(h), 0));
  std::vector<size_t> order(p.loops.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return p.loops[a].shift < p.loops[b].shift; });
  for (size_t i : order) {
    LoopPlan& lp = p.loops[i];
    if (lp.sensor_node == lp.controller_node) continue;  // reported by the caller
    const int64_t m = int64_t{1} << lp.shift;
    auto& bs = busy[static_cast<size_t>(lp.sensor_node)];
    auto& bc = busy[static_cast<size_t>(lp.controller_node)];
    int64_t best = -1;
    int best_load = 0;
    for (int64_t o = 0; o < m; ++o) {
      bool free = true;
      int load = 0;
      for (int64_t f = o; f < h && free; f += m) {
        const auto fu = static_cast<size_t>(f);
        free = !bs[fu] && !bc[fu];
        load = std::max(load, p.frame_load[fu]);
      }
      if (free && (best < 0 || load < best_load)) {
        best = o;
        best_load = load;
      }
    }
    lp.offset = best;
    if (best < 0) continue;
    for (int64_t f = best; f < h; f += m) {
      const auto fu = static_cast<size_t>(f);
      bs[fu] = bc[fu] = 1;
      p.frame_load[fu] += kPacketsPerSample;
    }
  }
  p.gamma = p.frame_load.empty() ? 0 : *std::max_element(p.frame_load.begin(), p.frame_load.end());
  // Lower bound: the average load, 2 * sum(1 / m_i) packets per frame, rounded
  // up to whole samples (a sample's two packets share a frame).
  int64_t demand = 0;  // in 1/h frames
  for (const LoopPlan& lp : p.loops) demand += h >> lp.shift;
  p.gamma_lower_bound = kPacketsPerSample * static_cast<int>((demand + h - 1) / h);
}

// Every node must be able to send its sources' packets one per frame:
// sum over its sources of 1 / m <= 1, and a loop's two sources on two nodes.
bool check_nodes(const Design& d, Plan& p) {
  bool ok = true;
  const int64_t h = int64_t{1} << kMaxPeriodShift;
  std::vector<int64_t> demand(static_cast<size_t>(d.nodes), 0);  // in 1/h frames
  std::vector<int> sources(static_cast<size_t>(d.nodes), 0);
  for (const LoopPlan& lp : p.loops) {
    if (lp.sensor_node == lp.controller_node) {
      fail(p, Condition::kNodeLoad, lp.name,
           "loop " + lp.name + " has its sensor and its controller on node " +
               std::to_string(lp.sensor_node) +
               "; both send in the same frame and a node sends one periodic packet per frame");
      ok = false;
      continue;
    }
    for (int n : {lp.sensor_node, lp.controller_node}) {
      demand[static_cast<size_t>(n)] += h >> lp.shift;
      ++sources[static_cast<size_t>(n)];
    }
  }
  for (int n = 0; n < d.nodes; ++n) {
    const auto nu = static_cast<size_t>(n);
    if (sources[nu] > 0) ++p.periodic_nodes;
    if (demand[nu] > h) {
      fail(p, Condition::kNodeLoad, "",
           "node " + std::to_string(n) + " sends for " + std::to_string(sources[nu]) +
               " loop ends needing " + per_frame(demand[nu], h) +
               " periodic packets per frame; a node sends at most one per frame (give some "
               "loops longer periods or other nodes)");
      ok = false;
    }
  }
  return ok;
}

}  // namespace

const char* to_string(Condition c) {
  switch (c) {
    case Condition::kLink:
      return "link";
    case Condition::kFrame:
      return "frame";
    case Condition::kPeriod:
      return "period";
    case Condition::kWindows:
      return "windows";
    case Condition::kNodeLoad:
      return "node_load";
    case Condition::kStability:
      return "stability";
    case Condition::kNonrtPacket:
      return "nonrt_packet";
    case Condition::kC1:
      return "C1";
    case Condition::kC2:
      return "C2";
  }
  return "?";
}

Nanos Plan::shortfall() const {
  for (const Failure& f : failures) {
    if (f.condition == Condition::kStability) return f.shortfall;
  }
  for (const Failure& f : failures) {
    if (f.shortfall > 0) return f.shortfall;
  }
  return 0;
}

Plan plan(const Design& d) {
  Plan p;
  if (d.nodes < 2 || d.nodes > kMaxNodes) {
    fail(p, Condition::kLink, "",
         d.nodes <= 0   ? "the link has no nodes: the server visits nobody, so nothing can be sent"
         : d.nodes == 1 ? "the link has one node; a loop needs two (its sensor and "
                          "its controller send in the same frame)"
                        : "the link has " + std::to_string(d.nodes) +
                              " nodes; the PB byte's 7-bit address allows 127",
         0);
    return p;
  }
  if (d.loops.empty()) {
    fail(p, Condition::kLink, "", "the design has no loops, so there is no T_1 frame to plan");
    return p;
  }
  p.t1 = choose_frame(d);
  p.server_round = d.nodes * d.server_overhead;
  for (size_t i = 0; i < d.loops.size(); ++i) {
    const LoopSpec& l = d.loops[i];
    LoopPlan lp;
    lp.name = l.name;
    lp.max_delay = l.max_delay;
    const int auto_node = static_cast<int>((2 * i) % static_cast<size_t>(d.nodes));
    lp.sensor_node = l.sensor_node >= 0 ? l.sensor_node : auto_node;
    lp.controller_node = l.controller_node >= 0 ? l.controller_node : (auto_node + 1) % d.nodes;
    p.loops.push_back(lp);
  }
  if (p.t1 <= 0) {
    fail(p, Condition::kFrame, "", "T_1 comes out as " + t(p.t1) + "; no frame can be that short");
    return p;
  }
  for (size_t i = 0; i < d.loops.size(); ++i) choose_period(d, d.loops[i], p.t1, p.loops[i], p);

  if (p.t1 < d.periodic_packet) {
    fail(p, Condition::kFrame, "",
         "T_1 = " + t(p.t1) +
             " is shorter than one periodic packet (L_p = " + t(d.periodic_packet) + ")",
         d.periodic_packet - p.t1);
  }
  if (d.rt_queues > 0 && p.t1 < d.rt_packet) {
    fail(
        p, Condition::kFrame, "",
        "T_1 = " + t(p.t1) + " is shorter than one real-time packet (L_c = " + t(d.rt_packet) + ")",
        d.rt_packet - p.t1);
  }

  const bool nodes_ok = check_nodes(d, p);
  place_loops(d, p);
  if (p.gamma_lower_bound > p.periodic_nodes) {
    fail(p, Condition::kWindows, "",
         "the loops need at least " + std::to_string(p.gamma_lower_bound) +
             " periodic packets per frame (gamma) but only " + std::to_string(p.periodic_nodes) +
             " nodes send periodic data, one packet each per frame (gamma <= N_p)");
  } else if (nodes_ok) {
    for (const LoopPlan& lp : p.loops) {
      if (lp.offset < 0) {
        fail(p, Condition::kWindows, lp.name,
             "loop " + lp.name + " finds no frame offset where nodes " +
                 std::to_string(lp.sensor_node) + " and " + std::to_string(lp.controller_node) +
                 " are both free; move one of its ends to a less busy node");
      }
    }
  }

  p.periodic_part = p.gamma * d.periodic_packet + d.rt_queues * d.rt_packet + p.server_round;
  const Nanos slack = p.t1 - p.periodic_part;
  if (slack < 0) {
    fail(p, Condition::kStability, "",
         "gamma L_p + N_c L_c + R = " + std::to_string(p.gamma) + " * " + t(d.periodic_packet) +
             " + " + std::to_string(d.rt_queues) + " * " + t(d.rt_packet) + " + " +
             t(p.server_round) + " = " + t(p.periodic_part) + " exceeds T_1 = " + t(p.t1) + " by " +
             t(-slack),
         -slack);
  }
  const int64_t divisor = std::max<int64_t>(1, d.nodes - p.gamma + 1);
  p.ln_max = slack >= 0 ? slack / divisor : 0;
  if (slack >= 0 && d.nonrt_packet && *d.nonrt_packet > p.ln_max) {
    fail(p, Condition::kNonrtPacket, "",
         "the non-RT packet " + t(*d.nonrt_packet) + " exceeds L_n max = (" + t(p.t1) + " - " +
             t(p.periodic_part) + ") / (" + std::to_string(d.nodes) + " - " +
             std::to_string(p.gamma) + " + 1) = " + t(p.ln_max) + " by " +
             t(*d.nonrt_packet - p.ln_max),
         *d.nonrt_packet - p.ln_max);
  } else if (slack >= 0 && d.nonrt_packet && p.ln_max < d.nonrt_min_packet) {
    fail(p, Condition::kNonrtPacket, "",
         "L_n max = " + t(p.ln_max) + " is shorter than the shortest packet the link carries (" +
             t(d.nonrt_min_packet) + "): no non-RT traffic can move",
         d.nonrt_min_packet - p.ln_max);
  }
  p.nonrt_packet = d.nonrt_packet ? *d.nonrt_packet : p.ln_max;

  // W: at a frame start the bus may be busy with one packet (non-RT, RT) or one
  // server move; then one full round sends every periodic packet of the frame.
  Nanos in_flight = std::max(p.nonrt_packet, d.server_overhead);
  if (d.rt_queues > 0) in_flight = std::max(in_flight, d.rt_packet);
  p.transfer_bound = in_flight + p.periodic_part;
  if (slack >= 0 && p.transfer_bound > p.t1) {
    fail(p, Condition::kC1, "",
         "a periodic packet may wait " + t(in_flight) +
             " for the packet in flight at the frame "
             "start, then the periodic part: " +
             t(p.transfer_bound) + " exceeds T_1 = " + t(p.t1) + " by " +
             t(p.transfer_bound - p.t1),
         p.transfer_bound - p.t1);
  }
  for (LoopPlan& lp : p.loops) {
    lp.delay_bound = lp.period + p.transfer_bound;
    if (lp.max_delay && lp.delay_bound > *lp.max_delay) {
      fail(p, Condition::kC2, lp.name,
           "loop " + lp.name + ": D = T_i + W = " + t(lp.period) + " + " + t(p.transfer_bound) +
               " = " + t(lp.delay_bound) + " exceeds max_delay " + t(*lp.max_delay) + " by " +
               t(lp.delay_bound - *lp.max_delay),
           lp.delay_bound - *lp.max_delay);
    }
  }
  p.feasible = p.failures.empty();
  return p;
}

}  // namespace rtplc::fieldbus
