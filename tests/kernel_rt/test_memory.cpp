// Tests of memory locking, stack prefault and the per-thread fault counters (kernel_rt/memory.h).
#include "kernel_rt/memory.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <thread>

#include "kernel_rt/rt_thread.h"
#include "privilege_drop.h"

namespace rtplc::kernel_rt {
namespace {

size_t page() {
  return static_cast<size_t>(sysconf(_SC_PAGESIZE));
}

// Sanitizer runtimes fault on their own shadow memory and keep large per-thread state on
// thread stacks: fault counts and stack room are only exact in a plain build.
bool plain_build() {
  return memory_locking_supported();
}

TEST(Memory, minor_fault_counter_counts_first_touch_only) {
  const size_t pages = 64;
  auto* mem = static_cast<unsigned char*>(
      mmap(nullptr, pages * page(), PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0));
  ASSERT_NE(mem, MAP_FAILED);
  const uint64_t before = minor_faults_this_thread();
  for (size_t i = 0; i < pages; ++i) mem[i * page()] = 1;
  const uint64_t first = minor_faults_this_thread() - before;
  // At most one fault a page.
  EXPECT_GE(first, 1u);
  if (plain_build()) {
    EXPECT_LE(first, pages + 2);
  }

  const uint64_t again_before = minor_faults_this_thread();
  for (size_t i = 0; i < pages; ++i) mem[i * page()] = 2;
  EXPECT_EQ(minor_faults_this_thread() - again_before, 0u) << "resident pages must not fault again";
  munmap(mem, pages * page());
}

TEST(Memory, fault_counter_is_per_thread) {
  if (!plain_build()) GTEST_SKIP() << "a sanitizer's thread start faults in the creating thread";
  const uint64_t mine = minor_faults_this_thread();
  std::thread other([] {
    const size_t n = 32 * static_cast<size_t>(sysconf(_SC_PAGESIZE));
    auto* mem = static_cast<unsigned char*>(
        mmap(nullptr, n, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0));
    for (size_t i = 0; i < n; i += 4096) mem[i] = 1;
    munmap(mem, n);
  });
  other.join();
  // The other thread's faults are not ours; ours may grow by a handful from join bookkeeping.
  EXPECT_LT(minor_faults_this_thread() - mine, 16u);
}

TEST(Memory, lock_memory_locks_and_later_allocations_do_not_fault) {
  if (geteuid() != 0)
    GTEST_SKIP() << "needs root (CAP_IPC_LOCK) to lock without a large RLIMIT_MEMLOCK";
  if (!memory_locking_supported()) GTEST_SKIP() << "sanitizer build: memory is never locked";
  MemoryLockOptions opt;
  opt.heap_reserve_bytes = 16u << 20;
  opt.stack_prefault_bytes = 128u << 10;
  Result<void> r = lock_memory(opt);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_GT(locked_bytes_of_this_process(), opt.heap_reserve_bytes);

  // The point of it all: a "cycle" that allocates from the reserve and touches the memory
  // takes no page fault.
  std::free(std::malloc(1));  // warm-up, as a cycle after the first
  const uint64_t before = minor_faults_this_thread();
  void* block = std::malloc(4u << 20);
  ASSERT_NE(block, nullptr);
  std::memset(block, 0x5a, 4u << 20);
  std::free(block);
  EXPECT_EQ(minor_faults_this_thread() - before, 0u);

  unlock_memory();
  EXPECT_EQ(locked_bytes_of_this_process(), 0u);
}

TEST(Memory, lock_memory_says_which_limit_refused_it) {
  if (!testing::can_drop_privileges()) GTEST_SKIP() << "needs root to fork an unprivileged child";
  if (!memory_locking_supported()) GTEST_SKIP() << "sanitizer build: memory is never locked";
  testing::ChildLimits limits;
  limits.memlock = 64 * 1024;
  const auto child = testing::run_unprivileged(limits, [] {
    MemoryLockOptions opt;
    opt.heap_reserve_bytes = 1u << 20;
    opt.stack_prefault_bytes = 0;
    Result<void> r = lock_memory(opt);
    return r.ok() ? std::string("locked") : r.error();
  });
  ASSERT_TRUE(child.ran) << child.problem;
  EXPECT_NE(child.output, "locked");
  EXPECT_NE(child.output.find("RLIMIT_MEMLOCK (64 KiB)"), std::string::npos) << child.output;
  EXPECT_NE(child.output.find("LimitMEMLOCK=infinity"), std::string::npos) << child.output;
}

TEST(Memory, prefault_stack_touches_what_fits_and_refuses_what_does_not) {
  ThreadSpec spec;
  spec.name = "stack-test";
  spec.stack_bytes = 4u << 20;
  std::string small_error;
  std::string big_error;
  size_t room = 0;
  uint64_t faults_after_prefault = 1;
  auto t = start_thread(spec, [&] {
    room = stack_room_of_this_thread();
    Result<void> small = prefault_stack(256u << 10);
    if (!small) small_error = small.error();
    // A second walk over the same range finds every page resident.
    const uint64_t before = minor_faults_this_thread();
    (void)prefault_stack(256u << 10);
    faults_after_prefault = minor_faults_this_thread() - before;
    // glibc may hand out a cached stack larger than asked for, but never this large.
    Result<void> big = prefault_stack(64u << 20);
    big_error = big.ok() ? "" : big.error();
  });
  ASSERT_TRUE(t.ok()) << t.error();
  t->join();
  if (plain_build()) {
    EXPECT_GT(room, 3u << 20) << "glibc keeps only TLS and its thread descriptor up there";
    EXPECT_EQ(faults_after_prefault, 0u);
  }
  EXPECT_EQ(small_error, "");
  EXPECT_NE(big_error.find("larger stack"), std::string::npos) << big_error;
}

TEST(Memory, zero_bytes_prefault_is_a_no_op) {
  EXPECT_TRUE(prefault_stack(0).ok());
}

}  // namespace
}  // namespace rtplc::kernel_rt
