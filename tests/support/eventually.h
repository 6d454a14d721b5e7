// Waiting for something a running runtime, driver or peer does "soon": polls
// `condition` every 20 ms until it holds or `seconds` passed. The bound only
// keeps a broken test from hanging; it is generous for a loaded machine and no
// claim about speed (a condition that holds returns at once).
#pragma once

#include <chrono>
#include <thread>

namespace rtplc::testing {

template <class F>
bool eventually(F condition, double seconds = 10) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < until) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return condition();
}

}  // namespace rtplc::testing
