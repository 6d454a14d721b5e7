// The `sim` I/O driver of the runtime (spec io-links.md, "The simulated plant"):
// a pinned thread at its own period that reads each plant's input from the task
// output that drives it (a dao channel), integrates the plant in real time with
// RK4, and publishes the plant's output as the driver's input channel (the dai a
// task reads). It is how the runtime runs with no hardware, and how the tests
// close real loops through the process image.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "common/result.h"
#include "io/plant.h"
#include "io/process_image.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::sched {

struct SimPlantWiring {
  std::unique_ptr<io::Plant> plant;
  uint32_t input_region = 0;  // where the dao value lives (a task's output region)
  uint32_t input_index = 0;
  uint32_t output_index = 0;  // position in this driver's region
};

class SimDriver {
 public:
  SimDriver(std::string name, io::ProcessImage& image, uint32_t region, int64_t period_ns,
            int priority, int cpu, std::vector<SimPlantWiring> plants);
  ~SimDriver();
  SimDriver(const SimDriver&) = delete;
  SimDriver& operator=(const SimDriver&) = delete;

  Result<void> start(int64_t first_release_ns);
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }
  void join();
  const std::string& name() const { return name_; }
  bool fell_back() const { return fell_back_; }
  uint64_t cycles() const { return cycles_.load(std::memory_order_relaxed); }

 private:
  void run() noexcept;
  void publish(int64_t now_ns) noexcept;

  std::string name_;
  io::ProcessImage& image_;
  uint32_t region_;
  int64_t period_ns_;
  int priority_;
  int cpu_;
  std::vector<SimPlantWiring> plants_;
  double step_s_ = 0.001;
  int steps_ = 10;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> cycles_{0};
  int64_t first_release_ = 0;
  kernel_rt::RtThread thread_;
  bool fell_back_ = false;
};

}  // namespace rtplc::sched
