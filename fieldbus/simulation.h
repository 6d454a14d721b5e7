// A discrete-event simulation of the cyclic server of one planned link (spec
// io-links.md, "Fieldbus bandwidth allocation": per-class delay statistics that
// show the design holds; docs/fieldbus.md, "Simulating the plan"). The server
// (poll or token) visits the nodes in a fixed order; at each visit the node
// sends one packet of each of its real-time queues first, then its periodic
// packets while the PB byte's PSB bit marks the periodic part, else one non-RT
// packet. Sampling follows the plan's periods and frame offsets; real-time and
// non-RT packets arrive at random (Poisson) or, for non-RT, saturate the bus.
// Time is whole nanoseconds and randomness comes from one seeded generator, so a
// run is the same on every machine for the same seed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.h"
#include "fieldbus/design.h"
#include "fieldbus/planner.h"

namespace rtplc::fieldbus {

struct SimOptions {
  Nanos duration = 60 * kNanosPerSecond;
  uint64_t seed = 1;
  bool keep_samples = false;  // keep every delay (for --plot)
};

struct DelaySummary {
  int64_t count = 0;
  Nanos p50 = 0;
  Nanos p99 = 0;
  Nanos max = 0;
};

struct LoopSimStats {
  std::string name;
  Nanos worst_delay = 0;  // worst loop delay D_i seen
  int64_t lost = 0;
  int64_t vacant = 0;
};

struct SimResult {
  Nanos duration = 0;
  DelaySummary periodic;    // queueing to complete receipt, every periodic packet
  DelaySummary loop_delay;  // sensor sampling to the actuator's receipt of its control
  DelaySummary realtime;
  DelaySummary nonrt;              // count only when the non-RT traffic saturates the bus
  int64_t samples = 0;           // periodic packets queued
  int64_t lost_samples = 0;      // overwritten before sent, or unused by the controller
  int64_t vacant_samplings = 0;  // controller samplings with no new sensor value
  int64_t late_packets = 0;      // periodic packets delivered later than T_1
  int64_t nonrt_packets = 0;
  double nonrt_per_second = 0;
  double nonrt_bus_share = 0;  // fraction of bus time carrying non-RT packets
  bool nonrt_saturated = false;
  std::vector<LoopSimStats> loops;
  // With SimOptions::keep_samples: every delay per class, in nanoseconds.
  std::vector<Nanos> periodic_samples, loop_samples, realtime_samples, nonrt_samples;
};

// Simulates any plan, infeasible ones too (that is how a user sees a design
// break); needs a server overhead above 0.
Result<SimResult> simulate(const Design& d, const Plan& p, const SimOptions& opt);

}  // namespace rtplc::fieldbus
