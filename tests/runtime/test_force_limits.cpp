// A force the plant could never see is refused before anything changes: a
// value outside the channel's engineering `range`, and an output value a driver
// that sends it cannot encode (an S7 INT holds -32768..32767); the message
// names the range and the item. A value inside both is forced as before.
#include <gtest/gtest.h>

#include <string>

#include "io/drivers/s7/fake_plc.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;

TEST(ForceLimits, a_force_outside_the_range_or_the_drivers_encoding_is_refused_and_changes_nothing) {
  s7::FakePlc plc;
  ASSERT_TRUE(plc.add_endpoint({"127.0.0.1", 0, {}}).ok());
  ASSERT_TRUE(plc.start().ok());
  RuntimeFixture fx;
  fx.write("e.fbd", "%%\nF1 = era(p1, d0, c0, \"Volt\")\newa(F1, p1, d0, c1, \"CurrentSP\")\nEND\n");
  auto rt = fx.start("tasks:\n  - name: e\n    program: e.fbd\n    period: 10ms\n"
                     "    ranges: {Volt: {min: 0, max: 400}, CurrentSP: {max: 500}}\n"
                     "drivers:\n  - kind: s7\n    plcs: [{name: panel01, address: 127.0.0.1, port: " +
                     std::to_string(plc.port(0)) + ", poll: 50ms}]\n"
                     "    read: [{channel: p1.d0.c0, plc: panel01, item: DB10.DBD0:REAL}]\n"
                     "    write: [{channel: p1.d0.c1, plc: panel01, item: DB10.DBW4:INT, scale: 0.01}]\n");
  ASSERT_NE(rt, nullptr);
  // The engineering range of an input.
  Result<std::string> r = rt->force("Volt", 450, 0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("450 is outside the range of \"Volt\": [0, 400]"), std::string::npos) << r.error();
  // Inside the range, but an INT with scale 0.01 carries -327.68..327.67 only.
  r = rt->force("CurrentSP", 400, 0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("driver s7 sends \"CurrentSP\""), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("DB10.DBW4:INT"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("-32768..32767"), std::string::npos) << r.error();
  // The range of an output, then a huge value (the 1e300).
  r = rt->force("CurrentSP", 1e300, 0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("outside the range of \"CurrentSP\""), std::string::npos) << r.error();
  EXPECT_TRUE(rt->forces().empty()) << "a refused force was recorded";
  // What fits both is forced.
  r = rt->force("CurrentSP", 12.5, 0);
  EXPECT_TRUE(r.ok()) << r.error();
  EXPECT_NE(r->find("every driver sends this value"), std::string::npos) << *r;
  rt->stop();
  plc.stop();
}

TEST(ForceLimits, a_range_must_name_an_input_or_output_of_its_task) {
  RuntimeFixture fx;
  fx.write("p.fbd", "%%\nF1 = dai(p0, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 5, \"SP\")\n"
                    "dao(F1, p0, d0, c0, \"Out\")\nEND\n");
  std::string errors;
  EXPECT_EQ(fx.load("tasks:\n  - {name: p, program: p.fbd, ranges: {Nope: {max: 1}}}\ndrivers:\n  - kind: sim\n",
                    &errors),
            nullptr);
  EXPECT_NE(errors.find("task p has no input or output labelled \"Nope\""), std::string::npos) << errors;
  EXPECT_EQ(fx.load("tasks:\n  - {name: p, program: p.fbd, ranges: {SP: {max: 1}}}\ndrivers:\n  - kind: sim\n",
                    &errors),
            nullptr);
  EXPECT_NE(errors.find("\"SP\" is a set-point: its range goes under `setpoints`"), std::string::npos) << errors;
}

}  // namespace
}  // namespace rtplc::sched
