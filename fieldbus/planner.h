// The fieldbus bandwidth planner (spec io-links.md, "Fieldbus bandwidth
// allocation"; docs/fieldbus.md, "How the planner decides"): from a Design it
// chooses T_1 and the harmonic sampling periods, places every loop's samples in
// T_1 frames so that no frame carries more than gamma periodic packets (window
// scheduling), checks the seed's conditions and computes the largest non-RT
// packet
//   L_n <= [T_1 - (gamma L_p + N_c L_c + R)] / (N - gamma + 1).
// A design that cannot work comes back with every failed condition and by how
// much it fails; the planner never stops at the first.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fieldbus/design.h"

namespace rtplc::fieldbus {

enum class Condition : uint8_t {
  kLink,         // the link itself cannot carry a loop (no nodes, ...)
  kFrame,        // T_1 shorter than one packet
  kPeriod,       // a fixed period that is not T_1 * 2^k
  kWindows,      // more periodic packets per frame than nodes sending them (gamma > N_p)
  kNodeLoad,     // one node asked for more than one periodic packet per frame
  kStability,    // gamma L_p + N_c L_c + R <= T_1
  kNonrtPacket,  // the non-RT packet the file asks for is longer than L_n max
  kC1,           // transfer delay of every sample <= T_1 (no loss, no vacant sampling)
  kC2,           // loop delay D_i <= Phi_i
};
const char* to_string(Condition c);  // "stability", "C2", ...

struct Failure {
  Condition condition;
  std::string loop;     // the loop it concerns, or ""
  std::string message;  // one sentence with the numbers
  Nanos shortfall = 0;  // by how much time it fails; 0 when it is not a time
};

struct LoopPlan {
  std::string name;
  Nanos period = 0;  // T_i = T_1 * 2^shift
  int shift = 0;
  int64_t offset = -1;  // first T_1 frame of each period; -1 = not placed
  int sensor_node = 0;
  int controller_node = 0;
  Nanos delay_bound = 0;  // D_i <= T_i + W
  std::optional<Nanos> max_delay;
  bool fixed = false;  // period given by the file
};

struct Plan {
  bool feasible = false;
  Nanos t1 = 0;
  int gamma = 0;                // periodic packets in the busiest frame
  int gamma_lower_bound = 0;    // no schedule of these periods can do better
  int periodic_nodes = 0;       // N_p
  Nanos server_round = 0;       // R = N sigma
  Nanos periodic_part = 0;      // gamma L_p + N_c L_c + R
  Nanos ln_max = 0;             // meaningful when periodic_part <= t1
  Nanos nonrt_packet = 0;       // the non-RT packet the simulation uses
  Nanos transfer_bound = 0;     // W: worst transfer delay of a periodic packet
  int64_t hyperperiod = 1;      // frames after which the schedule repeats
  std::vector<int> frame_load;  // periodic packets per frame, one per frame of the hyperperiod
  std::vector<LoopPlan> loops;  // in the file's order
  std::vector<Failure> failures;

  // The first time shortfall among the failures (the stability one first), 0 if none.
  Nanos shortfall() const;
};

Plan plan(const Design& d);

}  // namespace rtplc::fieldbus
