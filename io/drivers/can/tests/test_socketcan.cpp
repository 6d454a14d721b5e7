// The SocketCAN transport on this host: without PF_CAN (no can-raw module, a
// container) opening fails with a message that says so, and the tests that
// need a bus skip with that reason; with vcan, a frame sent on one port comes
// out of another through its filter. The full driver runs against can-utils
// in the VM (tests/rt_vm/can.sh).
#include <gtest/gtest.h>

#include "io/drivers/can/transport.h"

namespace rtplc::can {
namespace {

TEST(SocketCan, says_why_when_the_kernel_has_no_pf_can) {
  auto r = socketcan_available();
  if (r.ok()) GTEST_SKIP() << "this kernel has PF_CAN: nothing to refuse";
  EXPECT_NE(r.error().find("no SocketCAN raw sockets"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("modprobe"), std::string::npos) << r.error();
  const IdFilter f[] = {{0x181, false, kMaxExtendedId}};
  auto p = Port::open(socketcan_transport(), "vcan0", f, true);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().find("no SocketCAN raw sockets"), std::string::npos) << p.error();
}

TEST(SocketCan, names_a_missing_interface) {
  if (auto r = socketcan_available(); !r.ok()) GTEST_SKIP() << r.error();
  auto p = Port::open(socketcan_transport(), "nocan7", {}, false);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().find("CAN interface 'nocan7' does not exist"), std::string::npos) << p.error();
}

TEST(SocketCan, carries_a_frame_through_the_filter_on_vcan0) {
  if (auto r = socketcan_available(); !r.ok()) GTEST_SKIP() << r.error();
  const IdFilter only[] = {{0x181, false, kMaxExtendedId}};
  auto rx = Port::open(socketcan_transport(), "vcan0", only, false);
  if (!rx.ok()) GTEST_SKIP() << rx.error();
  auto tx = Port::open(socketcan_transport(), "vcan0", {}, false);
  ASSERT_TRUE(tx.ok()) << tx.error();
  Frame a;
  a.id = 0x180;
  a.len = 1;
  Frame b;
  b.id = 0x181;
  b.len = 2;
  b.data[1] = 0x42;
  ASSERT_EQ(tx->send(a), 0);
  ASSERT_EQ(tx->send(b), 0);
  Frame got;
  int err = 0;
  ASSERT_EQ(rx->recv(got, 2000000000, &err), RecvResult::kFrame);
  EXPECT_EQ(got.id, 0x181u);  // 0x180 was filtered out
  EXPECT_EQ(got.data[1], 0x42);
}

}  // namespace
}  // namespace rtplc::can
