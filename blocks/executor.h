// The executor: runs one cycle of a task image over its arenas (spec
// fbd-language.md "The compiled form", issue: "no allocation, no exceptions, no
// locks"). Everything a cycle touches is allocated when the arena is built.
#pragma once

#include <cstdint>
#include <vector>

#include "blocks/image.h"
#include "blocks/native_abi.h"

namespace rtplc {

// Backward branches (Loop instructions) a task may take in one cycle before the
// cycle is cut short as a runaway loop (config key `loop_budget`). 100,000 is
// ~20x what a cycle sorting 64 values, a CRC over 256 bytes and a 1,000-step
// search take together, and a few milliseconds of work at most.
inline constexpr uint64_t kDefaultLoopBudget = 100'000;

// The mutable side of a task: block outputs (values), block memory (state), error
// counters, and the I/O buffers the runtime fills before and drains after a cycle.
// All zero-initialised: "a delayed reference reads 0 in the first cycle".
struct TaskArena {
  TaskArena() = default;
  explicit TaskArena(const TaskImage& image) { resize_for(image); }
  void resize_for(const TaskImage& image);
  void reset();  // back to the initial (all-zero) state

  std::vector<double> values;
  std::vector<double> state;
  std::vector<uint64_t> errors;  // per instruction, schedule order
  std::vector<double> io_in;     // inputs and set-points, indexed by Binding::io_index
  std::vector<double> io_out;    // outputs, indexed by Binding::io_index
  uint64_t total_errors = 0;
  uint64_t cycles = 0;
  uint64_t loop_budget = kDefaultLoopBudget;
  // 1 + the schedule index of the Loop instruction that exhausted the budget in
  // the last cycle, 0 when none did. The cycle stopped there: what it wrote is
  // partial, and the task must not publish it (sched/task.cpp puts the safe
  // outputs in its place).
  uint32_t loop_fault = 0;
};

// Raw pointers resolved once per (image, arena) pair so a cycle is one call.
struct ExecContext {
  const Instr* code = nullptr;
  const Run* runs = nullptr;
  uint32_t n_runs = 0;
  const double* params = nullptr;
  double* values = nullptr;
  uint32_t n_values = 0;  // strings' lengths are read within it
  double* state = nullptr;
  uint64_t* errors = nullptr;
  const double* io_in = nullptr;
  double* io_out = nullptr;
  uint64_t* total_errors = nullptr;
  uint64_t* cycles = nullptr;
  uint64_t loop_budget = kDefaultLoopBudget;
  uint32_t* loop_fault = nullptr;  // see TaskArena::loop_fault; written every cycle
  // Native code compiled from this very image (blocks/native.h), or null: the
  // interpreter runs the cycle. The object that loaded it must outlive the context.
  RtplcNativeCycle native = nullptr;
};

ExecContext make_context(const TaskImage& image, TaskArena& arena);

// Runs one cycle: the runs in schedule order, every run once unless a branch
// chooses another (Jmp, Jz, Jnz forward; Loop backward, counted against
// loop_budget). Never allocates, locks, throws or makes a system call. With
// ctx.native set the native code runs it, with the same results bit for bit.
void execute_cycle(const ExecContext& ctx) noexcept;

// Which interpreter body execute_cycle runs on this CPU: "avx2" or "baseline".
const char* executor_variant();

// Runs one cycle on a given body (benchmarks and the tests that check both
// bodies agree). kAvx2 falls back to the baseline where it was not built.
enum class ExecutorBody : uint8_t { kBaseline, kAvx2 };
void execute_cycle_on(ExecutorBody body, const ExecContext& ctx) noexcept;
bool executor_body_available(ExecutorBody body);

inline void execute_cycle(const TaskImage& image, TaskArena& arena) noexcept {
  execute_cycle(make_context(image, arena));
}

}  // namespace rtplc
