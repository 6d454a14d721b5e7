// The plans of a driver's links: each plan file loaded once however many links
// name it, its plan (or its error) shared between them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "fieldbus/link_plan.h"

namespace rtplc::fieldbus {
namespace {

struct PlanDir {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("rtplc-linkplan-" + std::to_string(getpid()));
  PlanDir() { std::filesystem::create_directories(path); }
  ~PlanDir() { std::filesystem::remove_all(path); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name) << text;
    return (path / name).string();
  }
};

const char* kRtuPlan =
    "link: {nodes: 4, bit_rate: 19200, layout: modbus-rtu}\n"
    "periodic: {bytes: 4}\n"
    "loops:\n"
    "  - {name: L1, period: 100ms}\n";

TEST(LinkPlanCache, loads_each_path_once_and_shares_its_plan) {
  PlanDir dir;
  const std::string a = dir.write("a.yaml", kRtuPlan);
  const std::string b = dir.write("b.yaml", kRtuPlan);
  std::map<std::string, int> loads;
  LinkPlanCache plans([&](const std::string& path) {
    ++loads[path];
    return load_link_plan(path);
  });
  const LinkPlanCache::Loaded& first = plans.get(a);
  ASSERT_TRUE(first) << first.error();
  const LinkPlanCache::Loaded& again = plans.get(a);
  ASSERT_TRUE(again);
  EXPECT_EQ(first->get(), again->get());
  EXPECT_EQ((*first)->file, a);
  EXPECT_EQ((*first)->plan.t1, 100'000'000);
  const LinkPlanCache::Loaded& other = plans.get(b);
  ASSERT_TRUE(other) << other.error();
  EXPECT_NE(first->get(), other->get());  // equal content, another file: its own plan
  EXPECT_EQ(loads[a], 1);
  EXPECT_EQ(loads[b], 1);
}

TEST(LinkPlanCache, loads_a_bad_plan_once_and_gives_its_error_to_every_caller) {
  PlanDir dir;
  const std::string bad = dir.write("bad.yaml", "link: {nodes: 4}\nperiodic: {packet: soon}\n");
  int loads = 0;
  LinkPlanCache plans([&](const std::string& path) {
    ++loads;
    return load_link_plan(path);
  });
  const LinkPlanCache::Loaded& first = plans.get(bad);
  ASSERT_FALSE(first);
  EXPECT_NE(first.error().find(bad + ":2:"), std::string::npos) << first.error();
  const LinkPlanCache::Loaded& again = plans.get(bad);
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error(), first.error());
  EXPECT_EQ(loads, 1);
}

TEST(LinkPlanCache, reports_a_missing_file_as_the_loader_does) {
  PlanDir dir;
  const std::string missing = (dir.path / "none.yaml").string();
  LinkPlanCache plans;
  const LinkPlanCache::Loaded& lp = plans.get(missing);
  ASSERT_FALSE(lp);
  auto direct = load_link_plan(missing);
  ASSERT_FALSE(direct);
  EXPECT_EQ(lp.error(), direct.error());
}

}  // namespace
}  // namespace rtplc::fieldbus
