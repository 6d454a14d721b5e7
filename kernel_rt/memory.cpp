// Memory locking, heap and stack prefault, per-thread fault counters
// (spec: runtime.md, "Tasks and the scheduler").
#include "kernel_rt/memory.h"

#include <malloc.h>
#include <pthread.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <alloca.h>
#include <fmt/format.h>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define RTPLC_SANITIZED_BUILD 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define RTPLC_SANITIZED_BUILD 1
#endif
#endif

namespace rtplc::kernel_rt {
namespace {

// Left untouched below the prefaulted region so the prefault itself, and the frames of
// whatever runs after it, can never reach the guard page.
constexpr size_t kStackSafetyMargin = 64u * 1024u;

size_t page_size() {
  const long p = sysconf(_SC_PAGESIZE);
  return p > 0 ? static_cast<size_t>(p) : 4096u;
}

std::string describe_limit(rlim_t v) {
  if (v == RLIM_INFINITY) return "unlimited";
  return fmt::format("{} KiB", v / 1024u);
}

std::string mlock_refusal(int err) {
  rlimit lim{};
  getrlimit(RLIMIT_MEMLOCK, &lim);
  const std::string fix =
      "run as root (or with CAP_IPC_LOCK), or raise the limit: `ulimit -l unlimited` in the "
      "shell, `LimitMEMLOCK=infinity` in the systemd unit, or `<user> - memlock unlimited` in "
      "/etc/security/limits.d/rtplc.conf";
  if (err == EPERM) {
    return fmt::format("memory not locked: mlockall refused (not permitted, RLIMIT_MEMLOCK {}); {}",
                       describe_limit(lim.rlim_cur), fix);
  }
  if (err == ENOMEM) {
    return fmt::format(
        "memory not locked: the process is larger than RLIMIT_MEMLOCK ({}) allows to lock; {}",
        describe_limit(lim.rlim_cur), fix);
  }
  return fmt::format("memory not locked: mlockall failed: {}", std::strerror(err));
}

// Never inlined, so the alloca'd block lives in a frame of its own below the caller's and
// is released when this returns; the pages stay resident (and locked under MCL_FUTURE).
[[gnu::noinline]] void touch_stack(size_t bytes, size_t page) {
  auto* block = static_cast<volatile unsigned char*>(alloca(bytes));
  for (size_t off = 0; off < bytes; off += page) block[off] = 0;
  if (bytes > 0) block[bytes - 1] = 0;
}

constexpr unsigned char kStackPaint = 0xA5;
// Kept unpainted below the current frame: the painting call's own frames live there.
constexpr size_t kPaintMargin = 8u * 1024u;

// The calling thread's stack as [low, high); false when unknown.
[[maybe_unused]] bool stack_bounds(uintptr_t& low, uintptr_t& high) noexcept {
  pthread_attr_t attr;
  if (pthread_getattr_np(pthread_self(), &attr) != 0) return false;
  void* base = nullptr;
  size_t size = 0;
  const int rc = pthread_attr_getstack(&attr, &base, &size);
  pthread_attr_destroy(&attr);
  if (rc != 0 || base == nullptr || size == 0) return false;
  low = reinterpret_cast<uintptr_t>(base);
  high = low + size;
  return true;
}

// One page above the lowest address is left alone: with glibc's guard page below the
// stack, that keeps even an off-by-one far from it.
[[gnu::noinline, maybe_unused]] void paint_below(uintptr_t low, uintptr_t top) noexcept {
  const uintptr_t from = low + page_size();
  if (top <= from + kPaintMargin) return;
  std::memset(reinterpret_cast<void*>(from), kStackPaint, top - kPaintMargin - from);
}

}  // namespace

void paint_stack_of_this_thread() noexcept {
#ifndef RTPLC_SANITIZED_BUILD
  uintptr_t low = 0, high = 0;
  if (!stack_bounds(low, high)) return;
  unsigned char marker = 0;
  paint_below(low, reinterpret_cast<uintptr_t>(&marker));
#endif
}

size_t stack_high_water_of_this_thread() noexcept {
#ifdef RTPLC_SANITIZED_BUILD
  return 0;
#else
  uintptr_t low = 0, high = 0;
  if (!stack_bounds(low, high)) return 0;
  const auto* p = reinterpret_cast<const unsigned char*>(low + page_size());
  const auto* end = reinterpret_cast<const unsigned char*>(high);
  // The first byte that lost the paint, from the bottom up, is the deepest one written.
  while (p < end && *p == kStackPaint) ++p;
  if (p == reinterpret_cast<const unsigned char*>(low + page_size())) return 0;  // never painted
  return static_cast<size_t>(end - p);
#endif
}

Result<void> lock_memory(const MemoryLockOptions& options) {
  // Why each knob:
  //  - M_TRIM_THRESHOLD -1: free() never gives heap pages back with brk/madvise, so pages
  //    prefaulted now stay resident; otherwise a later malloc faults them in again.
  //  - M_MMAP_MAX 0: large blocks come from the (locked, prefaulted) heap, never from a
  //    fresh mmap whose pages would fault on first touch.
  //  - M_ARENA_MAX 1: glibc otherwise gives new threads their own mmap'd arenas, which the
  //    reserve below would not cover.
  mallopt(M_TRIM_THRESHOLD, -1);
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_ARENA_MAX, 1);

  std::string failure;
  if (!memory_locking_supported()) {
    failure = "memory not locked: this is a sanitizer build, whose shadow memory cannot be locked";
  } else if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    failure = mlock_refusal(errno);
  }

  if (options.heap_reserve_bytes > 0) {
    const size_t page = page_size();
    auto* reserve = static_cast<volatile unsigned char*>(std::malloc(options.heap_reserve_bytes));
    if (reserve == nullptr) {
      if (failure.empty()) {
        failure =
            fmt::format("heap reserve of {} MiB could not be allocated (locked-memory limit?)",
                        options.heap_reserve_bytes >> 20);
      }
    } else {
      for (size_t off = 0; off < options.heap_reserve_bytes; off += page) reserve[off] = 1;
      // Thanks to the trim threshold this goes back to malloc's free lists, not the kernel.
      std::free(const_cast<unsigned char*>(reserve));
    }
  }

  if (options.stack_prefault_bytes > 0) {
    Result<void> st = prefault_stack(options.stack_prefault_bytes);
    if (!st && failure.empty()) failure = st.error();
  }

  if (!failure.empty()) return make_error(std::move(failure));
  return {};
}

bool memory_locking_supported() noexcept {
#ifdef RTPLC_SANITIZED_BUILD
  return false;
#else
  return true;
#endif
}

void unlock_memory() noexcept {
  munlockall();
}

size_t stack_room_of_this_thread() noexcept {
  pthread_attr_t attr;
  if (pthread_getattr_np(pthread_self(), &attr) != 0) return 0;
  void* base = nullptr;  // lowest address of the stack
  size_t size = 0;
  const int rc = pthread_attr_getstack(&attr, &base, &size);
  pthread_attr_destroy(&attr);
  if (rc != 0 || base == nullptr) return 0;
  unsigned char marker = 0;
  const auto here = reinterpret_cast<uintptr_t>(&marker);
  const auto low = reinterpret_cast<uintptr_t>(base);
  return here > low ? static_cast<size_t>(here - low) : 0;
}

Result<void> prefault_stack(size_t bytes) {
  if (bytes == 0) return {};
  const size_t room = stack_room_of_this_thread();
  if (room == 0) return make_error("stack not prefaulted: its bounds are unknown");
  if (bytes + kStackSafetyMargin > room) {
    return make_error(fmt::format(
        "stack not prefaulted: {} KiB requested but only {} KiB are left below this frame "
        "(keeping {} KiB spare); give the thread a larger stack",
        bytes / 1024u, room / 1024u, kStackSafetyMargin / 1024u));
  }
  touch_stack(bytes, page_size());
  return {};
}

uint64_t minor_faults_this_thread() noexcept {
  rusage ru{};
  if (getrusage(RUSAGE_THREAD, &ru) != 0) return 0;
  return static_cast<uint64_t>(ru.ru_minflt);
}

uint64_t major_faults_this_thread() noexcept {
  rusage ru{};
  if (getrusage(RUSAGE_THREAD, &ru) != 0) return 0;
  return static_cast<uint64_t>(ru.ru_majflt);
}

size_t locked_bytes_of_this_process() noexcept {
  std::FILE* f = std::fopen("/proc/self/status", "re");
  if (f == nullptr) return 0;
  char line[256];
  size_t kib = 0;
  while (std::fgets(line, sizeof line, f) != nullptr) {
    if (std::strncmp(line, "VmLck:", 6) == 0) {
      kib = static_cast<size_t>(std::strtoull(line + 6, nullptr, 10));
      break;
    }
  }
  std::fclose(f);
  return kib * 1024u;
}

}  // namespace rtplc::kernel_rt
