// The allocation counter (see alloc_counter.h): replaces the global operator
// new and delete of the test binary that links it.
#include "tests/support/alloc_counter.h"

#include <pthread.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "kernel_rt/cycle_scope.h"

namespace {

std::atomic<bool> g_armed{false};
std::atomic<uint64_t> g_in_cycle{0};
char g_first_thread[16] = {};  // the first offender's thread name

void note_allocation() noexcept {
  if (!g_armed.load(std::memory_order_relaxed) || !rtplc::kernel_rt::in_cycle()) return;
  if (g_in_cycle.fetch_add(1, std::memory_order_relaxed) == 0) {
    pthread_getname_np(pthread_self(), g_first_thread, sizeof g_first_thread);
  }
}

void* counted(size_t n) {
  note_allocation();
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* counted_aligned(size_t n, std::align_val_t a) {
  note_allocation();
  const size_t al = static_cast<size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}

}  // namespace

void* operator new(size_t n) { return counted(n); }
void* operator new[](size_t n) { return counted(n); }
void* operator new(size_t n, const std::nothrow_t&) noexcept {
  note_allocation();
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new[](size_t n, const std::nothrow_t&) noexcept {
  note_allocation();
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new(size_t n, std::align_val_t a) { return counted_aligned(n, a); }
void* operator new[](size_t n, std::align_val_t a) { return counted_aligned(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }
void operator delete[](void* p, size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, size_t, std::align_val_t) noexcept { std::free(p); }


namespace rtplc::testing {

AllocationCounter::AllocationCounter() {
  g_in_cycle.store(0);
  g_first_thread[0] = '\0';
  g_armed.store(true);
}
AllocationCounter::~AllocationCounter() { g_armed.store(false); }
uint64_t AllocationCounter::in_cycles() const { return g_in_cycle.load(); }
std::string AllocationCounter::first_thread() const { return g_first_thread; }

}  // namespace rtplc::testing
