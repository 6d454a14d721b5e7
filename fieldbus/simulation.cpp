// The cyclic-server simulation (see simulation.h; protocol in docs/fieldbus.md,
// "Simulating the plan").
#include "fieldbus/simulation.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <queue>
#include <random>

namespace rtplc::fieldbus {
namespace {

// One periodic queue of capacity one: a loop's sensor or its controller.
struct Source {
  int loop = 0;
  bool controller = false;
  bool pending = false;
  Nanos queued_at = 0;
  Nanos basis = -1;  // controller: the sensor sampling its control comes from
};

struct LoopState {
  int64_t fresh = 0;  // sensor values received since the controller last sampled
  Nanos latest_sensor_sample = -1;
  bool sampled_once = false;
};

struct Arrival {
  Nanos at;
  int queue;  // >= 0: RT queue; < 0: non-RT of node -queue-1
  bool operator>(const Arrival& o) const { return at > o.at || (at == o.at && queue > o.queue); }
};

DelaySummary stats_of(std::vector<Nanos>& v) {
  DelaySummary s;
  s.count = static_cast<int64_t>(v.size());
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) {
    const auto i = static_cast<size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
    return v[std::min(i, v.size() - 1)];
  };
  s.p50 = at(0.50);
  s.p99 = at(0.99);
  s.max = v.back();
  return s;
}

class BusSimulation {
 public:
  BusSimulation(const Design& d, const Plan& p, const SimOptions& o)
      : d_(d), p_(p), opt_(o), rng_(o.seed) {
    node_sources_.resize(static_cast<size_t>(d.nodes));
    node_rt_.resize(static_cast<size_t>(d.nodes));
    nonrt_.resize(static_cast<size_t>(d.nodes));
    loops_.resize(p.loops.size());
    frame_loops_.resize(static_cast<size_t>(p.hyperperiod));
    for (size_t i = 0; i < p.loops.size(); ++i) {
      const LoopPlan& l = p.loops[i];
      for (bool ctl : {false, true}) {
        sources_.push_back(Source{static_cast<int>(i), ctl, false, 0, -1});
        const int node = ctl ? l.controller_node : l.sensor_node;
        node_sources_[static_cast<size_t>(node)].push_back(sources_.size() - 1);
      }
      const int64_t m = l.period / p.t1;
      // A loop the planner could not place (an infeasible plan) samples at
      // offset 0, so the run shows what the overload does.
      for (int64_t f = std::max<int64_t>(0, l.offset); f < p.hyperperiod; f += m) {
        frame_loops_[static_cast<size_t>(f)].push_back(i);
      }
    }
    rt_.resize(static_cast<size_t>(d.rt_queues));
    for (int q = 0; q < d.rt_queues; ++q) {
      node_rt_[static_cast<size_t>(q % d.nodes)].push_back(q);
      if (d.rt_rate > 0) schedule(q, 0, d.rt_rate);
    }
    saturated_ = d.nonrt_rate < 0;
    if (!saturated_ && d.nonrt_rate > 0) {
      for (int n = 0; n < d.nodes; ++n) schedule(-n - 1, 0, d.nonrt_rate);
    }
    r_.nonrt_saturated = saturated_;
    for (const LoopPlan& l : p.loops) r_.loops.push_back(LoopSimStats{l.name, 0, 0, 0});
  }

  SimResult run() {
    const Nanos end = opt_.duration;
    Nanos t = 0;
    int node = 0;
    while (t < end) {
      t += d_.server_overhead;  // the poll or token reaches `node`
      advance(t, true);
      visit(node, t);
      node = (node + 1) % d_.nodes;
    }
    finish(end);
    return std::move(r_);
  }

 private:
  // Exponential gaps from our own transform of the 64-bit generator, so the
  // arrivals do not depend on a standard library's distribution code.
  void schedule(int queue, Nanos after, double rate) {
    const double u = static_cast<double>(rng_() >> 11) * 0x1.0p-53;
    const double gap_s = -std::log1p(-u) / rate;
    const Nanos gap = std::max<Nanos>(1, static_cast<Nanos>(gap_s * 1e9));
    arrivals_.push(Arrival{after + gap, queue});
  }

  // Everything that happens up to `t`: frame boundaries (sampling) and sporadic
  // arrivals. `inclusive` also takes those at exactly `t` (before a decision);
  // a delivery at `t` comes before a sampling at `t`, so it counts as in time.
  void advance(Nanos t, bool inclusive) {
    while (next_frame_ * p_.t1 < t || (inclusive && next_frame_ * p_.t1 == t)) {
      start_frame(next_frame_++);
    }
    while (!arrivals_.empty() &&
           (arrivals_.top().at < t || (inclusive && arrivals_.top().at == t))) {
      const Arrival a = arrivals_.top();
      arrivals_.pop();
      if (a.queue >= 0) {
        rt_[static_cast<size_t>(a.queue)].push_back(a.at);
        schedule(a.queue, a.at, d_.rt_rate);
      } else {
        nonrt_[static_cast<size_t>(-a.queue - 1)].push_back(a.at);
        schedule(a.queue, a.at, d_.nonrt_rate);
      }
    }
  }

  void start_frame(int64_t f) {
    const Nanos at = f * p_.t1;
    for (size_t li : frame_loops_[static_cast<size_t>(f % p_.hyperperiod)]) {
      LoopState& ls = loops_[li];
      LoopSimStats& st = r_.loops[li];
      // The controller samples: it should find exactly one new sensor value.
      if (ls.sampled_once) {
        if (ls.fresh == 0) {
          ++st.vacant;
          ++r_.vacant_samplings;
        } else if (ls.fresh > 1) {
          st.lost += ls.fresh - 1;
          r_.lost_samples += ls.fresh - 1;
        }
      }
      const Nanos basis = ls.sampled_once && ls.fresh > 0 ? ls.latest_sensor_sample : -1;
      ls.fresh = 0;
      ls.sampled_once = true;
      for (size_t k = 0; k < 2; ++k) {
        Source& s = sources_[2 * li + k];
        if (s.pending) {  // the old sample was never sent: the new one replaces it
          ++st.lost;
          ++r_.lost_samples;
        }
        s.pending = true;
        s.queued_at = at;
        s.basis = s.controller ? basis : -1;
        ++r_.samples;
      }
    }
  }

  void deliver(Source& s, Nanos t) {
    s.pending = false;
    const Nanos transfer = t - s.queued_at;
    periodic_.push_back(transfer);
    if (transfer > p_.t1) ++r_.late_packets;
    LoopState& ls = loops_[static_cast<size_t>(s.loop)];
    if (!s.controller) {
      ++ls.fresh;
      ls.latest_sensor_sample = s.queued_at;
    } else if (s.basis >= 0) {
      const Nanos dl = t - s.basis;
      loop_.push_back(dl);
      LoopSimStats& st = r_.loops[static_cast<size_t>(s.loop)];
      st.worst_delay = std::max(st.worst_delay, dl);
    }
  }

  bool has_pending(int node) const {
    for (size_t si : node_sources_[static_cast<size_t>(node)]) {
      if (sources_[si].pending) return true;
    }
    return false;
  }

  void visit(int node, Nanos& t) {
    // Back at the node that raised PSB: the periodic part is over, PB cleared.
    if (psb_ && node == raiser_) psb_ = false;
    // Real-time first: one packet of each of the node's queues.
    for (int q : node_rt_[static_cast<size_t>(node)]) {
      auto& queue = rt_[static_cast<size_t>(q)];
      if (queue.empty()) continue;
      const Nanos arrived = queue.front();
      queue.pop_front();
      t += d_.rt_packet;
      realtime_.push_back(t - arrived);
      advance(t, true);
    }
    // Frame-aligned PSB: every node samples on the T_1 grid, so the first node
    // the server reaches after a frame boundary opens that frame's periodic
    // part, as does any node holding periodic data while PSB is clear.
    const int64_t frame = t / p_.t1;
    if (!psb_ && (frame > raised_frame_ || has_pending(node))) {
      psb_ = true;
      raiser_ = node;
      raised_frame_ = frame;
    }
    if (psb_) {
      for (size_t si : node_sources_[static_cast<size_t>(node)]) {
        Source& s = sources_[si];
        if (!s.pending) continue;
        t += d_.periodic_packet;
        advance(t, false);
        deliver(s, t);
      }
      return;
    }
    if (p_.nonrt_packet <= 0) return;
    auto& q = nonrt_[static_cast<size_t>(node)];
    if (saturated_ || !q.empty()) {
      t += p_.nonrt_packet;
      ++r_.nonrt_packets;
      if (!saturated_) {
        nonrt_delays_.push_back(t - q.front());
        q.pop_front();
      }
    }
  }

  void finish(Nanos end) {
    r_.duration = end;
    const double secs = to_seconds(end);
    r_.nonrt_per_second = static_cast<double>(r_.nonrt_packets) / secs;
    r_.nonrt_bus_share = static_cast<double>(r_.nonrt_packets) *
                         static_cast<double>(p_.nonrt_packet) / static_cast<double>(end);
    if (opt_.keep_samples) {
      r_.periodic_samples = periodic_;
      r_.loop_samples = loop_;
      r_.realtime_samples = realtime_;
      r_.nonrt_samples = nonrt_delays_;
    }
    r_.periodic = stats_of(periodic_);
    r_.loop_delay = stats_of(loop_);
    r_.realtime = stats_of(realtime_);
    r_.nonrt = stats_of(nonrt_delays_);
  }

  const Design& d_;
  const Plan& p_;
  const SimOptions& opt_;
  std::mt19937_64 rng_;
  std::vector<Source> sources_;
  std::vector<std::vector<size_t>> node_sources_;
  std::vector<std::vector<int>> node_rt_;
  std::vector<std::deque<Nanos>> rt_;
  std::vector<std::deque<Nanos>> nonrt_;
  std::vector<LoopState> loops_;
  std::vector<std::vector<size_t>> frame_loops_;
  std::priority_queue<Arrival, std::vector<Arrival>, std::greater<>> arrivals_;
  bool saturated_ = false;
  bool psb_ = false;
  int raiser_ = -1;
  int64_t raised_frame_ = -1;
  int64_t next_frame_ = 0;
  std::vector<Nanos> periodic_, loop_, realtime_, nonrt_delays_;
  SimResult r_;
};

}  // namespace

Result<SimResult> simulate(const Design& d, const Plan& p, const SimOptions& opt) {
  if (d.nodes < 2 || p.t1 <= 0) return make_error("the design has no usable link or frame");
  if (d.server_overhead <= 0) {
    return make_error(
        "the simulation needs a server overhead above 0 (an idle server would "
        "circle in no time)");
  }
  if (p.loops.size() != d.loops.size()) return make_error("the plan does not match the design");
  if (opt.duration <= 0) return make_error("the simulated duration must be above 0");
  BusSimulation sim(d, p, opt);
  return sim.run();
}

}  // namespace rtplc::fieldbus
