// Steps of the driver life (io/drivers/driver.h) that several kinds take the
// same way: creating a driver whose prepare() can refuse the config, and the
// last sends at stop.
#pragma once

#include <cstdint>
#include <memory>

#include "common/result.h"
#include "io/drivers/driver.h"
#include "kernel_rt/clock.h"

namespace rtplc::io {

// A kind's create(): a `D` built on `setup`, or the error of its prepare().
template <class D>
Result<std::unique_ptr<Driver>> create_prepared(const DriverSetup& setup) {
  auto d = std::make_unique<D>(setup);
  if (auto r = d->prepare(); !r) return make_error(r.error());
  return std::unique_ptr<Driver>(std::move(d));
}

// For on_stop(), once the tasks have set their outputs to their safe values:
// runs `cycle(now)` until `pending()` says nothing waits to be sent or
// acknowledged any more, or `budget_ns` has passed, sleeping `step_ns`
// between cycles so the driver's I/O threads get them out. Not for the RT
// cycle (it sleeps).
template <class Cycle, class Pending>
void cycle_until_sent(int64_t budget_ns, int64_t step_ns, const Cycle& cycle, const Pending& pending) {
  const int64_t give_up = kernel_rt::monotonic_now_ns() + budget_ns;
  for (;;) {
    cycle(kernel_rt::monotonic_now_ns());
    if (!pending() || kernel_rt::monotonic_now_ns() > give_up) break;
    kernel_rt::sleep_until_ns(kernel_rt::monotonic_now_ns() + step_ns);
  }
}

}  // namespace rtplc::io
