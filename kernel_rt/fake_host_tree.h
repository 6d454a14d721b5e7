// A throw-away /proc + /sys tree on disk for tests of doctor and RT detection (spec:
// runtime.md, the doctor paragraph). Ships with the code it fakes so any area's tests can
// pretend to run on an RT box, a non-RT laptop or a badly tuned server.
//
// Start from one of the presets, change the files a test is about, point a HostFiles at
// root(). The directory is removed when the object dies.
#pragma once

#include <string>
#include <string_view>

#include "kernel_rt/host_files.h"

namespace rtplc::kernel_rt {

class FakeHostTree {
 public:
  // An empty tree in a new temporary directory.
  FakeHostTree();
  ~FakeHostTree();
  FakeHostTree(const FakeHostTree&) = delete;
  FakeHostTree& operator=(const FakeHostTree&) = delete;

  // A 4-CPU box on Debian's PREEMPT_RT kernel, tuned as docs/rt-tuning.md says: CPUs 2-3
  // isolated with nohz_full and rcu_nocbs, IRQs on 0-1, throttling off, performance governor,
  // tsc, SMT off, /dev/cpu_dma_latency present. Every doctor check is OK on it.
  static void make_tuned_rt_box(FakeHostTree& t);
  // The same hardware on Debian's stock (PREEMPT_DYNAMIC, voluntary by default) kernel and
  // default settings: throttling on, no isolation, schedutil governor, SMT active.
  static void make_stock_box(FakeHostTree& t);

  const std::string& root() const noexcept { return root_; }
  HostFiles files() const { return HostFiles(root_); }

  // Creates parent directories as needed; `text` is written as is (add the '\n' yourself).
  void write(std::string_view abs_path, std::string_view text);
  void remove(std::string_view abs_path);

 private:
  std::string root_;
};

}  // namespace rtplc::kernel_rt
