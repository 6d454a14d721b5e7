// The sim driver's cycle over a real process image: the plant follows the task
// output that drives it, and holds its last input when that output cannot be
// read or is marked bad (an actuator keeps its position), saying so in the
// output's delivery entry.
#include <gtest/gtest.h>
#include <unistd.h>

#include <memory>

#include "io/drivers/driver.h"
#include "io/drivers/sim/config.h"
#include "io/drivers/sim/driver.h"

namespace rtplc::sim {
namespace {

struct Rig {
  io::ProcessImage image;
  config::DriverConfig dc;
  std::unique_ptr<io::Driver> driver;

  Rig() {
    io::ImageLayout l;
    l.name = "test-simdrv-" + std::to_string(getpid());
    l.channel_capacity = 8;
    l.regions.push_back({"task:a", io::RegionKind::kTask, 0, 4});
    l.regions.push_back({"driver:plant", io::RegionKind::kDriver, 0, 2});
    l.n_tasks = 1;
    l.task_stats_bytes = 64;
    auto img = io::ProcessImage::create(l);
    EXPECT_TRUE(img.ok()) << img.error();
    image = std::move(img).value();
    dc.kind = "sim";
    dc.name = "plant";
    Settings s;
    PlantConfig pc;
    pc.model = "tf:1/1,1";  // first order, gain 1: output climbs towards the input
    s.plants.push_back(pc);
    dc.settings = s;
    io::DriverSetup setup;
    setup.config = &dc;
    setup.image = &image;
    setup.region = 1;
    setup.n_provides = 1;
    setup.consumes = {{0, 0}};
    setup.period_ns = 10000000;
    auto d = kDriverKind.create(setup);
    EXPECT_TRUE(d.ok()) << d.error();
    driver = std::move(d).value();
  }

  void task_writes(double v, Quality q) {
    const uint32_t k = image.begin_write(0);
    image.put(0, k, 0, v, q, 1);
    image.end_write(0, k, 1, 0);
  }
  SimDriver& sim() { return static_cast<SimDriver&>(*driver); }
  Quality delivery() {
    double v = 0;
    Quality q = Quality::kGood;
    const uint32_t idx = 1;
    EXPECT_TRUE(image.read_values(1, &idx, 1, &v, 3, nullptr, &q));
    return q;
  }
};

TEST(SimDriver, follows_the_task_output_that_drives_the_plant) {
  Rig r;
  r.task_writes(5, Quality::kGood);
  for (int i = 0; i < 50; ++i) r.driver->cycle_now(i);
  EXPECT_EQ(r.sim().held_input(0), 5.0);
  EXPECT_GT(r.sim().plant_output(0), 0.1);
  EXPECT_EQ(r.delivery(), Quality::kGood);
}

TEST(SimDriver, holds_its_last_input_when_the_output_cannot_be_read) {
  Rig r;
  r.task_writes(5, Quality::kGood);
  for (int i = 0; i < 20; ++i) r.driver->cycle_now(i);
  const double before = r.sim().plant_output(0);
  // The task's published snapshot is being rewritten (odd version) on every
  // try: no consistent read. The plant must go on with 5, not fall to 0.
  const uint64_t pub = r.image.ring(0).published.load();
  io::SlotHeader& s = r.image.slot(0, static_cast<uint32_t>(pub % io::kRingSlots));
  s.version.store(s.version.load() + 1);
  for (int i = 0; i < 20; ++i) r.driver->cycle_now(i);
  EXPECT_EQ(r.sim().held_input(0), 5.0);
  EXPECT_GT(r.sim().plant_output(0), before);  // still climbing towards 5
  EXPECT_EQ(r.delivery(), Quality::kBad);
}

TEST(SimDriver, does_not_apply_an_output_the_task_marks_bad) {
  Rig r;
  r.task_writes(5, Quality::kGood);
  for (int i = 0; i < 5; ++i) r.driver->cycle_now(i);
  r.task_writes(0, Quality::kBad);  // e.g. an output a swap dropped
  for (int i = 0; i < 5; ++i) r.driver->cycle_now(i);
  EXPECT_EQ(r.sim().held_input(0), 5.0);
  EXPECT_EQ(r.delivery(), Quality::kBad);
}

}  // namespace
}  // namespace rtplc::sim
