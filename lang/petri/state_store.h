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
#pragma once

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

// Number of bits that hold 0..max.
uint32_t bits_for(uint64_t max);

class MarkingTable {
 public:
  MarkingTable(size_t words, bool with_ids, size_t initial_capacity = 1024);

  // Inserts `key` (bit 63 of word 0 set) unless present. Returns the slot and
  // whether it was new; a new slot is tagged with `id` when ids are kept.
  struct Found {
    size_t slot;
    bool inserted;
  };
  Found insert(const uint64_t* key, uint32_t id);
  uint32_t id_at(size_t slot) const { return ids_[slot]; }
  size_t size() const { return size_; }
  size_t capacity() const { return capacity_; }
  size_t bytes() const;
  // Hints the cache that `key` will be looked up soon.
  void prefetch(const uint64_t* key) const;

  static uint64_t hash(const uint64_t* key, size_t words);

 private:
  void grow();
  size_t words_;
  bool with_ids_;
  size_t capacity_;
  size_t size_ = 0;
  std::vector<uint64_t> slots_;
  std::vector<uint32_t> ids_;
};

}  // namespace rtplc::petri
