// The cyclic part of a real-time thread (a task's cycle, a driver bridge's
// cycle()) promises to allocate nothing once running: an allocation there can
// take a lock or fault pages, and so cost an unbounded time. CycleScope marks
// that part on the calling thread; in_cycle() says whether the thread is in
// one. The marker is one thread-local counter: nothing else reads or writes it,
// so no ordering is involved. Tests count the allocations made while
// in_cycle() is true (tests/runtime/test_no_alloc.cpp) across a run with every
// driver kind and its faults.
#pragma once

namespace rtplc::kernel_rt {

bool in_cycle() noexcept;

class CycleScope {
 public:
  CycleScope() noexcept;
  ~CycleScope();
  CycleScope(const CycleScope&) = delete;
  CycleScope& operator=(const CycleScope&) = delete;
};

}  // namespace rtplc::kernel_rt
