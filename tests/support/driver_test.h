// What the tests of one driver kind share: its config parsed from a snippet
// with the first error's text, and a process image laid out as the runtime
// lays it out for one task and that one driver, with the driver's setup on it.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <initializer_list>
#include <string>
#include <utility>

#include "common/quality.h"
#include "config/config.h"
#include "io/drivers/driver.h"
#include "io/process_image.h"

namespace rtplc::test {

// A config of one task `t` and one driver of `kind` named `name`, whose
// further keys are `driver` (indented as a driver's keys: "    interface: x\n").
inline config::LoadResult parse_driver(const std::string& kind, const std::string& name, const std::string& driver) {
  return config::parse_config("tasks:\n  - {name: t, program: p.fbd}\ndrivers:\n  - kind: " + kind +
                                  "\n    name: " + name + "\n" + driver,
                              "c.yaml", "", config::LoadOptions{false});
}

// The first error's "line:col: message" (the render starts with the file).
inline std::string first_error(const config::LoadResult& r) {
  const std::string text = r.render();
  return text.substr(0, text.find('\n'));
}

// The image "test-TAG-<pid>": region 0 the task's `outputs` channels, region
// 1 the driver `driver`'s (its `provides` inputs, then one delivery entry per
// output), one link row. Expected to be created.
inline io::ProcessImage driver_image(const std::string& tag, const std::string& driver, uint32_t provides,
                                     uint32_t outputs) {
  io::ImageLayout l;
  l.name = "test-" + tag + "-" + std::to_string(getpid());
  l.channel_capacity = 8;
  l.regions.push_back({"task:t", io::RegionKind::kTask, 0, outputs});
  l.regions.push_back({"driver:" + driver, io::RegionKind::kDriver, 0, provides + outputs});
  l.n_tasks = 1;
  l.task_stats_bytes = 64;
  l.n_links = 1;
  auto img = io::ProcessImage::create(l);
  EXPECT_TRUE(img.ok()) << img.error();
  return std::move(img).value();
}

// The setup of driver `d` on a driver_image(): it provides `provides` inputs
// and consumes the task's outputs 0..outputs-1, in that order.
inline io::DriverSetup driver_setup(const config::DriverConfig& d, io::ProcessImage& image,
                                    io::LinkEventQueue& events, uint32_t provides, uint32_t outputs,
                                    int64_t period_ns) {
  io::DriverSetup setup;
  setup.config = &d;
  setup.image = &image;
  setup.region = 1;
  setup.n_provides = provides;
  for (uint32_t i = 0; i < outputs; ++i) setup.consumes.push_back({0, i});
  setup.period_ns = period_ns;
  setup.events = &events;
  return setup;
}

// One write of the task region of a driver_image(): its outputs 0, 1, ... set
// to `values`, all of quality `q`.
inline void put_task_outputs(io::ProcessImage& image, std::initializer_list<double> values,
                             Quality q = Quality::kGood) {
  const uint32_t k = image.begin_write(0);
  uint32_t i = 0;
  for (double v : values) image.put(0, k, i++, v, q, 1);
  image.end_write(0, k, 1, 0);
}

// Entry `idx` of the driver's region of a driver_image() (an input, or a
// delivery entry after the inputs): its value and quality.
inline std::pair<double, Quality> driver_entry(io::ProcessImage& image, uint32_t idx) {
  double v = 0;
  Quality q = Quality::kGood;
  EXPECT_TRUE(image.read_values(1, &idx, 1, &v, 8, nullptr, &q));
  return {v, q};
}

}  // namespace rtplc::test
