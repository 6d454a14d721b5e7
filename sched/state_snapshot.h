// Retained block state, the copy a running task hands to the non-RT side
// (spec runtime.md, "Retain"; docs/runtime.md, "Retained block state"). The
// task's arena belongs to the task thread: nobody else may read it while the
// task runs. So every N cycles the task itself copies its retained slots (block
// outputs and block state) into one of two buffers, and the control thread
// reads the last completed buffer when it persists the state file.
//
// Protocol (one writer: the task thread; one reader: the control thread),
// fence-free like the process image's (io/process_image.h), so ThreadSanitizer
// checks it as it runs:
//   writer, into buffer w = the one NOT published last:
//     seq[w].fetch_add(1, acq_rel) (odd: being written)
//     data, cycle and time stored with release stores
//     seq[w] += 1 (even: whole), release
//     latest.store(w, release)
//   reader:
//     w = latest.load(acquire)            (none yet: nothing to read)
//     s1 = seq[w].load(acquire); odd -> try again
//     copy data, cycle and time with acquire loads
//     s2 = seq[w].load(relaxed); s1 == s2 -> the copy is one whole snapshot
// The odd RMW's acquire half keeps every data store of that snapshot after it;
// a data store is a release, so a reader whose acquire load sees it also sees
// the odd seq (and everything before it) in its later load of s2: a reader that
// saw any store of a newer snapshot sees s2 != s1 and retries. Two buffers make the
// reader wait-free in the case that matters: a reader that preempts the writer
// mid-copy (on the same CPU, or at any moment) finds `latest` pointing at the
// other, finished buffer, which the writer will not touch until it has
// published the one it is writing. Only a writer that finishes two snapshots
// during one read makes the reader retry; after a few tries it gives up for
// this round (the next persist tries again). The writer never waits, never
// allocates and makes no system call: a bounded copy of the retained doubles.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "blocks/executor.h"
#include "blocks/status.h"

namespace rtplc::sched {

// One retained block of a program: where its slots are in the arena.
struct RetainedBlock {
  static constexpr uint32_t kNoValue = UINT32_MAX;
  std::string name;  // BlockInfo name ("F10", "F10.M4", "step.Fill")
  std::string_view kind;  // opcode name ("intg", "pid"...; static text), so state restores only into its kind
  uint32_t value = kNoValue;  // value slot (the block's output), or kNoValue
  uint32_t state = 0;         // first state double
  uint32_t n_state = 0;
  uint32_t n_value = 1;  // slots of the value: 1 + cap for a string (its length, then its characters)
  bool wide = false;     // the watch's: a WSTRING (shown as UTF-8)
  // Doubles this block contributes to a snapshot: [value] then its state.
  uint32_t width() const { return (value == kNoValue ? 0u : n_value) + n_state; }
};

class StateSnapshot {
 public:
  StateSnapshot() = default;
  StateSnapshot(const StateSnapshot&) = delete;
  StateSnapshot& operator=(const StateSnapshot&) = delete;

  // Off the RT path: sizes the two buffers for `blocks` (the program's retained blocks).
  void prepare(std::vector<RetainedBlock> blocks);
  const std::vector<RetainedBlock>& blocks() const { return *blocks_; }
  // The same layout, shared: the runtime keeps it with the last snapshot it
  // persisted, so it outlives a program a swap retired.
  std::shared_ptr<const std::vector<RetainedBlock>> layout() const { return blocks_; }
  uint32_t size() const { return n_; }

  // Task thread: copies the retained slots of `arena` into the free buffer and
  // publishes it. Bounded, no allocation, no lock, no system call.
  void take(const TaskArena& arena, int64_t now_ns) noexcept;

  // Control thread: the last published snapshot, whole, into `out` (resized).
  // False when none was published yet, or the writer kept overwriting the
  // buffer being read (try again later).
  bool read(std::vector<double>& out, uint64_t& cycle, int64_t& taken_ns,
            uint32_t max_tries = 4) const;

  // Control thread, while no task runs this program: drops what was published,
  // so read() has nothing until the next take(). The publication of the program
  // to its task (a release store) orders this before the task's next take().
  void forget() noexcept { latest_.store(kNone, std::memory_order_relaxed); }

  // Published snapshots (for the control thread to see whether anything is new).
  uint64_t taken() const { return taken_.load(std::memory_order_acquire); }

  // Task thread, for the watch (watched_blocks below): each block's output
  // and then its status (the StatusLane lane value as a double), through the
  // same two buffers and protocol as take(). Bounded, no allocation.
  void take_watch(const TaskArena& arena, const StatusLane& lane, int64_t now_ns) noexcept;

  // Tests: the writer's steps one at a time, so a test can stop between them.
  uint32_t begin_take() noexcept;
  void store(uint32_t buffer, uint32_t i, double v) noexcept;
  void end_take(uint32_t buffer, uint64_t cycle, int64_t now_ns) noexcept;

 private:
  static constexpr uint32_t kNone = UINT32_MAX;
  struct Buffer {
    std::atomic<uint64_t> seq{0};
    std::atomic<uint64_t> cycle{0};
    std::atomic<int64_t> taken_ns{0};
    std::unique_ptr<double[]> data;
  };
  std::shared_ptr<const std::vector<RetainedBlock>> blocks_ = std::make_shared<const std::vector<RetainedBlock>>();
  uint32_t n_ = 0;
  Buffer buffers_[2];
  std::atomic<uint32_t> latest_{kNone};
  std::atomic<uint64_t> taken_{0};
  uint32_t next_ = 0;  // writer only: the buffer the next take() fills
};

// The retained blocks of `image` under a task's `retain` selection: every block
// with state, and the outputs a later cycle reads back, but the input and set-point loads (`all`), none, or
// the blocks named in `names` (a name also selects what a macro call or SFC
// chart expanded under it: "F10" selects "F10.M4"). Unknown names are listed
// in `unknown` when given.
// The watch's layout (the editor's live wires, Runtime::watch): every block
// that writes a value, in textual order, with `n_state` = 1 standing for its
// status (take_watch writes [output, status]; a string's output is its
// n_value slots, blocks/ops.h "Strings"). Loads of inputs and set-points
// are left out: their channels are in the process image already.
std::vector<RetainedBlock> watched_blocks(const TaskImage& image);

std::vector<RetainedBlock> retained_blocks(const TaskImage& image, bool all,
                                           const std::vector<std::string>& names,
                                           std::vector<std::string>* unknown = nullptr);

}  // namespace rtplc::sched
