// The libgpiod chip implementation on this machine: without a GPIO character
// device it says why (and the tests that need one skip with that reason); in
// the VM, against gpio-sim, tests/rt_vm/gpio.sh runs the real thing.
#include <gtest/gtest.h>

#include "io/drivers/gpio/chip.h"

namespace rtplc::gpio {
namespace {

TEST(GpiodChip, a_missing_chip_is_refused_with_a_reason) {
  auto c = gpiod_chip_ops().open(nullptr, "gpiochip-none");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find("GPIO chip 'gpiochip-none'"), std::string::npos) << c.error();
}

TEST(GpiodChip, lists_the_first_chip_when_the_machine_has_one) {
  if (auto a = gpio_cdev_available(); !a) GTEST_SKIP() << a.error();
  auto c = gpiod_chip_ops().open(nullptr, "gpiochip0");
  if (!c) GTEST_SKIP() << c.error();  // e.g. no permission on /dev/gpiochip0
  const ChipInfo i = gpiod_chip_ops().chip_info(*c);
  EXPECT_EQ(i.name, "gpiochip0");
  EXPECT_GT(i.lines, 0u);
  gpiod_chip_ops().close(*c);
}

}  // namespace
}  // namespace rtplc::gpio
