// The retained-state file (spec runtime.md, "Retain"; docs/runtime.md,
// "Retained block state"): the block state of every task, written by the
// control thread — at `retain_every` and when the runtime stops — so a restart,
// also after `kill -9` or a power cut, continues from it (warm start). One file
// per runtime, beside the set-point retain file: `NAME.state`. Text, so an
// engineer can read it:
//
//   rtplc-state 1
//   runtime NAME
//   saved UNIX_MS
//   task TASK CYCLE N_BLOCKS
//   block NAME KIND N_VALUES V1 V2 ...      (N_BLOCKS lines: [output] then state)
//   ...
//   crc32 XXXXXXXX                          (of every byte before this line)
//
// Doubles are written with 17 significant digits (they read back bit-exact).
// The file is replaced atomically (temp file, fsync, rename, fsync folder), so
// a crash leaves the old file or the new one; a file that is still torn or
// damaged (bad magic, unknown version, no checksum line, checksum mismatch, a
// malformed line) is reported with its path and why, and ignored: every block
// then starts cold. A block restores only into a block of the same name, kind
// and state size (the program identity, as hot swap matches state); any other
// saved block is reported: refused (changed) or dropped (gone).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "blocks/executor.h"
#include "common/result.h"
#include "sched/state_snapshot.h"

namespace rtplc::sched {

inline constexpr const char* kStateMagic = "rtplc-state";
inline constexpr uint32_t kStateVersion = 1;

struct SavedBlock {
  std::string name;
  std::string kind;
  std::vector<double> values;  // [output] then state, as RetainedBlock::width()
  bool operator==(const SavedBlock&) const = default;
};

struct SavedTask {
  std::string name;
  uint64_t cycle = 0;  // the task's cycle count when the snapshot was taken
  std::vector<SavedBlock> blocks;
};

struct SavedState {
  std::string runtime;
  int64_t saved_unix_ms = 0;
  std::vector<SavedTask> tasks;
  const SavedTask* find(std::string_view task) const;
};

uint32_t crc32(std::string_view bytes);
// Incremental form: crc32(b) == crc32_final(crc32_update(kCrc32Start, b)).
inline constexpr uint32_t kCrc32Start = 0xFFFFFFFFu;
uint32_t crc32_update(uint32_t state, std::string_view bytes);
inline uint32_t crc32_final(uint32_t state) { return state ^ 0xFFFFFFFFu; }

// One task of a state file as the running runtime holds it, without a copy per
// block: what the file had (`saved`, until the task's first snapshot), or its
// retained blocks' layout and its last snapshot (`layout` and `data`).
struct TaskStateRef {
  std::string_view name;
  uint64_t cycle = 0;
  const SavedTask* saved = nullptr;
  const std::vector<RetainedBlock>* layout = nullptr;
  const std::vector<double>* data = nullptr;
};
// Writes the file's text piece by piece into `sink` (a big runtime's state is
// megabytes: never built whole). False when the sink gave up.
bool encode_state_to(const std::function<bool(std::string_view)>& sink, std::string_view runtime,
                     int64_t saved_unix_ms, const std::vector<TaskStateRef>& tasks);
std::string encode_state(const SavedState& s);
// `file` names the source in errors ("/var/lib/rtplc/x.state: checksum mismatch ...").
Result<SavedState> decode_state(std::string_view text, const std::string& file);

// A missing file is no saved state (nullopt), not an error.
Result<std::optional<SavedState>> load_state_file(const std::string& path);
Result<void> save_state_file(const std::string& path, const SavedState& s);
Result<void> save_state_file(const std::string& path, std::string_view runtime, int64_t saved_unix_ms,
                             const std::vector<TaskStateRef>& tasks);

// One task's snapshot (StateSnapshot::read's doubles) as saved blocks.
SavedTask saved_task(const std::string& task, const std::vector<RetainedBlock>& layout,
                     const std::vector<double>& data, uint64_t cycle);

// What a restore did, for the start log.
struct RestoreOutcome {
  std::vector<std::string> restored;  // block names
  std::vector<std::string> refused;   // "F3 (saved as pid with 4 values, now lowpass with 2)"
  std::vector<std::string> missing;   // retained blocks the file had nothing for
  std::vector<std::string> dropped;   // saved blocks the program no longer retains (or has)
};

// Copies the saved values of `saved` into `arena` for every block of `layout`
// with the same name, kind and width. Off the RT path, before the task runs.
RestoreOutcome restore_task(const SavedTask& saved, const std::vector<RetainedBlock>& layout,
                            TaskArena& arena);

}  // namespace rtplc::sched
