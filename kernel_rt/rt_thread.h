// Threads with an explicit real-time scheduling policy, priority, CPU and stack
// (spec: runtime.md, "Tasks and the scheduler": one SCHED_FIFO thread per task, created with
// PTHREAD_EXPLICIT_SCHED; without privileges run anyway with SCHED_OTHER and say so once).
//
// The scheduler and the driver threads start their threads here. A refused SCHED_FIFO is not
// an error: the thread still starts under SCHED_OTHER and the outcome says so, so a developer
// laptop runs the same code path as the RT box. Only a request that can never work (a CPU
// that does not exist, a priority outside 1..99) is an error.
#pragma once

#include <pthread.h>
#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "common/result.h"

namespace rtplc::kernel_rt {

enum class SchedPolicy : uint8_t { kOther, kFifo, kRoundRobin, kBatch, kIdle, kDeadline, kUnknown };

const char* policy_name(SchedPolicy p) noexcept;

// What the kernel actually gave a thread.
struct SchedState {
  SchedPolicy policy = SchedPolicy::kUnknown;
  int priority = 0;  // the RT priority (1..99) for FIFO/RR, 0 otherwise
};

// The stack a thread gets unless its spec asks for another size. Not glibc's
// default (8 MiB, from RLIMIT_STACK): under mlockall(MCL_FUTURE) every page of a
// new thread's stack is made resident and locked at once, so each thread would
// cost 8 MiB of RAM. Every thread of ours uses a few KiB to a few tens of KiB
// (RtThread::stack_high_water() measures it; tests hold each kind below half of
// its stack).
// Sanitizer builds get more: their instrumented frames are several times larger.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr size_t kDefaultStackBytes = 2u * 1024u * 1024u;
#else
inline constexpr size_t kDefaultStackBytes = 256u * 1024u;
#endif

struct ThreadSpec {
  std::string name;             // shown by ps/top/htop; the kernel keeps 15 characters
  int fifo_priority = 0;        // 1..99 asks for SCHED_FIFO; 0 means SCHED_OTHER
  std::optional<unsigned> cpu;  // pin to this CPU; unset = any CPU the process may use
  size_t stack_bytes = 0;       // 0 = kDefaultStackBytes
  size_t prefault_stack = 0;    // bytes of stack to touch before `body` runs
};

// How a start went: what was asked, what was obtained and, after a fallback, why.
struct SchedOutcome {
  SchedState requested;
  SchedState obtained;
  bool fell_back = false;                  // SCHED_FIFO was refused, running SCHED_OTHER
  bool first_fallback_in_process = false;  // true for exactly one fallback per process: log it
  std::string fallback_reason;             // why, and how to allow it; empty when !fell_back
  std::string stack_note;                  // set when the stack prefault could not be done
};

// A started thread. Joins in its destructor, so a thread never outlives its owner.
class RtThread {
 public:
  RtThread() = default;
  RtThread(RtThread&& other) noexcept;
  RtThread& operator=(RtThread&& other) noexcept;
  RtThread(const RtThread&) = delete;
  RtThread& operator=(const RtThread&) = delete;
  ~RtThread();

  bool joinable() const noexcept { return joinable_; }
  void join() noexcept;
  pthread_t native_handle() const noexcept { return handle_; }
  pid_t tid() const noexcept { return tid_; }
  const SchedOutcome& outcome() const noexcept { return outcome_; }
  // Queries the kernel now (the policy can change after start, e.g. by chrt). Only while
  // the thread runs; after its body returned the answer is {kUnknown, 0}.
  SchedState sched_now() const noexcept;
  // The deepest the thread's stack ever went, in bytes, once its body has returned
  // (0 before that, or when unknown: a sanitizer build); and the stack's size.
  size_t stack_high_water() const noexcept;
  size_t stack_bytes() const noexcept { return stack_bytes_; }

 private:
  friend Result<RtThread> start_thread(const ThreadSpec& spec, std::function<void()> body);
  pthread_t handle_{};
  pid_t tid_ = 0;
  bool joinable_ = false;
  size_t stack_bytes_ = 0;
  // Written by the thread as its body returns, read after join (which orders it).
  std::shared_ptr<std::atomic<size_t>> stack_high_water_;
  SchedOutcome outcome_;
};

// Starts `body` on a new thread as `spec` asks. When SCHED_FIFO is refused (EPERM: no
// CAP_SYS_NICE and RLIMIT_RTPRIO below the priority) it starts the thread under SCHED_OTHER
// instead and reports that in the outcome. The outcome is complete when this returns: the
// new thread has applied its name and prefaulted its stack before `body` runs.
Result<RtThread> start_thread(const ThreadSpec& spec, std::function<void()> body);

// The scheduling state of the calling thread.
SchedState current_thread_sched() noexcept;

// Number of CPUs this process may run on (its affinity mask), and whether `cpu` is one of them.
unsigned allowed_cpu_count() noexcept;
bool cpu_allowed(unsigned cpu) noexcept;

// Clears the "fallback already reported" latch (tests only).
void reset_fallback_notice_for_tests() noexcept;

}  // namespace rtplc::kernel_rt
