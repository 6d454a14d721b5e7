// Small nets shared by the Petri-net tests, built through the public API.
#pragma once

#include <string>

#include "lang/petri/net.h"

namespace rtplc::petri::testing {

// Two processes take resources R1, R2 in opposite orders: one deadlock {A1, B1}.
inline Net deadlock_net() {
  Net n("deadlock");
  const PlaceId a0 = n.add_place("A0", 1).value(), a1 = n.add_place("A1").value(),
                a2 = n.add_place("A2").value();
  const PlaceId b0 = n.add_place("B0", 1).value(), b1 = n.add_place("B1").value(),
                b2 = n.add_place("B2").value();
  const PlaceId r1 = n.add_place("R1", 1).value(), r2 = n.add_place("R2", 1).value();
  auto step = [&n](const std::string& id, PlaceId from, PlaceId res, PlaceId to) {
    const TransitionId t = n.add_transition(id).value();
    n.add_input(from, t);
    n.add_input(res, t);
    n.add_output(t, to);
  };
  auto release = [&n, r1, r2](const std::string& id, PlaceId from, PlaceId to) {
    const TransitionId t = n.add_transition(id).value();
    n.add_input(from, t);
    n.add_output(t, to);
    n.add_output(t, r1);
    n.add_output(t, r2);
  };
  step("takeR1_A", a0, r1, a1);
  step("takeR2_A", a1, r2, a2);
  release("release_A", a2, a0);
  step("takeR2_B", b0, r2, b1);
  step("takeR1_B", b1, r1, b2);
  release("release_B", b2, b0);
  return n;
}

// A producer that never waits: `buffer` grows without bound.
inline Net producer_net() {
  Net n("producer");
  const PlaceId ready = n.add_place("ready", 1).value();
  const PlaceId buffer = n.add_place("buffer").value();
  const PlaceId consumer = n.add_place("consumer", 1).value();
  const TransitionId produce = n.add_transition("produce").value();
  n.add_read(ready, produce);
  n.add_output(produce, buffer);
  const TransitionId consume = n.add_transition("consume").value();
  n.add_input(buffer, consume);
  n.add_read(consumer, consume);
  return n;
}

}  // namespace rtplc::petri::testing
