// Runtime test helpers (see runtime_fixture.h).
#include "tests/support/runtime_fixture.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <chrono>
#include <thread>

#include "kernel_rt/clock.h"
#include "kernel_rt/rt_thread.h"
#include "lang/compiler.h"
#include "sched/control.h"

#include <algorithm>

namespace rtplc::testing {

RuntimeFixture::RuntimeFixture() {
  std::string tmpl = ::testing::TempDir() + "rtplc-rt-XXXXXX";
  char* d = mkdtemp(tmpl.data());
  dir_ = d ? d : "/tmp";
}

RuntimeFixture::~RuntimeFixture() {
  std::error_code ec;
  std::filesystem::remove_all(dir_, ec);
}

std::string RuntimeFixture::write(const std::string& name, const std::string& text) const {
  const std::string path = dir_ + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string RuntimeFixture::unique_name() {
  return "t" + std::to_string(getpid()) + "-" + std::to_string(++counter_);
}

std::unique_ptr<sched::Runtime> RuntimeFixture::load(const std::string& yaml, std::string* errors,
                                                     sched::RuntimeOptions opt) {
  const std::string name = unique_name();
  std::string text = "runtime:\n  name: " + name + "\n  socket: " + dir_ + "/" + name +
                     ".sock\n  retain_file: " + dir_ + "/" + name + ".retain\n" + yaml;
  const std::string file = write(name + ".yaml", text);
  config::LoadResult cfg = config::load_config(file);
  if (!cfg.ok()) {
    if (errors) *errors = cfg.render();
    return nullptr;
  }
  sched::LoadReport report;
  auto rt = sched::Runtime::load(*cfg.config, opt, report);
  if (!rt && errors) *errors = report.render();
  return rt;
}

std::unique_ptr<sched::Runtime> RuntimeFixture::start(const std::string& yaml, sched::RuntimeOptions opt) {
  std::string errors;
  auto rt = load(yaml, &errors, opt);
  EXPECT_NE(rt, nullptr) << errors;
  if (!rt) return nullptr;
  auto started = rt->start();
  EXPECT_TRUE(started.ok()) << (started.ok() ? "" : started.error());
  return rt;
}

double block_value(const sched::LoadedProgram& p, const std::string& name) {
  const auto blocks = p.image.blocks();
  for (uint32_t i = 0; i < blocks.size(); ++i) {
    if (name == p.image.str(blocks[i].name)) return p.arena.values[p.image.code()[i].out];
  }
  ADD_FAILURE() << "no block " << name;
  return 0;
}

int64_t measure_exec_ns(const std::string& source) {
  auto r = lang::compile_source(source);
  EXPECT_TRUE(r.ok());
  if (!r.ok()) return 0;
  TaskArena arena(*r.image);
  std::vector<int64_t> t;
  auto measure = [&] {
    for (int i = 0; i < 21; ++i) {
      const int64_t a = kernel_rt::monotonic_now_ns();
      execute_cycle(*r.image, arena);
      t.push_back(kernel_rt::monotonic_now_ns() - a);
    }
  };
  // Measured as the tasks will run: on a SCHED_FIFO thread where allowed (a
  // SCHED_OTHER thread beside stress-ng --cpu 2 is preempted in every run of
  // a long cycle, as under ThreadSanitizer, and a task sized to overrun from
  // such a figure did not). And the fastest cycle, not the median: the one
  // nobody interrupted.
  kernel_rt::ThreadSpec spec;
  spec.name = "measure-exec";
  spec.fifo_priority = 30;
  auto th = kernel_rt::start_thread(spec, measure);
  if (th) {
    th->join();
  } else {
    measure();
  }
  return t.empty() ? 0 : *std::min_element(t.begin(), t.end());
}

double channel_value(sched::Runtime& rt, const std::string& label) {
  const int c = rt.image().find_channel(label);
  EXPECT_GE(c, 0) << label;
  return c < 0 ? 0 : rt.image().read_channel(static_cast<uint32_t>(c)).value;
}

bool can_use_fifo() {
  bool ok = false;
  auto t = kernel_rt::start_thread(kernel_rt::ThreadSpec{"fifo-probe", 10, {}, 0, 0}, [] {});
  if (t) ok = !t->outcome().fell_back;
  return ok;
}

pid_t launch_rtplc_run(const std::string& config, const std::string& socket,
                       const std::vector<std::string>& extra) {
  const std::string bin = std::string(RTPLC_BINARY_DIR) + "/rtplc";
  std::vector<std::string> args = {bin, "run", config, "-q", "--no-lock"};
  args.insert(args.end(), extra.begin(), extra.end());
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(bin.c_str(), argv.data());
    _exit(127);
  }
  for (int i = 0; i < 200; ++i) {
    if (sched::control_request(socket, "ping", "", 500).ok()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return pid;
}

}  // namespace rtplc::testing
