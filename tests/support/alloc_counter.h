// Counting allocations made inside a cycle (kernel_rt/cycle_scope.h): a test
// binary that links alloc_counter.cpp gets a global operator new that counts
// every allocation on any thread while that thread is inside a CycleScope
// and an AllocationCounter is alive.
#pragma once

#include <cstdint>
#include <string>

namespace rtplc::testing {

class AllocationCounter {
 public:
  AllocationCounter();  // arms the count from zero
  ~AllocationCounter();
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;
  uint64_t in_cycles() const;
  std::string first_thread() const;  // the first offender's thread name
};

}  // namespace rtplc::testing
