// The sim driver thread (see sim_driver.h).
#include "sched/sim_driver.h"

#include "kernel_rt/clock.h"
#include "sched/periodic.h"

namespace rtplc::sched {

SimDriver::SimDriver(std::string name, io::ProcessImage& image, uint32_t region, int64_t period_ns,
                     int priority, int cpu, std::vector<SimPlantWiring> plants)
    : name_(std::move(name)),
      image_(image),
      region_(region),
      period_ns_(period_ns),
      priority_(priority),
      cpu_(cpu),
      plants_(std::move(plants)) {
  step_s_ = io::plant_step_for(static_cast<double>(period_ns_) / 1e9, &steps_);
  for (SimPlantWiring& p : plants_) p.plant->reset();
}

SimDriver::~SimDriver() {
  request_stop();
  join();
}

Result<void> SimDriver::start(int64_t first_release_ns) {
  first_release_ = first_release_ns;
  publish(kernel_rt::monotonic_now_ns());  // plants at rest are readable before the first cycle
  auto t = start_driver_thread(name_, "sim", priority_, cpu_, [this] { run(); });
  if (!t) return make_error(t.error());
  thread_ = std::move(t).value();
  fell_back_ = thread_.outcome().fell_back;
  return {};
}

void SimDriver::join() {
  if (thread_.joinable()) thread_.join();
}

void SimDriver::publish(int64_t now_ns) noexcept {
  const uint32_t k = image_.begin_write(region_);
  for (const SimPlantWiring& p : plants_) {
    image_.put(region_, k, p.output_index, p.plant->output(), io::Quality::kGood, now_ns);
  }
  image_.end_write(region_, k, now_ns, cycles_.load(std::memory_order_relaxed));
}

void SimDriver::run() noexcept {
  int64_t release = first_release_;
  while (!stop_.load(std::memory_order_relaxed)) {
    kernel_rt::sleep_until_ns(release);
    for (SimPlantWiring& p : plants_) {
      double u = 0;
      const uint32_t zero = 0;
      // A task mid-write never blocks us: we read its last completed snapshot.
      if (!image_.read_values(p.input_region, &p.input_index, &zero, 1, &u, 8)) u = 0;
      for (int s = 0; s < steps_; ++s) p.plant->step(u, step_s_);
    }
    const int64_t now = kernel_rt::monotonic_now_ns();
    cycles_.fetch_add(1, std::memory_order_relaxed);
    publish(now);
    release = next_release(release, period_ns_, now);
  }
}

}  // namespace rtplc::sched
