// The status lane (spec runtime.md, "The process image"; issue: values you can
// trust end to end). Every value a task computes carries a status beside it,
// derived by one rule per opcode (op_status_rule below, the block's status
// column), so an output computed from a bad input is not good:
//
//   lane      meaning                               OPC UA            Foundation Fieldbus
//   good      computed from good (or forced) values Good              Good_NonCascade
//   uncertain from a stale input, or the held value of  Uncertain     Uncertain (LastUsableValue)
//             a block that could not compute this cycle
//   bad       from a bad input (peer gone, not a    Bad               Bad
//             finite number, nobody feeds it)
//
// Forced inputs count as good: the operator vouches for them (their own
// channel shows `forced`). Rules:
//   worst     the worst of the inputs it reads (every block but those below)
//   select    amux: the worst of `sel` and the branch `sel` chose, so a
//             program that switches to a good fallback on `not good(PV)`
//             yields good outputs while the fallback is good
//   source    constants, and `good(x)` itself (the quality is known even
//             when the value is not): always good
//   and / or  a good input that decides the result alone (a good 0 into
//             an and, a good 1 into an or) makes it good whatever the
//             others are, so `and(Ready, good(Speed))` is a good 0 when the
//             speed is lost and a drive sees Enable drop; else worst
// A block's state (an integrator, a filter) does not remember a bad past:
// its output is as good as the inputs of this cycle. A delayed reference
// reads last cycle's status, as it reads last cycle's value.
//
// Cost: the lane runs after the value pass only in cycles that need it: some
// input is not good, a block counted an error, or the last pass left a value
// that is not good. A task whose inputs are all good pays one test of a flag
// its reader sets (StatusLane::needs_pass). bench/executor measures both.
#pragma once

#include <cstdint>
#include <vector>

#include "blocks/executor.h"
#include "blocks/image.h"
#include "common/quality.h"

namespace rtplc {

enum class Lane : uint8_t { kGood = 0, kUncertain = 1, kBad = 2 };

inline Lane lane_of(Quality q) {
  switch (q) {
    case Quality::kGood:
    case Quality::kForced:
      return Lane::kGood;
    case Quality::kStale:
      return Lane::kUncertain;
    case Quality::kBad:
      break;
  }
  return Lane::kBad;
}
inline Quality quality_of(Lane s) {
  return s == Lane::kGood ? Quality::kGood : s == Lane::kUncertain ? Quality::kStale : Quality::kBad;
}

// Programs with control flow (Var, Set, branches; docs/st.md "Loops"): one
// pass in schedule order cannot know which branch ran or what a loop's last
// iteration read, so the pass treats every Set as possibly run: a variable's
// status is the worst of everything any Set may write into it (and good for
// its initial value), found by repeating the pass until no variable gets
// worse (each can only worsen twice, so at most 2 * variables + 1 passes), and
// select / and / or fall back to `worst`, the values in their slots being the
// last iteration's, not necessarily what decided the result.
// Pick is as good as its index and every element it may pick; Put makes every
// variable it may write as bad as its index and value.
enum class StatusRule : uint8_t { kWorst, kSelect, kSource, kLoad, kStore, kAnd, kOr, kVar, kSet, kBranch, kPick, kPut };
StatusRule op_status_rule(Op op);

// The statuses of one task's values, beside its TaskArena.
struct StatusLane {
  StatusLane() = default;
  explicit StatusLane(const TaskImage& image) { resize_for(image); }
  void resize_for(const TaskImage& image);

  // Whether this cycle needs a pass (false: every status is good and stays
  // so). O(1): whoever writes `in` sets `in_dirty` when it writes a status
  // that is not good (set_in, sched::read_group).
  bool needs_pass(uint64_t total_errors) const {
    return !settled || in_dirty || total_errors != errors_at_pass;
  }
  void set_in(uint32_t i, uint8_t s) {
    in[i] = s;
    in_dirty = in_dirty || s != 0;
  }

  std::vector<uint8_t> in;      // per input-buffer entry (Binding::io_index), set by the reader
  std::vector<uint8_t> values;  // per value slot
  std::vector<uint8_t> out;     // per output-buffer entry
  std::vector<uint64_t> errors_seen;  // per instruction: its error count at the last pass
  std::vector<uint8_t> rule;  // per instruction: its StatusRule, looked up once
  uint64_t errors_at_pass = 0;
  uint32_t n_vars = 0;    // Var instructions: the image has control flow when any Var, Set or branch
  bool has_flow = false;
  bool settled = false;   // the last pass found every value good
  bool in_dirty = true;   // an input status that is not good was written since the last pass
};

// One pass in schedule order over the values `arena` holds after a cycle.
// Returns true when any output is not good. No allocation, no system call.
bool propagate_status(const TaskImage& image, const TaskArena& arena, StatusLane& lane) noexcept;

}  // namespace rtplc
