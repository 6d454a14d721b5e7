// An indexed binary min-heap of deadlines, one entry per key (a PLC), for the engine's
// timers (spec: s7-client.md, "timeouts from a timer wheel or heap"). Each PLC keeps
// exactly one deadline — the earliest of its poll tick, its reply/connect timeouts and
// its reconnect time — so rescheduling is an O(log n) move of that one entry, and the
// heap never grows with stale entries.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace rtplc::link {

class TimerHeap {
 public:
  static constexpr int64_t kNever = std::numeric_limits<int64_t>::max();

  explicit TimerHeap(size_t keys = 0) { resize(keys); }
  void resize(size_t keys) { pos_.resize(keys, kNone); }

  // Sets (or moves) the deadline of `key`; kNever removes it.
  void schedule(uint32_t key, int64_t deadline);
  void cancel(uint32_t key) { schedule(key, kNever); }

  bool empty() const { return heap_.empty(); }
  int64_t next_deadline() const { return heap_.empty() ? kNever : heap_[0].deadline; }
  uint32_t top() const { return heap_[0].key; }
  int64_t deadline_of(uint32_t key) const { return pos_[key] == kNone ? kNever : heap_[pos_[key]].deadline; }
  size_t size() const { return heap_.size(); }

 private:
  static constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
  struct Entry {
    int64_t deadline;
    uint32_t key;
  };
  void place(size_t i, Entry e);
  void sift_up(size_t i);
  void sift_down(size_t i);
  void remove_at(size_t i);

  std::vector<Entry> heap_;
  std::vector<uint32_t> pos_;
};

}  // namespace rtplc::link
