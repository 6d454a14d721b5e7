// The driver kinds' own commissioning commands (`rtplc s7 ...`): each kind
// that has some adds them through its hook (io/drivers/driver.h); the app
// names no kind.
#include <CLI/CLI.hpp>

#include "app/commands.h"
#include "io/drivers/driver.h"

namespace rtplc::app {

void add_driver_commands(CLI::App& app) {
  for (const io::DriverKind* k : io::driver_kinds()) {
    if (k->add_commands != nullptr) k->add_commands(app);
  }
}

}  // namespace rtplc::app
