// The `gpio` driver kind's settings (issue "CAN/GPIO", GPIO half; docs/gpio.md):
// GPIO lines of the kernel's character device as direct I/O (the DIO group):
//   inputs    lines read into `ddi` channels (`in/DIO/pN.dN.cN`);
//   outputs   lines driven from `ddo` outputs (`out/DIO/pN.dN.cN`);
//   counters  edges of input lines counted into `dpi` channels
//             (`in/DIOP/pN.dN.cN`, device letter P).
// A line is a chip and an offset, or a line name found on the chip at start.
// Parsed by config.cpp; kept in DriverConfig::settings as a GpioSettings.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "config/driver_kinds.h"
#include "config/values.h"
#include "io/drivers/gpio/chip.h"

namespace rtplc::gpio {

using config::ChannelAddress;

enum class Role : uint8_t { kInput, kOutput, kCounter };

struct LineMap {
  Role role = Role::kInput;
  ChannelAddress addr;
  std::string channel;       // "pN.dN.cN"
  std::string chip;          // as configured: gpiochip0, /dev/gpiochip0, a label
  std::string line_name;     // empty: by offset
  unsigned offset = 0;       // when line_name is empty
  bool active_low = false;
  Bias bias = Bias::kAsIs;
  Edge edge = Edge::kNone;   // counters: rising, falling or both
  int64_t debounce_ns = 0;   // inputs: stable this long; counters: edges closer than this to the last counted one are ignored
  int safe = 0;              // outputs: driven while the task's value cannot be vouched for
  SourcePos pos, line_pos;
};

// Lines one driver's I/O thread waits on (counters and debounced inputs).
inline constexpr size_t kMaxEventLines = 64;

struct GpioSettings {
  std::string chip;  // the default chip of the entries
  std::vector<LineMap> lines;  // inputs, counters, then outputs, each as listed
};

const GpioSettings& settings_of(const config::DriverConfig& d);
// "line 3" or "line 'START'" for messages.
std::string line_text(const LineMap& m);
// The same in a fixed buffer, for the bridge's cycle (no allocation).
struct LineChars {
  char s[48];
};
LineChars line_chars(const LineMap& m) noexcept;

extern const config::DriverKind kConfigKind;

}  // namespace rtplc::gpio
