// Helpers for runtime tests: a temporary folder with programs and a config, a
// loaded-and-started Runtime under a unique name, and a few readings of it.
#pragma once

#include <sys/types.h>

#include <memory>
#include <string>
#include <vector>

#include "config/config.h"
#include "sched/runtime.h"

namespace rtplc::testing {

class RuntimeFixture {
 public:
  RuntimeFixture();
  ~RuntimeFixture();

  const std::string& dir() const { return dir_; }
  std::string write(const std::string& name, const std::string& text) const;
  // A unique runtime name for this test process.
  std::string unique_name();

  // Parses `yaml` (relative paths against dir()) and loads a runtime; on failure
  // returns null and sets `errors`.
  std::unique_ptr<sched::Runtime> load(const std::string& yaml, std::string* errors = nullptr,
                                       sched::RuntimeOptions opt = {});
  // load() + start(); fails the test on error.
  std::unique_ptr<sched::Runtime> start(const std::string& yaml, sched::RuntimeOptions opt = {});

 private:
  std::string dir_;
  int counter_ = 0;
};

// The current output of a block (by name, e.g. "F2") in a program's arena.
double block_value(const sched::LoadedProgram& p, const std::string& name);

// Fastest of 21 executions of one cycle of `source` on this machine, in ns
// (the one no other thread interrupted).
int64_t measure_exec_ns(const std::string& source);

// Reads a channel of a runtime by label.
double channel_value(sched::Runtime& rt, const std::string& label);

// True when this process may run SCHED_FIFO threads (root or CAP_SYS_NICE);
// timing assertions depend on it.
bool can_use_fifo();

// The real binary: starts `rtplc run CONFIG -q --no-lock [extra...]` in a child
// and returns its pid once its control socket `socket` answers a ping (or after
// 10 s, so a test that expects it up fails on its next request).
pid_t launch_rtplc_run(const std::string& config, const std::string& socket,
                       const std::vector<std::string>& extra = {});

}  // namespace rtplc::testing
