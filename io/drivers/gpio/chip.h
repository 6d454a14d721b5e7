// How the gpio driver reaches GPIO lines: a small table of operations over an
// opaque chip and opaque requested lines, so the driver, the commissioning CLI
// and the tests share one core whatever holds the lines.
//   gpiod_chip_ops()  the kernel's GPIO character device through libgpiod 1.6
//                     (/dev/gpiochipN; gpiod_chip.cpp);
//   fake_chip.h       an in-process chip for host tests (fake_chip.cpp).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/result.h"

namespace rtplc::gpio {

enum class Bias : uint8_t { kAsIs, kDisable, kPullUp, kPullDown };
enum class Edge : uint8_t { kNone, kRising, kFalling, kBoth };

// What one line is requested as. Values are logical: with active_low a
// physical low reads 1 and an output set to 1 drives the line low.
struct LineRequest {
  unsigned offset = 0;
  bool output = false;
  bool active_low = false;
  Bias bias = Bias::kAsIs;
  Edge edge = Edge::kNone;  // inputs: also queue these edges as events
  int initial = 0;          // outputs: the level driven at once
};

struct EdgeEvent {
  bool rising = false;  // logical (active_low taken into account by the kernel)
  int64_t ts_ns = 0;    // the kernel's timestamp (CLOCK_MONOTONIC)
};

struct LineInfo {
  unsigned offset = 0;
  std::string name;      // empty: unnamed
  std::string consumer;  // empty: free
  bool used = false;
  bool output = false;
  bool active_low = false;
};

struct ChipInfo {
  std::string name;   // gpiochip0
  std::string label;  // the driver's label: gpio-sim.0-node0, pinctrl-bcm2711
  unsigned lines = 0;
};

struct ChipOps {
  const char* name;
  void* context;  // what open() gets first (the fake's chip set; null for libgpiod)
  // "gpiochip0", "/dev/gpiochip0", "0" or a chip label; fails saying why.
  Result<void*> (*open)(void* context, const std::string& chip);
  void (*close)(void* chip);
  ChipInfo (*chip_info)(void* chip);
  LineInfo (*line_info)(void* chip, unsigned offset);
  // The offset of the line called `name` on this chip; -1 when none is.
  int (*find)(void* chip, const std::string& name);
  // Requests one line for `consumer`; fails saying why (busy, no such offset).
  Result<void*> (*request)(void* chip, const LineRequest& req, const char* consumer);
  void (*release)(void* line);
  // 0 or 1, or -errno.
  int (*get)(void* line);
  // 0 or an errno.
  int (*set)(void* line, int value);
  // Waits at most timeout_ns until one of `lines` (requested with edges) has
  // events queued; ready[i] says which. Returns how many are ready, or -errno.
  int (*wait)(std::span<void* const> lines, int64_t timeout_ns, bool* ready);
  // Takes up to `max` queued events of a ready line, oldest first: how many,
  // or -errno.
  int (*read_events)(void* line, EdgeEvent* out, unsigned max);
};

const ChipOps& gpiod_chip_ops();
// Whether this machine has any GPIO character device (and why not).
Result<void> gpio_cdev_available();

}  // namespace rtplc::gpio
