// Helpers shared by the S7 tests that use real sockets: waiting for a condition
// (a generous limit so a broken build fails instead of hanging, never a speed
// assertion) and loopback addresses that do not collide between test processes.
#pragma once

#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include <fmt/format.h>

namespace rtplc::s7::testing {

// Waits until `pred` holds; false if it still does not after `limit`.
template <typename Pred>
bool wait_for(Pred&& pred, std::chrono::milliseconds limit = std::chrono::seconds(30)) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return pred();
}

// A loopback address of its own for endpoint `i` of this process (127.0.0.0/8).
inline std::string loopback(unsigned i) {
  const unsigned pid = static_cast<unsigned>(::getpid());
  return fmt::format("127.{}.{}.{}", 100 + pid % 100, (pid / 100 + i / 250) % 250, 1 + i % 250);
}

}  // namespace rtplc::s7::testing
