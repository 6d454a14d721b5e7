// Online change that survives a restart: the program a swap put in is what the
// task runs after the runtime restarts — also after kill -9 — and the start says
// so; `runtime.programs: config` runs the config's file instead; rollback walks
// back through several versions.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "sched/control.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;


std::string program(double gain) {
  return "%%\nF1 = asp(d0, c0, 1, \"SP\")\nF2 = mult(F1, F1, " + std::to_string(gain) +
         ")\ndao(F2, p0, d0, c0, \"OUT\")\nEND\n";
}

std::string config_for(RuntimeFixture& fx, const std::string& name, const char* extra = "") {
  return fx.write(name + ".yaml", "runtime:\n  name: " + name + "\n  socket: " + fx.dir() + "/" + name +
                                      ".sock\n  retain_file: " + fx.dir() + "/" + name + ".retain\n" + extra +
                                      "tasks:\n  - {name: t, program: p.fbd, period: 5ms}\n");
}

std::unique_ptr<Runtime> load(const std::string& file, std::vector<std::string>* notices = nullptr) {
  config::LoadResult cfg = config::load_config(file);
  EXPECT_TRUE(cfg.ok()) << cfg.render();
  LoadReport report;
  auto rt = Runtime::load(*cfg.config, {}, report);
  EXPECT_NE(rt, nullptr) << report.render();
  if (!rt) return nullptr;
  auto started = rt->start();
  EXPECT_TRUE(started.ok());
  if (notices && started.ok()) *notices = *started;
  return rt;
}

TEST(BootProgram, a_swapped_program_is_what_runs_after_a_restart) {
  RuntimeFixture fx;
  fx.write("p.fbd", program(2));
  const std::string name = fx.unique_name();
  const std::string cfg = config_for(fx, name);
  {
    auto rt = load(cfg);
    ASSERT_NE(rt, nullptr);
    auto r = rt->swap("t", program(3), "three.fbd");
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_NE(r->find("kept for restarts as program " + ProgramStore::hash_of(program(3))), std::string::npos) << *r;
    rt->stop();
  }
  std::vector<std::string> notices;
  auto rt = load(cfg, &notices);
  ASSERT_NE(rt, nullptr);
  EXPECT_EQ(rt->task(0).active().source, program(3));
  bool said = false;
  for (const std::string& n : notices) said |= n.find("runs the program it ran last (swap three.fbd") != std::string::npos;
  EXPECT_TRUE(said) << "the start must say it did not run the config's file";
  EXPECT_NE(rt->status().find("swap three.fbd"), std::string::npos) << rt->status();
  rt->stop();
}

TEST(BootProgram, programs_config_runs_the_configs_file) {
  RuntimeFixture fx;
  fx.write("p.fbd", program(2));
  const std::string name = fx.unique_name();
  {
    auto rt = load(config_for(fx, name));
    ASSERT_NE(rt, nullptr);
    ASSERT_TRUE(rt->swap("t", program(3), "three.fbd").ok());
    rt->stop();
  }
  auto rt = load(config_for(fx, name, "  programs: config\n"));
  ASSERT_NE(rt, nullptr);
  EXPECT_EQ(rt->task(0).active().source, program(2));
  rt->stop();
}

TEST(BootProgram, rollback_walks_back_through_several_versions) {
  RuntimeFixture fx;
  fx.write("p.fbd", program(2));
  auto rt = load(config_for(fx, fx.unique_name()));
  ASSERT_NE(rt, nullptr);
  ASSERT_TRUE(rt->swap("t", program(3), "three.fbd").ok());
  ASSERT_TRUE(rt->swap("t", program(4), "four.fbd").ok());
  ASSERT_TRUE(rt->rollback("t").ok());
  EXPECT_EQ(rt->task(0).active().source, program(3));
  ASSERT_TRUE(rt->rollback("t").ok());
  EXPECT_EQ(rt->task(0).active().source, program(2));
  EXPECT_FALSE(rt->rollback("t").ok());  // nothing older
  rt->stop();
}

// The real binary, killed with SIGKILL right after the swap was acknowledged.
TEST(BootProgram, kill_9_right_after_a_swap_keeps_the_swap) {
  RuntimeFixture fx;
  fx.write("p.fbd", program(2));
  const std::string name = fx.unique_name();
  const std::string cfg = config_for(fx, name);
  const std::string sock = fx.dir() + "/" + name + ".sock";
  auto launch = [&] { return rtplc::testing::launch_rtplc_run(cfg, sock); };
  pid_t pid = launch();
  const std::string src = program(5);
  auto r = control_request(sock, "swap t five.fbd " + std::to_string(src.size()), src, 10000);
  ASSERT_TRUE(r.ok()) << r.error();
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  pid = launch();
  auto st = control_request(sock, "status");
  ASSERT_TRUE(st.ok()) << st.error();
  EXPECT_NE(st->find("swap five.fbd"), std::string::npos) << *st;
  EXPECT_NE(st->find(ProgramStore::hash_of(src)), std::string::npos) << *st;
  (void)control_request(sock, "stop");
  waitpid(pid, nullptr, 0);
}

}  // namespace
}  // namespace rtplc::sched
