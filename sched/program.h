// A compiled program made ready to run in a task: its image, its arena, where its
// inputs come from in the process image, and — when it replaces a running
// program — the state migration to perform at the swap boundary (spec
// runtime.md, "Hot swap", steps 1 and 2). Everything here is built off the RT
// path; the task thread only walks the prepared lists.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "blocks/executor.h"
#include "blocks/image.h"

namespace rtplc::sched {

// The inputs one source region provides to a task: region value `src[i]` goes to
// the task's input buffer position `dst[i]`.
struct InputGroup {
  uint32_t region = 0;
  bool setpoints = false;   // changes rarely: copied only when its ring moved
  uint64_t seen = 0;        // ring publication last copied (task thread only)
  std::vector<uint32_t> src;
  std::vector<uint32_t> dst;
};

// What the swap keeps from the program it replaces, matched by (block name, opcode).
struct Migration {
  struct Copy {
    uint32_t from;
    uint32_t to;
    uint32_t len;
  };
  std::vector<Copy> values;  // value slots (a block's last output, and delayed references)
  std::vector<Copy> state;   // block state (integrators, filters, timers, counters, delays)
  std::vector<std::string> kept;   // block names whose state or output carried over
  std::vector<std::string> reset;  // stateful blocks that start from their initial state
  std::vector<std::string> added;  // blocks that did not exist before
  std::vector<std::string> removed;
  bool active = false;
};

struct LoadedProgram {
  TaskImage image;
  TaskArena arena;
  std::vector<InputGroup> inputs;
  // The task's output region index of each image output. When it is the
  // identity (always, unless a swap left holes) the executor writes the region
  // in place; otherwise outputs are copied through these indices.
  std::vector<uint32_t> output_slots;
  bool outputs_in_place = true;
  std::vector<double> safe_values;  // per image output: the value when the task is stopped
  Migration migration;
  std::string file;    // where the source came from
  std::string source;  // the source text (kept for rollback and for `status`)
};

// Builds the migration from `old_image` (running with `old_arena`) to `next`:
// a block keeps its output and state when a block of the same name and opcode
// (and the same state size) exists in both programs.
Migration plan_migration(const TaskImage& old_image, const TaskImage& next);

// Executes a migration on the task thread: bounded copies, no allocation.
void apply_migration(const Migration& m, const TaskArena& from, TaskArena& to) noexcept;

}  // namespace rtplc::sched
