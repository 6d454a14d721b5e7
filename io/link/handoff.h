// Lock-free handoff between a link's I/O thread (the S7 engine's event loop, later
// the Modbus and CAN threads) and the threads that use its data (a driver's
// bridge thread, the tasks, monitors). Two primitives:
//
// SnapshotSlot<T> — one writer, any number of readers, nobody ever waits.
//   The slot keeps kSlots copies of T, each with its own sequence number and
//   the publication number it holds (`gen`), and a count `published` of
//   completed stores.
//   writer  store(v): n = published + 1; k = n % kSlots; seq[k] += 1 (odd:
//           "being written"); the payload words of copy k; gen[k] = n; seq[k]
//           += 1 (even); published = n. Every one of these is an atomic store;
//           the odd increment is an acq_rel read-modify-write, the rest release.
//   reader  n = published (acquire); k = n % kSlots; s1 = seq[k] (acquire),
//           odd -> retry; g = gen[k] and the words (acquire loads, so the
//           second sequence load cannot move before them); s2 = seq[k];
//           s1 == s2 and g == n -> done, else retry.
//   Why this and not a plain seqlock (one copy): a reader at a higher SCHED_FIFO
//   priority on the writer's CPU that preempts the writer between its two
//   sequence stores would spin on the odd sequence forever, and the writer would
//   never run again to make it even. Here the reader reads the last *completed*
//   copy, which the writer is not touching (it only ever writes copy
//   published + 1), so a reader that preempts the writer succeeds at once. A
//   retry is needed only when the writer completes kSlots - 1 further stores
//   during one copy, i.e. while the reader itself was preempted; readers bound
//   their retries (try_load) and keep what they had when they run out.
//   If a payload load saw a word of a later store into the same copy, that
//   store's odd increment happens-before the second sequence load, which then
//   differs, so a torn copy is never accepted. Payload words are atomics, so
//   there is no data race (ThreadSanitizer checks this very code; no fences).
//   Why `gen`: readers must see values in publication order. Without it, a
//   reader that loaded published = n and was then delayed could find copy k
//   already rewritten whole with publication n + kSlots (its seq even again)
//   while the writer had not yet stored published = n + kSlots; it took that
//   value, and its next load of `published` (still n + kSlots - 1) handed it
//   an older one. Accepting only g == n means a reader returns exactly the
//   publication whose number it loaded, and successive loads of one atomic by
//   one thread never go backwards (read-read coherence), so neither do values.
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
#include <utility>

namespace rtplc::link {

template <typename T>
class SnapshotSlot {
  static_assert(std::is_trivially_copyable_v<T>, "snapshot payloads are copied as bytes");
  static constexpr size_t kWords = (sizeof(T) + 7) / 8;

 public:
  static constexpr uint32_t kSlots = 4;
  static constexpr uint32_t kDefaultTries = 16;

  SnapshotSlot() {
    for (Copy& c : copies_) {
      for (auto& w : c.words) w.store(0, std::memory_order_relaxed);
    }
    // Copy 0 holds a value-initialised T and counts as published, so a reader
    // always finds a completed copy.
    const T zero{};
    write_words(copies_[0], zero);
  }

  // The one writer thread.
  void store(const T& value) {
    store(value, [] {}, [] {});
  }
  // The same; `mid_store()` runs while the copy is half written and
  // `before_publish()` once the copy is whole but not yet published (tests use
  // them to be preempted exactly there).
  template <typename MidStore, typename BeforePublish>
  void store(const T& value, MidStore&& mid_store, BeforePublish&& before_publish) {
    const uint64_t n = published_.load(std::memory_order_relaxed) + 1;
    Copy& c = copies_[n % kSlots];
    const uint64_t s = c.seq.fetch_add(1, std::memory_order_acq_rel);
    mid_store();
    write_words(c, value);
    c.gen.store(n, std::memory_order_release);
    c.seq.store(s + 2, std::memory_order_release);
    before_publish();
    published_.store(n, std::memory_order_release);
    last_ = value;
  }
  template <typename MidStore>
  void store(const T& value, MidStore&& mid_store) {
    store(value, std::forward<MidStore>(mid_store), [] {});
  }

  // The writer's own latest value (writer thread only: no race with itself).
  const T& writer_value() const { return last_; }

  // Any thread; never waits. Returns false (and leaves `out` unchanged) when no
  // consistent copy was obtained in `tries` attempts.
  bool try_load(T& out, uint32_t tries = kDefaultTries) const {
    return try_load(out, tries, [] {});
  }
  // The same; `after_index()` runs between the load of `published` and the
  // copy (tests use it to delay a reader exactly there).
  template <typename AfterIndex>
  bool try_load(T& out, uint32_t tries, AfterIndex&& after_index) const {
    uint64_t buf[kWords];
    for (uint32_t t = 0; t < tries; ++t) {
      const uint64_t n = published_.load(std::memory_order_acquire);
      after_index();
      const Copy& c = copies_[n % kSlots];
      const uint64_t s1 = c.seq.load(std::memory_order_acquire);
      if (s1 & 1) continue;
      const uint64_t g = c.gen.load(std::memory_order_acquire);
      for (size_t i = 0; i < kWords; ++i) buf[i] = c.words[i].load(std::memory_order_acquire);
      if (c.seq.load(std::memory_order_relaxed) != s1 || g != n) continue;
      std::memcpy(&out, buf, sizeof(T));
      return true;
    }
    return false;
  }

 private:
  struct alignas(64) Copy {
    std::atomic<uint64_t> seq{0};
    std::atomic<uint64_t> gen{0};  // the publication number this copy holds
    std::atomic<uint64_t> words[kWords];
  };
  static void write_words(Copy& c, const T& value) {
    uint64_t buf[kWords] = {};
    std::memcpy(buf, &value, sizeof(T));
    for (size_t i = 0; i < kWords; ++i) c.words[i].store(buf[i], std::memory_order_release);
  }

  Copy copies_[kSlots];
  alignas(64) std::atomic<uint64_t> published_{0};
  T last_{};
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

  // The one consumer thread: true when pop() would return false now. The
  // same acquire load of the head cell's sequence as pop(): false means a
  // producer published that cell, so the consumer's next pop() takes it (no
  // other thread removes items); true may be stale by the time the caller
  // acts, as any emptiness test of a concurrent queue is.
  bool empty() const {
    const Cell& c = cells_[head_ & mask_];
    return static_cast<int64_t>(c.seq.load(std::memory_order_acquire)) - static_cast<int64_t>(head_ + 1) < 0;
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

}  // namespace rtplc::link
