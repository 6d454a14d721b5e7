// Compact storage of markings for reachability (issue item 4, "Speed and memory").
//
// MarkingLayout packs a marking into 64-bit words: each place gets a field just
// wide enough for its bound (1 bit for a safe place, 3 bits for a place that holds
// at most 5 tokens). Fields never straddle a word, so firing a transition is one
// subtraction and one addition per touched word (no borrow or carry can cross a
// field while every field stays within its width). Bit 63 of word 0 is reserved
// and always set in a stored key, so an all-zero slot means "empty".
//
// MarkingTable is an open-addressing (linear probing) hash set of packed keys,
// stored inline in one array, power-of-two sized and kept at most 3/4 full. One
// lookup costs one cache miss when the key is one word. An optional parallel array
// maps each slot to the marking's number (only when the caller needs graph edges).
//
// Shared insertion (insert_shared, the parallel BFS of reachability.cpp): several
// threads insert one-word keys at once, lock-free. The protocol, in full:
//  - Who writes a slot: whichever thread wins compare_exchange(0 -> key) on it.
//    A slot goes from 0 to a key exactly once and never changes again while
//    threads share the table (growing happens only when every thread waits at a
//    barrier). So each slot has at most one non-zero write in its history.
//  - Who reads: every inserting thread, probing from the key's home slot. A load
//    that sees 0 may be stale; it only leads to a CAS, and a CAS reads the latest
//    value, so it fails on a taken slot and the thread compares what is there.
//  - Why one insert per key: a thread passes slot j only after seeing its single
//    non-zero write (a different key); it claims slot s only by a CAS from 0.
//    Two threads inserting K probe the same sequence of slots; the first slot
//    either claims is the first one empty for both, where only one CAS succeeds
//    and the other thread's CAS returns K. No thread ever waits for another:
//    there is no half-written state (the key is one word), so a thread that
//    preempts an inserter on the same CPU finishes its own insert at once.
//  - Memory order: relaxed. The slot carries no pointer to other data (the
//    marking's parent and transition stay in the inserting thread's own list,
//    handed over at the level barrier, which orders everything for the next level).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace rtplc::petri {

class MarkingLayout {
 public:
  struct Field {
    uint32_t word = 0;
    uint32_t shift = 0;
    uint64_t mask = 0;  // unshifted: 2^bits - 1
  };
  static constexpr uint64_t kOccupied = uint64_t{1} << 63;

  // `bits[p]` = field width of place p, 1..32.
  explicit MarkingLayout(const std::vector<uint32_t>& bits);
  MarkingLayout() = default;

  size_t words() const { return words_; }
  size_t places() const { return fields_.size(); }
  const Field& field(size_t p) const { return fields_[p]; }
  uint64_t max_tokens(size_t p) const { return fields_[p].mask; }
  size_t total_bits() const { return bits_; }

  uint32_t get(const uint64_t* key, size_t p) const {
    const Field& f = fields_[p];
    return static_cast<uint32_t>((key[f.word] >> f.shift) & f.mask);
  }
  // Tokens must fit their fields (checked by the caller).
  void pack(const uint32_t* tokens, uint64_t* key) const;
  void unpack(const uint64_t* key, uint32_t* tokens) const;

 private:
  std::vector<Field> fields_;
  size_t words_ = 1;
  size_t bits_ = 0;
};

// An append-only array of records of `stride` elements, in fixed-size chunks:
// growing never copies what is stored and never needs twice the memory for a
// moment, as a doubling vector does. Records are contiguous within a chunk.
template <typename T>
class ChunkedArray {
 public:
  static constexpr size_t kChunkBits = 12;
  static constexpr size_t kChunk = size_t{1} << kChunkBits;  // records per chunk

  explicit ChunkedArray(size_t stride = 1) : stride_(stride) {}
  size_t size() const { return size_; }
  T* at(size_t i) { return chunks_[i >> kChunkBits].data() + (i & (kChunk - 1)) * stride_; }
  const T* at(size_t i) const {
    return chunks_[i >> kChunkBits].data() + (i & (kChunk - 1)) * stride_;
  }
  T& operator[](size_t i) { return *at(i); }
  const T& operator[](size_t i) const { return *at(i); }
  void push_back(const T* record) {
    if ((size_ & (kChunk - 1)) == 0) chunks_.emplace_back(kChunk * stride_);
    T* dst = chunks_.back().data() + (size_ & (kChunk - 1)) * stride_;
    for (size_t k = 0; k < stride_; ++k) dst[k] = record[k];
    ++size_;
  }
  void push_back(T v) { push_back(&v); }
  size_t bytes() const {
    return chunks_.size() * kChunk * stride_ * sizeof(T) + chunks_.capacity() * sizeof(chunks_[0]);
  }

 private:
  std::vector<std::vector<T>> chunks_;
  size_t stride_;
  size_t size_ = 0;
};

// Number of bits that hold 0..max.
uint32_t bits_for(uint64_t max);

class MarkingTable {
 public:
  MarkingTable(size_t words, bool with_ids, size_t initial_capacity = 1024);
  ~MarkingTable();
  MarkingTable(const MarkingTable&) = delete;
  MarkingTable& operator=(const MarkingTable&) = delete;

  static uint64_t hash(const uint64_t* key, size_t words) {
    // A multiply-xorshift mix per word (the 64-bit finaliser of a well-known mixer):
    // neighbouring markings differ in few bits, so every input bit must reach the top.
    uint64_t h = 0x9e3779b97f4a7c15ULL;
    for (size_t i = 0; i < words; ++i) {
      uint64_t x = key[i] ^ h;
      x ^= x >> 33;
      x *= 0xff51afd7ed558ccdULL;
      x ^= x >> 33;
      x *= 0xc4ceb9fe1a85ec53ULL;
      x ^= x >> 33;
      h = x;
    }
    return h;
  }
  uint64_t hash(const uint64_t* key) const { return hash(key, words_); }
  // Hints the cache that the key with hash `h` will be looked up soon.
  void prefetch(uint64_t h) const { __builtin_prefetch(slots_ + (h & (capacity_ - 1)) * words_); }

  // Inserts `key` (bit 63 of word 0 set; `h` its hash) unless present. Returns the
  // slot and whether it was new; a new slot is tagged with `id` when ids are kept.
  struct Found {
    size_t slot;
    bool inserted;
  };
  Found insert(const uint64_t* key, uint64_t h, uint32_t id) {
    if ((size_ + 1) * 4 > capacity_ * 3) grow();
    const size_t mask = capacity_ - 1;
    size_t slot = static_cast<size_t>(h) & mask;
    if (words_ == 1) {
      for (;;) {
        const uint64_t s = slots_[slot];
        if (s == key[0]) return {slot, false};
        if (s == 0) break;
        slot = (slot + 1) & mask;
      }
      slots_[slot] = key[0];
    } else {
      for (;;) {
        const uint64_t* s = slots_ + slot * words_;
        if (s[0] == 0) break;
        if (same(s, key)) return {slot, false};
        slot = (slot + 1) & mask;
      }
      for (size_t k = 0; k < words_; ++k) slots_[slot * words_ + k] = key[k];
    }
    if (with_ids_) ids_[slot] = id;
    ++size_;
    return {slot, true};
  }
  Found insert(const uint64_t* key, uint32_t id) { return insert(key, hash(key), id); }

  // Shared insertion of a one-word key by several threads at once (the protocol is
  // described at the top of this file). No ids are recorded and the table never
  // grows here: the caller keeps the load in check with needs_room()/grow_to_fit()
  // while no thread inserts, and adds what was inserted with add_shared_inserts().
  // `before_claim` runs between seeing an empty slot and claiming it (tests use it
  // to let another inserter in at the worst moment; the explorer passes a no-op).
  template <typename BeforeClaim>
  bool insert_shared(uint64_t key, uint64_t h, BeforeClaim&& before_claim) {
    const size_t mask = capacity_ - 1;
    size_t slot = static_cast<size_t>(h) & mask;
    for (;;) {
      std::atomic_ref<uint64_t> s(slots_[slot]);
      uint64_t v = s.load(std::memory_order_relaxed);
      if (v == key) return false;
      if (v == 0) {
        before_claim();
        if (s.compare_exchange_strong(v, key, std::memory_order_relaxed)) return true;
        if (v == key) return false;  // another thread inserted the same key first
      }
      slot = (slot + 1) & mask;
    }
  }
  bool insert_shared(uint64_t key, uint64_t h) {
    return insert_shared(key, h, [] {});
  }
  // True when `extra` more keys would pass the 3/4 load limit.
  bool needs_room(size_t extra) const { return (size_ + extra) * 4 > capacity_ * 3; }
  // Grows until `extra` more keys fit (no thread may be inserting).
  void grow_to_fit(size_t extra) {
    while (needs_room(extra)) grow();
  }
  void add_shared_inserts(size_t n) { size_ += n; }

  // Growing a shared table with every thread's help, between two barriers:
  // begin_shared_grow() (one thread, none inserting) makes the doubled array,
  // then the threads move disjoint ranges of old slots with rehash_shared()
  // (CAS on empty slots of the new array, as insert_shared; the keys are all
  // different, so a failed CAS just means "taken, probe on"), and
  // end_shared_grow() (one thread, after the barrier) frees the old array. Each
  // thread also takes its share of the kernel's zeroing of the new pages. A table
  // grown this way keeps no ids any more.
  void begin_shared_grow();
  size_t old_capacity() const { return old_capacity_; }
  void rehash_shared(size_t from, size_t to) {
    const size_t mask = capacity_ - 1;
    for (size_t i = from; i < to; ++i) {
      const uint64_t k = old_slots_[i];
      if (k == 0) continue;
      size_t slot = static_cast<size_t>(hash(&k, 1)) & mask;
      for (;;) {
        std::atomic_ref<uint64_t> s(slots_[slot]);
        uint64_t expected = 0;
        if (s.load(std::memory_order_relaxed) == 0 &&
            s.compare_exchange_strong(expected, k, std::memory_order_relaxed))
          break;
        slot = (slot + 1) & mask;
      }
    }
  }
  void end_shared_grow();

  uint32_t id_at(size_t slot) const { return ids_[slot]; }
  size_t size() const { return size_; }
  size_t capacity() const { return capacity_; }
  size_t bytes() const;

 private:
  bool same(const uint64_t* a, const uint64_t* b) const {
    for (size_t k = 0; k < words_; ++k) {
      if (a[k] != b[k]) return false;
    }
    return true;
  }
  // Zeroed slot memory; large tables ask for transparent huge pages, since the
  // lookups jump all over it and would otherwise miss the TLB on most probes.
  static uint64_t* allocate(size_t n_words, void** base, size_t* mapped);
  void grow();
  size_t words_;
  bool with_ids_;
  size_t capacity_;
  size_t size_ = 0;
  uint64_t* slots_ = nullptr;
  void* base_ = nullptr;
  size_t mapped_ = 0;
  std::vector<uint32_t> ids_;
  // The array being moved from during a shared growth (see begin_shared_grow()).
  uint64_t* old_slots_ = nullptr;
  void* old_base_ = nullptr;
  size_t old_mapped_ = 0;
  size_t old_capacity_ = 0;
};

}  // namespace rtplc::petri
