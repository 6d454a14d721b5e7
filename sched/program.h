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
#include "blocks/native.h"
#include "blocks/status.h"
#include "io/process_image.h"
#include "sched/state_snapshot.h"

namespace rtplc::sched {

// The inputs one source region provides to a task: region value `src[i]` goes to
// the task's input buffer position `dst[i]`.
struct InputGroup {
  uint32_t region = 0;
  bool setpoints = false;   // changes rarely: copied only when its ring moved
  uint64_t seen = 0;        // ring publication last copied (task thread only)
  std::vector<uint32_t> src;
  std::vector<uint32_t> dst;
  // One consistent snapshot lands here first and is copied to the inputs only
  // when it validated, so a missed read leaves every input at its last good value.
  std::vector<double> scratch;  // src.size()
  // The qualities of the same snapshot (src.size()), and its channels' times.
  std::vector<Quality> quality_scratch;
  std::vector<int64_t> time_scratch;
  // Per src: the channel's maximum age (io::judge_quality; 0: never stale).
  std::vector<int64_t> max_age_ns;
  // `good` blocks: quality_dst[j] receives 1 or 0 for the channel src[quality_pos[j]].
  std::vector<uint32_t> quality_pos;
  std::vector<uint32_t> quality_dst;

  // Sizes the buffers read_group fills once src, dst and max_age_ns are known
  // (a channel left without an age is never stale by age).
  void size_buffers() {
    scratch.assign(src.size(), 0.0);
    quality_scratch.assign(src.size(), Quality::kBad);
    time_scratch.assign(src.size(), 0);
    max_age_ns.resize(src.size(), 0);
  }
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
  LoadedProgram();
  ~LoadedProgram();
  LoadedProgram(const LoadedProgram&) = delete;
  LoadedProgram& operator=(const LoadedProgram&) = delete;
  // Programs alive in this process (tests: a swap never leaks one).
  static uint64_t live_count();

  TaskImage image;
  TaskArena arena;
  // The image as native code (task key `native`), or null: the interpreter runs it.
  std::shared_ptr<const NativeCode> native;
  StatusLane lane;  // the statuses of the arena's values (blocks/status.h)
  std::vector<InputGroup> inputs;
  // The task's output region index of each image output. When it is the
  // identity (always, unless a swap left holes) the executor writes the region
  // in place; otherwise outputs are copied through these indices.
  std::vector<uint32_t> output_slots;
  bool outputs_in_place = true;
  std::vector<double> safe_values;  // per image output: the value when the task is stopped
  // Outputs an earlier program wrote and this one does not (a swap with
  // --drop-output): held at their safe value with bad quality, so no driver
  // sends them and no tool shows them good.
  struct Dropped {
    uint32_t index;  // in the task's output region
    double safe_value;
    std::string label;
  };
  std::vector<Dropped> dropped;
  // Quality of every index of the task's output region under this program:
  // good where it writes an output, bad elsewhere (holes, dropped outputs).
  std::vector<uint8_t> output_quality;
  // What the task writes as each output's quality: output_quality made worse
  // by the status lane's verdict on each output (task thread).
  std::vector<uint8_t> region_quality;
  Migration migration;
  // Channels this program adds (a swap): planned by Runtime::make_program, in
  // the image only once the swap can no longer be refused.
  struct NewChannel {
    io::ChannelDesc desc;
    std::string key;
    double setpoint_value = 0;  // set-points: what it starts at
  };
  std::vector<NewChannel> new_channels;
  // The retained blocks' state, copied by the task every few cycles for the
  // control thread to persist (state_snapshot.h).
  StateSnapshot snapshot;
  // Every block's output and status, copied by the task while someone watches
  // (Task::watch_until, Runtime::watch): the editor's live wires.
  StateSnapshot watch;
  std::string file;    // where the source came from
  std::string source;  // the source text (kept for rollback and for `status`)
  // Task thread only: per instruction, the error count already reported, their
  // sum, and where the next scan starts (so one erring block cannot hide the
  // others). Sized when the program is made: reporting allocates nothing.
  std::vector<uint64_t> errors_reported;
  uint64_t errors_reported_total = 0;
  uint32_t next_error_scan = 0;
  // Reports of this program come at most this far apart: 1 s, doubling with
  // each report up to a minute, so a block that errs every cycle is said at
  // once, then about once a minute, never thousands of times.
  int64_t error_report_gap_ns = 1000000000;
};

// A block that counted errors, as the task thread reports it (at most one a
// second per task) for the control thread to log and show in `status`. The
// names are copied: the program may be gone by the time the report is read.
struct BlockErrorReport {
  uint64_t count = 0;        // the block's errors so far under this program
  uint64_t new_errors = 0;   // since its previous report
  uint64_t source_hash = 0;  // of the program that counted them
  int64_t when_ns = 0;       // CLOCK_MONOTONIC of the cycle
  uint32_t line = 0;
  uint32_t col = 0;
  char name[48] = {};   // "F10.M4", "instance0.t1"
  char block[16] = {};  // the block as written: "div", "epi"
  // A runaway loop (the `loop` block ran past the task's budget; count is
  // the budget): the task stopped into its safe outputs.
  bool runaway_loop = false;
  uint64_t budget = 0;
};

// Copies one input group's values from its region into `io_in`, and each
// value's status as io::judge_quality says at `now_ns` into `in_status`: one
// consistent snapshot (at most `max_tries` attempts) lands in g.scratch and is
// copied only once it validated. False on a miss: io_in is untouched, so the
// task runs on last cycle's inputs, never on values mixed from two snapshots.
// A status that is not good sets `*any_not_good` (StatusLane::in_dirty).
bool read_group(const io::ProcessImage& image, InputGroup& g, double* io_in, uint8_t* in_status,
                int64_t now_ns, uint32_t max_tries, bool* any_not_good = nullptr) noexcept;

// Builds the migration from `old_image` (running with `old_arena`) to `next`:
// a block keeps its output and state when a block of the same name and opcode
// (and the same state size) exists in both programs.
Migration plan_migration(const TaskImage& old_image, const TaskImage& next);

// Executes a migration on the task thread: bounded copies, no allocation.
void apply_migration(const Migration& m, const TaskArena& from, TaskArena& to) noexcept;

}  // namespace rtplc::sched
