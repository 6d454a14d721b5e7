// docs/fieldbus.md's worked example as a Design (fieldbus/design.h).
#include "fieldbus/design.h"

namespace rtplc::fieldbus {

Design worked_example() {
  constexpr Nanos us = 1'000;
  constexpr Nanos ms = 1'000'000;
  Design d;
  d.nodes = 10;
  d.server_overhead = 20 * us;
  d.periodic_packet = 100 * us;
  d.rt_queues = 2;
  d.rt_packet = 150 * us;
  d.loops.push_back({"L1", 5 * ms, std::nullopt, -1, -1, {}});
  d.loops.push_back({"L2", std::nullopt, 25 * ms, -1, -1, {}});
  return d;
}

}  // namespace rtplc::fieldbus
