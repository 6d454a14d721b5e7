// Lock-free handoff between the engine thread and the tasks that use its data
// (issue 4, item 3: "the task side never blocks on it"). Two primitives:
//
// SeqlockSlot<T> — one writer (the engine thread), any number of readers (tasks,
//   monitors). The writer makes the sequence odd, stores the payload, makes it even
//   again; a reader copies the payload between two loads of the sequence and retries
//   if they differ or are odd. The writer never waits; a reader retries only while a
//   write of a few dozen bytes is in progress, which the single writer finishes
//   without blocking (it never sleeps or locks between the two sequence stores).
//   Memory order, without standalone fences (ThreadSanitizer cannot model them):
//   the writer makes the sequence odd with an acq_rel fetch_add, so no payload store
//   can be reordered before it; it stores the payload words with release and makes
//   the sequence even with a release store. The reader loads the sequence with
//   acquire, the payload words with acquire (so its second sequence load cannot move
//   before them), then the sequence again. If a payload load saw a word of a write in
//   progress, that write's odd increment happens-before the second load, which
//   therefore sees a different sequence and the reader retries. Payload words are
//   atomics, so there is no data race and no undefined behaviour. On x86 every one of
//   these is a plain move except the writer's one locked add.
//
// BoundedQueue<T> — many producers (tasks queueing writes), one consumer (the engine
//   thread); Vyukov's bounded array queue. Each cell carries a sequence number: a
//   producer claims a position with a CAS on the tail, writes the cell and publishes
//   it with a release store of the cell's sequence; the consumer acquires the
//   sequence before reading the cell and hands the cell back with a release store.
//   A full queue makes push() fail at once (the caller counts a rejected write); no
//   one ever waits for anyone. The claimed position doubles as a ticket number.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <type_traits>

namespace rtplc::s7 {

template <typename T>
class SeqlockSlot {
  static_assert(std::is_trivially_copyable_v<T>, "seqlock payloads are copied as bytes");
  static constexpr size_t kWords = (sizeof(T) + 7) / 8;

 public:
  SeqlockSlot() {
    for (auto& w : words_) w.store(0, std::memory_order_relaxed);
  }

  // Engine thread only.
  void store(const T& value) {
    uint64_t buf[kWords] = {};
    std::memcpy(buf, &value, sizeof(T));
    const uint64_t s = seq_.fetch_add(1, std::memory_order_acq_rel);
    for (size_t i = 0; i < kWords; ++i) words_[i].store(buf[i], std::memory_order_release);
    seq_.store(s + 2, std::memory_order_release);
  }

  // Any thread; never blocks, retries only across a concurrent store.
  T load() const {
    uint64_t buf[kWords];
    while (true) {
      const uint64_t s1 = seq_.load(std::memory_order_acquire);
      for (size_t i = 0; i < kWords; ++i) buf[i] = words_[i].load(std::memory_order_acquire);
      const uint64_t s2 = seq_.load(std::memory_order_relaxed);
      if (s1 == s2 && (s1 & 1) == 0) break;
    }
    T out;
    std::memcpy(&out, buf, sizeof(T));
    return out;
  }

 private:
  std::atomic<uint64_t> seq_{0};
  std::atomic<uint64_t> words_[kWords];
};

template <typename T>
class BoundedQueue {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  // `capacity` is rounded up to a power of two.
  explicit BoundedQueue(size_t capacity) {
    size_t c = 2;
    while (c < capacity) c <<= 1;
    mask_ = c - 1;
    cells_ = std::make_unique<Cell[]>(c);
    for (size_t i = 0; i < c; ++i) cells_[i].seq.store(i, std::memory_order_relaxed);
  }

  size_t capacity() const { return mask_ + 1; }

  // Any thread. Returns false if full. On success *ticket is the claimed position.
  bool push(const T& v, uint64_t* ticket = nullptr) {
    return push(v, [&](uint64_t pos) {
      if (ticket != nullptr) *ticket = pos;
    });
  }

  // As push(); `on_claim(position)` runs after the position is claimed and before the
  // cell is published, so whatever it stores happens-before the consumer sees the cell.
  template <typename OnClaim>
  bool push(const T& v, OnClaim&& on_claim) {
    uint64_t pos = tail_.load(std::memory_order_relaxed);
    while (true) {
      Cell& c = cells_[pos & mask_];
      const uint64_t seq = c.seq.load(std::memory_order_acquire);
      const auto diff = static_cast<int64_t>(seq) - static_cast<int64_t>(pos);
      if (diff == 0) {
        if (tail_.compare_exchange_weak(pos, pos + 1, std::memory_order_relaxed)) {
          on_claim(pos);
          c.value = v;
          c.seq.store(pos + 1, std::memory_order_release);
          return true;
        }
      } else if (diff < 0) {
        return false;
      } else {
        pos = tail_.load(std::memory_order_relaxed);
      }
    }
  }

  // The one consumer thread. Returns false if empty.
  bool pop(T& out) {
    Cell& c = cells_[head_ & mask_];
    const uint64_t seq = c.seq.load(std::memory_order_acquire);
    if (static_cast<int64_t>(seq) - static_cast<int64_t>(head_ + 1) < 0) return false;
    out = c.value;
    c.seq.store(head_ + mask_ + 1, std::memory_order_release);
    ++head_;
    return true;
  }

 private:
  struct Cell {
    std::atomic<uint64_t> seq{0};
    T value{};
  };
  size_t mask_ = 0;
  std::unique_ptr<Cell[]> cells_;
  alignas(64) std::atomic<uint64_t> tail_{0};
  alignas(64) uint64_t head_ = 0;
};

}  // namespace rtplc::s7
