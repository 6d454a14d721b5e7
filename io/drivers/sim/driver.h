// The `sim` I/O driver (spec io-links.md, "The simulated plant"): each cycle it
// reads every plant's input from the task output that drives it (a dao
// channel), integrates the plant in real time with RK4, and publishes the
// plant's output as the driver's input channel (the dai a task reads). It is
// how the runtime runs with no hardware, and how the tests close real loops
// through the process image.
//
// A plant whose input cannot be read (no consistent snapshot, or the task
// marked the output bad: stopped code, an output a swap dropped) holds the last
// input it had — an actuator keeps its position when its command stops
// arriving — and the delivery entry of that output says bad.
#pragma once

#include <memory>
#include <vector>

#include "io/drivers/driver.h"
#include "io/drivers/sim/plant.h"

namespace rtplc::sim {

struct PlantWiring {
  std::unique_ptr<io::Plant> plant;
  double input = 0;  // the last input applied (held on a miss)
};

class SimDriver final : public io::Driver {
 public:
  SimDriver(const io::DriverSetup& setup, std::vector<PlantWiring> plants);
  ~SimDriver() override {
    request_stop();
    join();
  }

  // Tests: the input plant p is integrating with now.
  double held_input(size_t p) const { return plants_[p].input; }
  double plant_output(size_t p) const { return plants_[p].plant->output(); }

 private:
  void cycle(int64_t now_ns) noexcept override;

  std::vector<PlantWiring> plants_;
  double step_s_ = 0.001;
  int steps_ = 10;
  bool first_ = true;  // the publish before the first cycle integrates nothing
};

extern const io::DriverKind kDriverKind;

}  // namespace rtplc::sim
