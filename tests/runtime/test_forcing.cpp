// Forcing and set-point limits on a running runtime (docs/runtime.md,
// "Forcing"): a forced input is what the program computes with, a forced output
// is what the driver sends and the monitor shows (FORCED), unforce and
// unforce --all return to normal, status lists forces, the control socket logs
// each with the peer's uid and the time, and `set` refuses values outside a
// set-point's configured range (and non-finite ones) naming the range; the CLI
// exits non-zero on every refusal.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "sched/control.h"
#include "tests/support/run_tool.h"
#include "tests/support/runtime_fixture.h"
#include "tests/support/eventually.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;

// ProcVal from the sim plant, ManiVal to it, Error = Setpoint - ProcVal.
const char* kLoop =
    "%%\nF1 = dai(p0, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 50, \"Setpoint\")\n"
    "F3 = sub(F2, F1, 1)\nF4 = epi(F3, 4, 3)\n"
    "dao(F4, p0, d0, c0, \"ManiVal\")\ndao(F3, p0, d0, c1, \"Error\")\n"
    "D5 = dsp(d0, c1, 0, \"Enable\")\nddo(D5, p0, d1, c0, \"Lamp\")\nEND\n";

const char* kConfig =
    "tasks:\n  - name: pid\n    program: loop.fbd\n    period: 10ms\n"
    "    setpoints: {Setpoint: {min: 0, max: 100}}\n"
    "drivers:\n  - kind: sim\n";

io::ChannelValue read_label(Runtime& rt, const std::string& label) {
  const int c = rt.image().find_channel(label);
  EXPECT_GE(c, 0) << label;
  return rt.image().read_channel(static_cast<uint32_t>(c));
}

// What the driver last sent of an output: its delivery entry.
double sent_value(Runtime& rt, const std::string& label) {
  const int c = rt.image().find_channel(label);
  const io::ChannelDesc& d = rt.image().channel(static_cast<uint32_t>(c));
  EXPECT_TRUE(d.has_delivery) << label;
  double v = 0;
  const uint32_t idx = d.delivery_index;
  EXPECT_TRUE(rt.image().read_values(d.delivery_region, &idx, 1, &v, 100));
  return v;
}

using rtplc::testing::eventually;

class Forcing : public ::testing::Test {
 protected:
  void SetUp() override {
    fx_.write("loop.fbd", kLoop);
    rt_ = fx_.start(kConfig);
    ASSERT_NE(rt_, nullptr);
    ASSERT_TRUE(eventually([&] { return read_label(*rt_, "ProcVal").quality == Quality::kGood; }));
  }
  void TearDown() override {
    if (rt_) rt_->stop();
  }
  RuntimeFixture fx_;
  std::unique_ptr<Runtime> rt_;
};

TEST_F(Forcing, a_forced_input_is_what_the_program_computes_with) {
  auto r = rt_->force("ProcVal", 20, 1234);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NE(r->find("FORCED to 20"), std::string::npos) << *r;
  // Error = Setpoint (50) - ProcVal: exactly 30 once the task reads the forced value.
  EXPECT_TRUE(eventually([&] { return read_label(*rt_, "Error").value == 30.0; }))
      << read_label(*rt_, "Error").value;
  for (int i = 0; i < 20; ++i) {
    const io::ChannelValue pv = read_label(*rt_, "ProcVal");
    EXPECT_EQ(pv.value, 20.0);
    EXPECT_TRUE(pv.forced);
    EXPECT_EQ(pv.quality, Quality::kForced);
    EXPECT_EQ(read_label(*rt_, "Error").value, 30.0) << "a cycle computed with the plant's value";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  // Released: the plant's value again, good, not forced.
  ASSERT_TRUE(rt_->unforce("ProcVal").ok());
  EXPECT_TRUE(eventually([&] { return read_label(*rt_, "ProcVal").value != 20.0; }));
  const io::ChannelValue pv = read_label(*rt_, "ProcVal");
  EXPECT_FALSE(pv.forced);
  EXPECT_EQ(pv.quality, Quality::kGood);
  EXPECT_TRUE(eventually([&] { return read_label(*rt_, "Error").value != 30.0; }));
}

TEST_F(Forcing, a_forced_output_is_what_the_driver_sends_and_the_monitor_shows) {
  auto r = rt_->force("ManiVal", 7.25, 1234);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_TRUE(eventually([&] { return sent_value(*rt_, "ManiVal") == 7.25; })) << sent_value(*rt_, "ManiVal");
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(sent_value(*rt_, "ManiVal"), 7.25);
    const io::ChannelValue mv = read_label(*rt_, "ManiVal");
    EXPECT_EQ(mv.value, 7.25);
    EXPECT_TRUE(mv.forced);
    EXPECT_EQ(mv.quality, Quality::kForced);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  // The task still computes: its controller block holds its own value.
  EXPECT_NE(testing::block_value(rt_->task(0).active(), "F4"), 7.25);
  // The monitor, as an operator runs it, says FORCED.
  const test::ToolRun mon = test::run_tool("monitor --once --name " + rt_->name() + " --filter ManiVal");
  EXPECT_EQ(mon.status, 0) << mon.out;
  EXPECT_NE(mon.out.find("FORCED"), std::string::npos) << mon.out;
  const test::ToolRun stats = test::run_tool("stats --name " + rt_->name());
  EXPECT_NE(stats.out.find("FORCED: 1 channel: ManiVal (output) = 7.25"), std::string::npos) << stats.out;
  const test::ToolRun json = test::run_tool("stats --json --name " + rt_->name());
  const nlohmann::json sj = nlohmann::json::parse(json.out, nullptr, false);
  ASSERT_TRUE(sj.is_object() && sj["forced"].is_array() && sj["forced"].size() == 1) << json.out;
  EXPECT_EQ(sj["forced"][0], (nlohmann::json{{"label", "ManiVal"}, {"dir", "output"}, {"value", 7.25}})) << json.out;
  // The monitor's JSON says the same: value, quality forced, the policy.
  const test::ToolRun mj = test::run_tool("monitor --json --name " + rt_->name() + " --filter ManiVal");
  EXPECT_EQ(mj.status, 0) << mj.out;
  const nlohmann::json m = nlohmann::json::parse(mj.out, nullptr, false);
  ASSERT_TRUE(m.is_object() && m["channels"].is_array() && m["channels"].size() == 1) << mj.out;
  const nlohmann::json& c = m["channels"][0];
  EXPECT_EQ(c["label"], "ManiVal");
  EXPECT_EQ(c["dir"], "output");
  EXPECT_EQ(c["channel"], "out/DIO/p0.d0.c0");
  EXPECT_EQ(c["value"], 7.25);
  EXPECT_EQ(c["quality"], "forced");
  EXPECT_EQ(c["forced"], true);
  EXPECT_EQ(c["sent_by_a_driver"], true);
  EXPECT_EQ(c["on_bad"], "hold");
  ASSERT_TRUE(rt_->unforce("ManiVal").ok());
  EXPECT_TRUE(eventually([&] { return sent_value(*rt_, "ManiVal") != 7.25; }));
  EXPECT_FALSE(read_label(*rt_, "ManiVal").forced);
  EXPECT_EQ(read_label(*rt_, "ManiVal").quality, Quality::kGood);
}

TEST_F(Forcing, a_stopping_runtime_drives_safe_outputs_even_where_they_are_forced) {
  ASSERT_TRUE(rt_->force("ManiVal", 7.25, 0).ok());
  ASSERT_TRUE(eventually([&] { return sent_value(*rt_, "ManiVal") == 7.25; }));
  rt_->stop();
  // The task's last snapshot holds the safe value (0), shown not forced, and the
  // driver's last cycle sent it.
  const io::ChannelValue mv = read_label(*rt_, "ManiVal");
  EXPECT_EQ(mv.value, 0.0);
  EXPECT_FALSE(mv.forced);
  EXPECT_EQ(sent_value(*rt_, "ManiVal"), 0.0);
}

TEST_F(Forcing, status_lists_forces_and_unforce_all_releases_every_one) {
  ASSERT_TRUE(rt_->force("ProcVal", 20, 1234).ok());
  ASSERT_TRUE(rt_->force("Lamp", 1, 1234).ok());
  const std::string s = rt_->status();
  EXPECT_NE(s.find("FORCED: 2 channels"), std::string::npos) << s;
  EXPECT_NE(s.find("FORCED input ProcVal = 20 since "), std::string::npos) << s;
  EXPECT_NE(s.find("FORCED output Lamp = 1 since "), std::string::npos) << s;
  EXPECT_NE(s.find("by uid 1234"), std::string::npos) << s;
  EXPECT_EQ(rt_->forces().size(), 2u);
  auto all = rt_->unforce_all();
  ASSERT_TRUE(all.ok()) << all.error();
  EXPECT_NE(all->find("ProcVal released"), std::string::npos) << *all;
  EXPECT_NE(all->find("Lamp released"), std::string::npos) << *all;
  EXPECT_TRUE(rt_->forces().empty());
  EXPECT_NE(rt_->status().find("forced: none"), std::string::npos);
  for (uint32_t r = 0; r < rt_->image().region_count(); ++r) EXPECT_EQ(rt_->image().force_region(r).n_forced.load(), 0u);
  EXPECT_FALSE(rt_->unforce("ProcVal").ok()) << "nothing left to release";
}

TEST_F(Forcing, nonsense_forces_are_refused_and_change_nothing) {
  auto unknown = rt_->force("Nope", 1, 0);
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().find("no channel is labelled \"Nope\""), std::string::npos) << unknown.error();
  auto sp = rt_->force("Setpoint", 10, 0);
  ASSERT_FALSE(sp.ok());
  EXPECT_NE(sp.error().find("rtplc set Setpoint"), std::string::npos) << sp.error();
  auto nan = rt_->force("ProcVal", std::nan(""), 0);
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().find("finite"), std::string::npos) << nan.error();
  EXPECT_FALSE(rt_->force("ProcVal", HUGE_VAL, 0).ok());
  auto digital = rt_->force("Lamp", 2, 0);
  ASSERT_FALSE(digital.ok());
  EXPECT_NE(digital.error().find("digital output: 0 or 1"), std::string::npos) << digital.error();
  EXPECT_TRUE(rt_->forces().empty());
  for (uint32_t r = 0; r < rt_->image().region_count(); ++r) EXPECT_EQ(rt_->image().force_region(r).n_forced.load(), 0u);
}

TEST_F(Forcing, set_refuses_values_outside_the_range_and_non_finite_ones_naming_the_range) {
  for (double bad : {1e308, -0.5, 100.5, std::nan(""), HUGE_VAL}) {
    auto r = rt_->set_value("Setpoint", bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().find("[0, 100]"), std::string::npos) << r.error();
    EXPECT_NE(r.error().find("not changed"), std::string::npos) << r.error();
  }
  EXPECT_EQ(read_label(*rt_, "Setpoint").value, 50.0);
  EXPECT_TRUE(rt_->set_value("Setpoint", 100).ok()) << "the bounds are inside";
  EXPECT_TRUE(rt_->set_value("Setpoint", 0).ok());
  EXPECT_EQ(read_label(*rt_, "Setpoint").value, 0.0);
  // A digital set-point takes 0 or 1, whatever the config says.
  auto en = rt_->set_value("Enable", std::nan(""));
  ASSERT_FALSE(en.ok());
  EXPECT_NE(en.error().find("0 or 1"), std::string::npos) << en.error();
}

TEST_F(Forcing, the_control_socket_logs_each_force_with_the_peer_uid_and_the_time) {
  std::mutex m;
  std::vector<std::string> lines;
  ControlServer server(*rt_, [&](bool, const std::string& l) {
    std::lock_guard<std::mutex> g(m);
    lines.push_back(l);
  });
  ASSERT_TRUE(server.start(rt_->socket_path()).ok());
  auto f = control_request(rt_->socket_path(), "force ProcVal 12.5");
  ASSERT_TRUE(f.ok()) << f.error();
  EXPECT_FALSE(control_request(rt_->socket_path(), "force ProcVal nan").ok());
  EXPECT_FALSE(control_request(rt_->socket_path(), "force ProcVal twelve").ok());
  auto set = control_request(rt_->socket_path(), "set Setpoint nan");
  ASSERT_FALSE(set.ok());
  EXPECT_NE(set.error().find("[0, 100]"), std::string::npos) << set.error();
  auto st = control_request(rt_->socket_path(), "status");
  ASSERT_TRUE(st.ok());
  const std::string uid = "by uid " + std::to_string(geteuid());
  const std::string who = "by " + OperatorApi::name_of_uid(geteuid());
  EXPECT_NE(st->find("FORCED input ProcVal = 12.5 since 20"), std::string::npos) << *st;
  EXPECT_NE(st->find(uid), std::string::npos) << *st;
  ASSERT_TRUE(control_request(rt_->socket_path(), "unforce ProcVal").ok());
  ASSERT_TRUE(control_request(rt_->socket_path(), "unforce_all").ok());
  server.stop();
  std::lock_guard<std::mutex> g(m);
  auto has = [&](const std::string& a, const std::string& b) {
    for (const std::string& l : lines) {
      if (l.find(a) != std::string::npos && l.find(b) != std::string::npos && l.find(who + " at 20") != std::string::npos &&
          l.find("Z") != std::string::npos)
        return true;
    }
    return false;
  };
  EXPECT_TRUE(has("FORCE ProcVal = 12.5", "FORCED to 12.5"));
  EXPECT_TRUE(has("FORCE ProcVal = nan", "refused"));
  EXPECT_TRUE(has("UNFORCE ProcVal", "released"));
  EXPECT_TRUE(has("UNFORCE --all", "nothing is forced"));
  std::string all;
  for (const std::string& l : lines) all += l + "\n";
  SCOPED_TRACE(all);
}

TEST_F(Forcing, the_cli_exits_zero_on_success_and_non_zero_on_every_refusal) {
  ControlServer server(*rt_, [](bool, const std::string&) {});
  ASSERT_TRUE(server.start(rt_->socket_path()).ok());
  const std::string at = " --socket " + rt_->socket_path();
  test::ToolRun r = test::run_tool("force ProcVal 20" + at);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("ProcVal (input) FORCED to 20"), std::string::npos) << r.out;
  r = test::run_tool("status" + at);
  EXPECT_NE(r.out.find("FORCED input ProcVal = 20"), std::string::npos) << r.out;
  r = test::run_tool("force Nope 1" + at);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("no channel is labelled \"Nope\""), std::string::npos) << r.out;
  r = test::run_tool("force Lamp 0.5" + at);
  EXPECT_EQ(r.status, 1) << r.out;
  r = test::run_tool("force ProcVal abc" + at);
  EXPECT_EQ(r.status, 2) << r.out;  // a typo on the command line, refused before the runtime is asked
  r = test::run_tool("force ProcVal" + at);
  EXPECT_EQ(r.status, 2) << r.out;  // a usage error: the value is missing
  r = test::run_tool("unforce" + at);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--all"), std::string::npos) << r.out;
  r = test::run_tool("unforce ProcVal --all" + at);
  EXPECT_EQ(r.status, 2) << r.out;
  r = test::run_tool("set Setpoint 1e308" + at);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("[0, 100]"), std::string::npos) << r.out;
  r = test::run_tool("unforce --all" + at);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("ProcVal released"), std::string::npos) << r.out;
  r = test::run_tool("unforce ProcVal" + at);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("is not forced"), std::string::npos) << r.out;
  server.stop();
}

TEST(ForcingRestart, forces_are_not_kept_across_a_restart) {
  RuntimeFixture fx;
  fx.write("loop.fbd", kLoop);
  sched::RuntimeOptions opt;
  opt.retain_override = fx.dir() + "/restart.retain";  // what a restart keeps: the same retain file
  {
    auto rt = fx.start(kConfig, opt);
    ASSERT_NE(rt, nullptr);
    ASSERT_TRUE(rt->force("ProcVal", 20, 0).ok());
    ASSERT_TRUE(rt->set_value("Setpoint", 60).ok());
    rt->stop();
  }
  auto rt = fx.start(kConfig, opt);
  ASSERT_NE(rt, nullptr);
  EXPECT_TRUE(rt->forces().empty());
  EXPECT_NE(rt->status().find("forced: none"), std::string::npos);
  EXPECT_TRUE(eventually([&] { return read_label(*rt, "ProcVal").quality == Quality::kGood; }));
  EXPECT_FALSE(read_label(*rt, "ProcVal").forced);
  EXPECT_EQ(read_label(*rt, "Setpoint").value, 60.0) << "set-points are retained; forces are not";
  rt->stop();
}

// ---- set-point limits in the config ----

std::string load_errors(RuntimeFixture& fx, const std::string& limits) {
  fx.write("loop.fbd", kLoop);
  std::string errors;
  auto rt = fx.load("tasks:\n  - name: pid\n    program: loop.fbd\n    period: 10ms\n    setpoints: " + limits +
                        "\ndrivers:\n  - kind: sim\n",
                    &errors);
  EXPECT_EQ(rt, nullptr) << limits;
  return errors;
}

TEST(SetpointLimits, a_limit_that_names_an_output_is_an_error_at_its_label) {
  RuntimeFixture fx;
  const std::string out = load_errors(fx, "{ManiVal: {max: 1}}");
  // Line 9 of the file (the fixture puts a 4-line runtime section first), column of the label.
  EXPECT_NE(out.find(".yaml:9:17: error: \"ManiVal\" is not a set-point of task pid"), std::string::npos) << out;
}

// The seed loop plus a set-point NewSP it adds to the error.
const char* kLoopWithNewSp =
    "%%\nF1 = dai(p0, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 50, \"Setpoint\")\n"
    "F9 = asp(d0, c5, 3, \"NewSP\")\nF3 = sub(F2, F1, 1)\nF10 = add(F3, F9)\nF4 = epi(F10, 4, 3)\n"
    "dao(F4, p0, d0, c0, \"ManiVal\")\ndao(F3, p0, d0, c1, \"Error\")\n"
    "D5 = dsp(d0, c1, 0, \"Enable\")\nddo(D5, p0, d1, c0, \"Lamp\")\nEND\n";

TEST(SetpointLimits, limits_apply_to_a_set_point_a_swap_adds) {
  RuntimeFixture fx;
  fx.write("loop.fbd", kLoop);
  auto rt = fx.start("tasks:\n  - name: pid\n    program: loop.fbd\n    period: 10ms\n"
                     "    setpoints: {NewSP: {min: 0, max: 10}}\ndrivers:\n  - kind: sim\n");
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(rt->swap("pid", kLoopWithNewSp, "new.fbd").ok());
  auto r = rt->set_value("NewSP", 42);
  ASSERT_FALSE(r.ok()) << "a swap-added set-point skipped its limits";
  EXPECT_NE(r.error().find("NewSP"), std::string::npos) << r.error();
  EXPECT_TRUE(rt->set_value("NewSP", 5).ok());
  rt->stop();
}

TEST(SetpointLimits, a_swap_whose_new_set_point_starts_outside_its_limits_is_refused_and_adds_nothing) {
  RuntimeFixture fx;
  fx.write("loop.fbd", kLoop);
  auto rt = fx.start("tasks:\n  - name: pid\n    program: loop.fbd\n    period: 10ms\n"
                     "    setpoints: {NewSP: {min: 5, max: 10}}\ndrivers:\n  - kind: sim\n");
  ASSERT_NE(rt, nullptr);
  const uint32_t channels = rt->image().channel_count();
  auto r = rt->swap("pid", kLoopWithNewSp, "new.fbd");  // NewSP starts at 3
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("outside its `setpoints` limits"), std::string::npos) << r.error();
  EXPECT_EQ(rt->image().channel_count(), channels);
  EXPECT_LT(rt->image().find_channel("NewSP"), 0);
  EXPECT_FALSE(rt->set_value("NewSP", 7).ok()) << "a refused swap left its set-point behind";
  rt->stop();
}

TEST(SetpointLimits, bad_limits_are_errors_with_their_position) {
  RuntimeFixture fx;
  std::string e = load_errors(fx, "{Setpoint: {min: 10, max: 5}}");
  EXPECT_NE(e.find(".yaml:9:"), std::string::npos) << e;
  EXPECT_NE(e.find("max 5 is below min 10"), std::string::npos) << e;
  e = load_errors(fx, "{Setpoint: {low: 0}}");
  EXPECT_NE(e.find("takes 'min' and 'max'"), std::string::npos) << e;
  e = load_errors(fx, "{Setpoint: {min: .nan}}");
  EXPECT_NE(e.find(".yaml:9:"), std::string::npos) << e;
  e = load_errors(fx, "{Setpoint: 5}");
  EXPECT_NE(e.find("expects {min: number, max: number}"), std::string::npos) << e;
  // The program starts Setpoint at 50: limits that exclude it cannot be right.
  e = load_errors(fx, "{Setpoint: {min: 60, max: 100}}");
  EXPECT_NE(e.find("starts at 50 (its init value in the program), outside [60, 100]"), std::string::npos) << e;
}

TEST(SetpointLimits, a_retained_value_outside_the_limits_is_not_used) {
  RuntimeFixture fx;
  fx.write("loop.fbd", kLoop);
  const std::string cfg = std::string("tasks:\n  - name: pid\n    program: loop.fbd\n    period: 10ms\n") +
                          "drivers:\n  - kind: sim\n";
  sched::RuntimeOptions opt;
  opt.retain_override = fx.dir() + "/kept.retain";
  {
    auto rt = fx.start(cfg, opt);
    ASSERT_NE(rt, nullptr);
    ASSERT_TRUE(rt->set_value("Setpoint", 500).ok()) << "no limits yet";
    rt->stop();
  }
  std::string errors;
  auto rt = fx.load(std::string("tasks:\n  - name: pid\n    program: loop.fbd\n    period: 10ms\n") +
                        "    setpoints: {Setpoint: {max: 100}}\ndrivers:\n  - kind: sim\n",
                    &errors, opt);
  ASSERT_NE(rt, nullptr) << errors;
  EXPECT_EQ(read_label(*rt, "Setpoint").value, 50.0) << "the init value, not the retained 500";
  auto r = rt->set_value("Setpoint", 500);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("<= 100"), std::string::npos) << r.error();
}

}  // namespace
}  // namespace rtplc::sched
