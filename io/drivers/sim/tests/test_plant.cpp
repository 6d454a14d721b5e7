// Plant models against their analytic responses.
#include <gtest/gtest.h>

#include <cmath>

#include "io/drivers/sim/plant.h"

namespace rtplc::io {
namespace {

std::unique_ptr<Plant> plant(const char* spec) {
  auto p = make_plant(spec);
  EXPECT_TRUE(p.ok()) << p.error();
  return std::move(p).value();
}

TEST(Plant, seed_second_order_matches_its_analytic_step_response) {
  // 1/(s^2 + s + 1), wn = 1, zeta = 0.5: y(t) = 1 - e^(-t/2) (cos(wd t) + sin(wd t)/sqrt(3)),
  // wd = sqrt(3)/2.
  auto p = plant("second-order");
  EXPECT_EQ(p->describe(), "1/(s^2 + s + 1)");
  const double h = 0.01, wd = std::sqrt(3.0) / 2;
  for (int k = 1; k <= 1500; ++k) {
    p->step(1.0, h);
    const double t = k * h;
    const double y = 1 - std::exp(-t / 2) * (std::cos(wd * t) + std::sin(wd * t) / std::sqrt(3.0));
    ASSERT_NEAR(p->output(), y, 1e-9) << t;  // RK4 at h = 0.01: error ~ h^4
  }
}

TEST(Plant, transfer_function_spec_equals_the_named_plant) {
  auto a = plant("tf:1/1,1,1"), b = plant("second-order:K=1,wn=1,zeta=0.5");
  for (int k = 0; k < 500; ++k) {
    a->step(std::sin(k * 0.05), 0.01);
    b->step(std::sin(k * 0.05), 0.01);
    ASSERT_DOUBLE_EQ(a->output(), b->output());
  }
}

TEST(Plant, biproper_transfer_function_has_direct_feedthrough) {
  // (2s + 1)/(s + 1): y = 2u immediately, then relaxes to u.
  auto p = plant("tf:2,1/1,1");
  p->step(1.0, 1e-4);
  EXPECT_NEAR(p->output(), 2.0, 1e-3);
  for (int k = 0; k < 2000; ++k) p->step(1.0, 0.01);
  EXPECT_NEAR(p->output(), 1.0, 1e-6);
}

TEST(Plant, fopdt_waits_its_dead_time_then_rises_exponentially) {
  auto p = plant("fopdt:K=2,T=1,L=0.5");
  const double h = 0.01;
  for (int k = 1; k <= 300; ++k) {
    p->step(1.0, h);
    const double t = k * h;
    const double y = t <= 0.5 ? 0.0 : 2 * (1 - std::exp(-(t - 0.5)));
    ASSERT_NEAR(p->output(), y, 2e-2) << t;  // one step of dead-time quantisation
    if (t < 0.5 - 1e-9) {
      ASSERT_EQ(p->output(), 0.0) << t;
    }
  }
}

TEST(Plant, tank_integrates_and_stays_within_its_bounds) {
  auto p = plant("tank:A=2,q=1,max=10");
  for (int k = 0; k < 100; ++k) p->step(3.0, 0.01);  // (3 - 1)/2 = 1 per second
  EXPECT_NEAR(p->output(), 1.0, 1e-12);
  for (int k = 0; k < 5000; ++k) p->step(3.0, 0.01);
  EXPECT_EQ(p->output(), 10.0);
  for (int k = 0; k < 5000; ++k) p->step(0.0, 0.01);
  EXPECT_EQ(p->output(), 0.0);
}

TEST(Plant, bad_specs_are_refused_with_a_reason) {
  for (const char* bad : {"nope", "tf:1", "tf:1,2,3/1,1", "tf:1/0,1", "tf:x/1", "fopdt:T=0",
                          "second-order:wn=-1", "second-order:Q=1", "tank:A=0", "fopdt:K"}) {
    auto p = make_plant(bad);
    EXPECT_FALSE(p.ok()) << bad;
    EXPECT_FALSE(p.ok() ? true : p.error().empty()) << bad;
  }
}

TEST(Plant, integration_step_divides_the_period) {
  int n = 0;
  EXPECT_DOUBLE_EQ(plant_step_for(0.1, &n), 0.01);
  EXPECT_EQ(n, 10);
  EXPECT_DOUBLE_EQ(plant_step_for(0.05, &n), 0.005);  // stime/10
  EXPECT_EQ(n, 10);
  EXPECT_NEAR(plant_step_for(0.25, &n) * n, 0.25, 1e-15);
  EXPECT_EQ(n, 25);
}

}  // namespace
}  // namespace rtplc::io
