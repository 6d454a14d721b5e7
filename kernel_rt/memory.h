// Memory that never page-faults once the RT tasks run (spec: runtime.md, "Tasks and the
// scheduler": mlockall, prefault stacks and arenas, mallopt so the heap never shrinks, count
// minor faults per cycle to prove it).
//
// Call order before RT starts: lock_memory() once in the main thread, then every RT thread
// prefaults its own stack (start_thread() does that for you with ThreadSpec::prefault_stack).
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/result.h"

namespace rtplc::kernel_rt {

struct MemoryLockOptions {
  // Bytes to allocate, touch and release back to malloc, so later load-time allocations
  // (and any stray one on the RT path) find resident, locked pages instead of faulting.
  // The runtime locks memory after loading its programs, so the reserve is only the
  // slack for what comes later on the non-RT side (a swap's program, a status reply);
  // the cycle allocates nothing. Beyond it the heap still grows locked and resident
  // (MCL_FUTURE), the faults taken by the non-RT thread that allocates (a swap's
  // compile, on the control thread), never by a task. 2 MiB covers a reply or a
  // small program without growing the heap.
  size_t heap_reserve_bytes = 2u * 1024u * 1024u;
  // Bytes of the calling thread's stack to touch now.
  size_t stack_prefault_bytes = 256u * 1024u;
};

// Tunes malloc so freed memory is never returned to the kernel nor served by fresh mmaps,
// locks every current and future page (mlockall MCL_CURRENT|MCL_FUTURE), then prefaults the
// heap reserve and the caller's stack. The malloc tuning and the prefault happen even when
// the lock is refused, so an unprivileged run still gets fewer faults; the error then says
// what limit stopped it and how to lift it.
Result<void> lock_memory(const MemoryLockOptions& options = {});

// False in AddressSanitizer/ThreadSanitizer builds: their shadow memory spans terabytes of
// reserved address space that mlockall would try to make resident. lock_memory() then only
// tunes malloc and prefaults, and says why it did not lock.
bool memory_locking_supported() noexcept;

// Undoes mlockall (for tests and for tools that lock only temporarily).
void unlock_memory() noexcept;

// Touches `bytes` of the calling thread's stack below the current frame so those pages are
// resident before the first cycle. Fails (touching nothing) when the request does not fit
// in the thread's stack with a safety margin left over.
Result<void> prefault_stack(size_t bytes);

// Bytes of stack the calling thread has below the current frame (0 if unknown).
size_t stack_room_of_this_thread() noexcept;

// Stack high-water mark, so every thread's stack can be sized to what it uses (under
// mlockall(MCL_FUTURE) a thread's whole stack is resident from its start). paint fills
// the calling thread's unused stack below the current frame with a pattern (it makes
// those pages resident); high_water, called later on the same thread, returns the bytes
// from the stack's top down to the deepest byte ever written. Both do nothing, and
// high_water returns 0 ("unknown"), in a sanitizer build, whose stack checks would
// trip over writes below the current frame, or when the stack bounds are unknown.
void paint_stack_of_this_thread() noexcept;
size_t stack_high_water_of_this_thread() noexcept;

// Minor page faults the calling thread has taken so far (getrusage RUSAGE_THREAD). Sampled
// before and after a cycle in test mode, the difference must be 0 after warm-up.
uint64_t minor_faults_this_thread() noexcept;
// Major faults (disk I/O) of the calling thread; any at all on an RT thread is a defect.
uint64_t major_faults_this_thread() noexcept;

// Bytes of this process locked in RAM (VmLck in /proc/self/status); 0 when nothing is locked.
size_t locked_bytes_of_this_process() noexcept;

}  // namespace rtplc::kernel_rt
