// The engine's indexed deadline heap (see timer_heap.h).
#include "io/link/timer_heap.h"

namespace rtplc::link {

void TimerHeap::place(size_t i, Entry e) {
  heap_[i] = e;
  pos_[e.key] = static_cast<uint32_t>(i);
}

void TimerHeap::sift_up(size_t i) {
  const Entry e = heap_[i];
  while (i > 0) {
    const size_t parent = (i - 1) / 2;
    if (heap_[parent].deadline <= e.deadline) break;
    place(i, heap_[parent]);
    i = parent;
  }
  place(i, e);
}

void TimerHeap::sift_down(size_t i) {
  const Entry e = heap_[i];
  const size_t n = heap_.size();
  while (true) {
    size_t child = 2 * i + 1;
    if (child >= n) break;
    if (child + 1 < n && heap_[child + 1].deadline < heap_[child].deadline) ++child;
    if (heap_[child].deadline >= e.deadline) break;
    place(i, heap_[child]);
    i = child;
  }
  place(i, e);
}

void TimerHeap::remove_at(size_t i) {
  pos_[heap_[i].key] = kNone;
  const Entry last = heap_.back();
  heap_.pop_back();
  if (i == heap_.size()) return;
  place(i, last);
  sift_down(i);
  sift_up(pos_[last.key]);
}

void TimerHeap::schedule(uint32_t key, int64_t deadline) {
  if (key >= pos_.size()) pos_.resize(key + 1, kNone);
  const uint32_t at = pos_[key];
  if (deadline == kNever) {
    if (at != kNone) remove_at(at);
    return;
  }
  if (at == kNone) {
    heap_.push_back({deadline, key});
    pos_[key] = static_cast<uint32_t>(heap_.size() - 1);
    sift_up(heap_.size() - 1);
    return;
  }
  const int64_t old = heap_[at].deadline;
  heap_[at].deadline = deadline;
  if (deadline < old) {
    sift_up(at);
  } else {
    sift_down(at);
  }
}

}  // namespace rtplc::link
