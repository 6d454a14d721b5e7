// The input of the fieldbus planner: one cyclic-service link, its traffic and
// its control loops, with every length already a time (spec io-links.md,
// "Fieldbus bandwidth allocation"; docs/fieldbus.md, "The plan file").
// plan_file.cpp fills it from YAML; tests and the benchmark build it directly.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "fieldbus/link_timing.h"
#include "fieldbus/units.h"

namespace rtplc::fieldbus {

// How the server travels. The planner treats both the same way (sigma is what
// one visit costs); the name is kept for the report and the simulation's labels.
enum class Access : uint8_t { kPolling, kTokenPassing };

// The node address lives in the 7 low bits of the PB byte the seed adds to the
// server's frame control, so a link has at most 127 nodes.
inline constexpr int kMaxNodes = 127;
// Sampling periods are T_1 * 2^k; a longer period only saves bandwidth the
// planner no longer needs to count, so k stops here (a loop is then sampled
// faster than its bound requires, which is always safe).
inline constexpr int kMaxPeriodShift = 12;  // 4096 frames
inline constexpr int kMaxLoops = 4096;

struct LoopSpec {
  std::string name;
  std::optional<Nanos> period;     // fixed sampling period T_i
  std::optional<Nanos> max_delay;  // loop-delay bound Phi_i
  int sensor_node = -1;            // -1: the planner places it
  int controller_node = -1;
  SourcePos pos;  // the loop's entry in the plan file
};

struct Design {
  int nodes = 0;              // N
  Nanos server_overhead = 0;  // sigma; R = N sigma
  Access access = Access::kPolling;
  std::optional<Nanos> frame;         // T_1 forced by the file; else chosen
  Nanos periodic_packet = 0;          // L_p
  int rt_queues = 0;                  // N_c
  Nanos rt_packet = 0;                // L_c
  std::optional<Nanos> nonrt_packet;  // the non-RT packet the user means to use
  Nanos nonrt_min_packet = 1;         // the shortest non-RT packet the link can carry
  // Sporadic traffic of the simulation: arrivals per second per RT queue and per
  // node for non-RT packets; a negative non-RT rate means every node always has
  // non-RT data waiting (the worst case for the periodic traffic).
  double rt_rate = 10;
  double nonrt_rate = -1;
  std::vector<LoopSpec> loops;
  std::string link_text;  // "CAN 11-bit id at 500 kbit/s", for the report
  // The bit rate and frame layout, when the file gave them: a link that runs
  // on the plan (link_plan.h) computes its own frames' wire times with it.
  std::optional<LinkTiming> timing;
};

// The worked example of docs/fieldbus.md in its generic form (what
// examples/fieldbus.yaml says, a test holds them equal): 10 nodes, sigma 20 us,
// L_p 100 us, two RT queues of 150 us packets, L1 at T = 5 ms, L2 with a 25 ms
// delay bound. The planner's tests and benchmark start from it.
Design worked_example();

}  // namespace rtplc::fieldbus
