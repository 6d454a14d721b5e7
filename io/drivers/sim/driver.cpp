// The sim driver's cycle and its kind (see driver.h).
#include "io/drivers/sim/driver.h"

#include "io/drivers/sim/config.h"

namespace rtplc::sim {

SimDriver::SimDriver(const io::DriverSetup& setup, std::vector<PlantWiring> plants)
    : io::Driver(setup, "sim"), plants_(std::move(plants)) {
  step_s_ = io::plant_step_for(static_cast<double>(setup.period_ns) / 1e9, &steps_);
  for (PlantWiring& p : plants_) p.plant->reset();
}

void SimDriver::cycle(int64_t now_ns) noexcept {
  const uint32_t k = begin_snapshot();
  for (uint32_t i = 0; i < plants_.size(); ++i) {
    PlantWiring& p = plants_[i];
    double u = 0;
    // A task mid-write never blocks us: we read its last completed snapshot.
    // Not good: the output's on_bad policy (hold keeps the plant's last input).
    const bool usable = output_to_send(i, u, now_ns) == io::SendDecision::kSend;
    if (usable) p.input = u;
    if (!first_) {
      for (int s = 0; s < steps_; ++s) p.plant->step(p.input, step_s_);
    }
    put_input(k, i, p.plant->output(), Quality::kGood, now_ns);
    put_delivery(k, i, p.input, usable ? Quality::kGood : Quality::kBad, now_ns);
  }
  first_ = false;
  end_snapshot(k, now_ns);
}

namespace {

Result<std::unique_ptr<io::Driver>> create(const io::DriverSetup& setup) {
  std::vector<PlantWiring> wiring;
  for (const PlantConfig& pc : settings_of(*setup.config).plants) {
    auto plant = io::make_plant(pc.model);
    if (!plant) return make_error("plant " + pc.model + ": " + plant.error());
    PlantWiring w;
    w.plant = std::move(plant).value();
    wiring.push_back(std::move(w));
  }
  return std::unique_ptr<io::Driver>(std::make_unique<SimDriver>(setup, std::move(wiring)));
}

}  // namespace

const io::DriverKind kDriverKind{&kConfigKind, &create, nullptr};

}  // namespace rtplc::sim
