// One periodic task: a SCHED_FIFO thread that runs a compiled program once per
// period over the process image (spec runtime.md, "Tasks and the scheduler",
// "Hot swap"). The cycle:
//   sleep until the absolute release time (the only system call)
//   take a pending replacement program if one was published (swap boundary)
//   copy the inputs it reads from their source regions
//   run the program with its outputs written straight into its output region
//   publish the outputs (forced ones take their forced value in the image's
//   end_write(), see io/process_image.h "Forcing"); record wake latency and
//   execution time
//   every `snapshot_every` cycles: copy the retained block state for the
//   control thread (state_snapshot.h; a bounded copy, no system call)
//   next release += period; a cycle that ends after the next release is an
//   overrun: count it and the releases it skipped; N in a row stop the task
//   (the watchdog) with its outputs at their safe values.
//   while a trace is selected (rtplc trace): append the traced values to the
//   task's trace ring (io/trace_ring.h)
// Nothing in the cycle allocates, locks, logs or throws.
//
// Swap protocol (control thread <-> task thread, one swap in flight at a time):
//   control: builds a LoadedProgram, pending_.store(p, release)
//   task:    at a cycle boundary p = pending_.load(acquire); migrates state
//            from the running program into p; retired_.store(old, release);
//            pending_.store(nullptr, release); runs p in this same cycle
//   control: sees pending_ == nullptr (acquire), takes retired_ and frees it
// The acquire/release pairs hand each program over whole: the task never sees a
// half-built program, the control thread never frees one the task still runs.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/result.h"
#include "config/config.h"
#include "io/link/handoff.h"
#include "io/process_image.h"
#include "kernel_rt/rt_thread.h"
#include "sched/jitter.h"
#include "sched/program.h"

namespace rtplc::sched {


using config::OverrunPolicy;

struct TaskParams {
  std::string name;
  int64_t period_ns = 100000000;
  int priority = 0;  // SCHED_FIFO priority; 0 = SCHED_OTHER
  int cpu = -1;      // -1 = any
  OverrunPolicy overrun = OverrunPolicy::kSkip;
  uint32_t watchdog = 0;  // consecutive overruns before stopping; 0 = never
  uint64_t loop_budget = kDefaultLoopBudget;  // backward branches per cycle before the task stops
  bool count_faults = false;  // measure minor faults per cycle (test mode: one syscall per cycle)
  // Benchmarks only: run cycles back to back instead of sleeping to each
  // release, so the runtime's own cost per cycle can be measured with warm caches.
  bool back_to_back = false;
  // Every this many cycles the task copies its retained block state into its
  // program's StateSnapshot (state_snapshot.h); 0 never.
  uint32_t snapshot_every = 0;
  // While watched, every this many cycles the task copies every block's output
  // and status into its program's watch snapshot (about 10 per second).
  uint32_t watch_every = 1;
};

class Task {
 public:
  Task(TaskParams params, io::ProcessImage& image, uint32_t index, uint32_t output_region,
       uint32_t setpoint_region, std::unique_ptr<LoadedProgram> first);
  ~Task();
  Task(const Task&) = delete;
  Task& operator=(const Task&) = delete;

  // Starts the thread; the first release is at `first_release_ns` (CLOCK_MONOTONIC).
  Result<void> start(int64_t first_release_ns);
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }
  void join();
  bool fell_back_to_other() const { return fell_back_; }
  const std::string& fallback_reason() const { return fallback_reason_; }

  // ---- control-thread API ----
  const TaskParams& params() const { return params_; }
  uint32_t index() const { return index_; }
  uint32_t output_region() const { return region_; }
  // The program running now, as far as the control thread knows (it changes only
  // through publish()/collect()). Never touch its arena from the control thread.
  const LoadedProgram& active() const { return *active_; }
  // The program the thread ran last. Only once the thread has been joined (or
  // before it starts): the join hands its arena over to the caller.
  LoadedProgram& last_run() { return *current_; }
  // Hands a prepared program to the task thread. Returns false if a swap is still in flight.
  bool publish(std::unique_ptr<LoadedProgram> next);
  // A program published and not yet collected (control thread).
  bool swap_in_flight() const { return in_flight_ != nullptr; }
  // True once the task thread has taken the last published program.
  bool swap_applied() const { return pending_.load(std::memory_order_acquire) == nullptr; }
  // After swap_applied(): takes back the program that was replaced (to free it off the RT path).
  std::unique_ptr<LoadedProgram> collect();
  // The next block-error report of the task thread, if any (control thread).
  bool pop_block_error(BlockErrorReport& out) { return block_errors_.pop(out); }
  bool running() const { return thread_.joinable(); }
  // Someone watches this task's block outputs until `until_ns` (monotonic): a
  // lease the reader renews. A hint only (relaxed): the values themselves are
  // published by the watch snapshot's protocol (state_snapshot.h).
  void watch_until(int64_t until_ns) { watch_until_ns_.store(until_ns, std::memory_order_relaxed); }
  // How deep the task thread's stack went (bytes; known once it stopped) and its size.
  size_t stack_high_water() const { return thread_.stack_high_water(); }
  size_t stack_bytes() const { return thread_.stack_bytes(); }
  int64_t first_release_ns() const { return first_release_; }

 private:
  void run() noexcept;
  void read_inputs(LoadedProgram& p, int64_t now_ns) noexcept;
  void write_outputs(LoadedProgram& p, bool safe) noexcept;
  // Where each traced value is found for program `p` (at a selection pick-up
  // and at a swap, both cycle boundaries), and one record of them.
  void resolve_trace(const LoadedProgram& p) noexcept;
  void record_trace(uint64_t cycle, int64_t release_ns) noexcept;
  // Queues one block whose error count grew since it was last reported; bounded
  // work (one pass over the program's counters), no allocation.
  void report_block_errors(LoadedProgram& p, int64_t now_ns) noexcept;
  // Queues the report of the runaway loop that ended this cycle (arena.loop_fault).
  void report_runaway_loop(LoadedProgram& p, int64_t now_ns) noexcept;

  TaskParams params_;
  io::ProcessImage& image_;
  uint32_t index_;
  uint32_t region_;
  uint32_t setpoint_region_;
  io::TaskInfo* info_;
  CycleStats* stats_;

  // Owned by the task thread while it runs (current_), by the control thread
  // otherwise; active_ is the control thread's view of it.
  LoadedProgram* current_ = nullptr;
  LoadedProgram* active_ = nullptr;
  std::unique_ptr<LoadedProgram> owned_;  // keeps current_ alive
  std::atomic<LoadedProgram*> pending_{nullptr};
  std::atomic<LoadedProgram*> retired_{nullptr};
  LoadedProgram* in_flight_ = nullptr;  // control side: published, not yet collected

  std::atomic<bool> stop_{false};
  std::atomic<int64_t> watch_until_ns_{0};
  // Task thread -> control thread: one producer, one consumer; a full queue
  // drops the report (the count in the image still says how many).
  link::BoundedQueue<BlockErrorReport> block_errors_{16};
  int64_t next_error_report_ns_ = 0;  // task thread: no report before this (see LoadedProgram)
  // Task thread: the trace selection and, per traced value, the output index
  // in this task's region (>= 0) or the input buffer entry it is read into.
  io::TraceWriter trace_;
  int32_t trace_output_[io::kTraceChannels] = {};
  const double* trace_input_[io::kTraceChannels] = {};
  kernel_rt::RtThread thread_;
  int64_t first_release_ = 0;
  bool fell_back_ = false;
  std::string fallback_reason_;
};

}  // namespace rtplc::sched
