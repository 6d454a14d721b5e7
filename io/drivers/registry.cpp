// The built-in driver kinds. Adding a driver is its folder under io/drivers/
// (which the build picks up by itself) and one entry in this list: the
// namespace of its `const io::DriverKind kDriverKind`.
//
// This file is an OBJECT library linked into the rtplc binary and every test
// that loads configurations, so its registration runs before main() in each.
#include "io/drivers/driver.h"

#define RTPLC_BUILTIN_DRIVERS(X) \
  X(sim)                         \
  X(s7)                          \
  X(modbus)                      \
  X(modbus_server)               \
  X(can)                         \
  X(gpio)                        \
  X(sparkplug)                   \
  /* one line per driver, above this one */

#define RTPLC_DECLARE_DRIVER(ns) \
  namespace rtplc::ns {          \
  extern const io::DriverKind kDriverKind; \
  }
RTPLC_BUILTIN_DRIVERS(RTPLC_DECLARE_DRIVER)

namespace {

const bool kRegistered = [] {
#define RTPLC_REGISTER_DRIVER(ns) rtplc::io::register_driver_kind(&rtplc::ns::kDriverKind);
  RTPLC_BUILTIN_DRIVERS(RTPLC_REGISTER_DRIVER)
  return true;
}();

}  // namespace
