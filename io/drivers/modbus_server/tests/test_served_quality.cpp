// What quality the server answers with (driver.h served_quality): the
// image's, made stale when the channel's writer stopped writing, never for
// set-points.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstring>

#include "io/drivers/modbus_server/driver.h"

namespace rtplc::modbus_server {
namespace {

constexpr int64_t kS = 1000000000;

io::ChannelDesc desc(const char* label, io::ChannelDir dir, uint16_t region) {
  io::ChannelDesc d{};
  std::strcpy(d.label, label);
  std::strcpy(d.key, label);
  d.dir = static_cast<uint8_t>(dir);
  d.region = region;
  return d;
}

class ServedQuality : public ::testing::Test {
 protected:
  void SetUp() override {
    io::ImageLayout l;
    l.name = "test-mbs-quality-" + std::to_string(getpid());
    l.channel_capacity = 8;
    l.regions.push_back({"task:a", io::RegionKind::kTask, 0, 1});
    l.regions.push_back({"driver:d", io::RegionKind::kDriver, 0, 1});
    l.regions.push_back({"setpoints", io::RegionKind::kSetpoints, 0, 1});
    l.regions.push_back({"unwritten", io::RegionKind::kDriver, 1, 1});
    l.n_tasks = 1;
    l.task_stats_bytes = 128;
    auto img = io::ProcessImage::create(l);
    ASSERT_TRUE(img.ok()) << img.error();
    img_ = std::move(*img);
    img_.task_info(0).period_ns = kS;
    for (uint32_t r = 0; r < 3; ++r) {
      const uint32_t k = img_.begin_write(r);
      img_.put(r, k, 0, 1.5, Quality::kGood, 0);
      img_.end_write(r, k, t0_, 1);
    }
  }
  Quality at(const io::ChannelDesc& d, int64_t after_ns) {
    io::ChannelValue v;
    v.value = 1.5;
    v.quality = Quality::kGood;
    v.fresh = true;
    return served_quality(img_, d, v, t0_ + after_ns, kS);
  }

  io::ProcessImage img_;
  const int64_t t0_ = 1000 * kS;
};

TEST_F(ServedQuality, an_input_whose_driver_stopped_writing_turns_stale) {
  const io::ChannelDesc in = desc("In", io::ChannelDir::kInput, 1);
  EXPECT_EQ(at(in, kS / 2), Quality::kGood);
  EXPECT_EQ(at(in, 2 * kS), Quality::kStale);
}

TEST_F(ServedQuality, a_slow_task_has_three_periods_before_its_outputs_turn_stale) {
  const io::ChannelDesc out = desc("Out", io::ChannelDir::kOutput, 0);
  EXPECT_EQ(at(out, 2 * kS), Quality::kGood);  // period 1 s: 3 s allowed
  EXPECT_EQ(at(out, 4 * kS), Quality::kStale);
}

TEST_F(ServedQuality, set_points_are_never_stale_and_unread_values_are_bad) {
  const io::ChannelDesc sp = desc("Sp", io::ChannelDir::kSetpoint, 2);
  EXPECT_EQ(at(sp, 3600 * kS), Quality::kGood);
  EXPECT_EQ(at(desc("Never", io::ChannelDir::kInput, 3), 0), Quality::kBad);
  io::ChannelValue torn;
  torn.quality = Quality::kGood;
  torn.fresh = false;
  EXPECT_EQ(served_quality(img_, sp, torn, t0_, kS), Quality::kBad);
}

}  // namespace
}  // namespace rtplc::modbus_server
