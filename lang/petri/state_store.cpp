// Bit-packed markings and their open-addressing hash set (see state_store.h;
// issue item 4, "Speed and memory").
#include "lang/petri/state_store.h"

#include <algorithm>
#include <cstring>

namespace rtplc::petri {

uint32_t bits_for(uint64_t max) {
  uint32_t b = 1;
  while (b < 64 && (max >> b) != 0) ++b;
  return b;
}

MarkingLayout::MarkingLayout(const std::vector<uint32_t>& bits) {
  // First fit, widest fields first, so few words go half empty; word 0 keeps
  // bit 63 free for the occupied flag.
  std::vector<size_t> order(bits.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return bits[a] > bits[b]; });
  std::vector<uint32_t> used{1};  // bits used per word; word 0 starts with the flag
  fields_.resize(bits.size());
  for (size_t p : order) {
    const uint32_t w = std::clamp<uint32_t>(bits[p], 1, 32);
    bits_ += w;
    size_t word = 0;
    while (word < used.size() && used[word] + w > 64) ++word;
    if (word == used.size()) used.push_back(0);
    // Word 0 fills from bit 0 upward below the flag; others likewise.
    fields_[p] = Field{static_cast<uint32_t>(word), word == 0 ? used[word] - 1 : used[word],
                       (uint64_t{1} << w) - 1};
    used[word] += w;
  }
  words_ = used.size();
}

void MarkingLayout::pack(const uint32_t* tokens, uint64_t* key) const {
  std::memset(key, 0, words_ * sizeof(uint64_t));
  key[0] = kOccupied;
  for (size_t p = 0; p < fields_.size(); ++p) {
    const Field& f = fields_[p];
    key[f.word] |= (uint64_t{tokens[p]} & f.mask) << f.shift;
  }
}

void MarkingLayout::unpack(const uint64_t* key, uint32_t* tokens) const {
  for (size_t p = 0; p < fields_.size(); ++p) tokens[p] = get(key, p);
}

MarkingTable::MarkingTable(size_t words, bool with_ids, size_t initial_capacity)
    : words_(words), with_ids_(with_ids), capacity_(16) {
  while (capacity_ < initial_capacity) capacity_ *= 2;
  slots_.assign(capacity_ * words_, 0);
  if (with_ids_) ids_.assign(capacity_, 0);
}

uint64_t MarkingTable::hash(const uint64_t* key, size_t words) {
  // A multiply-xorshift mix per word (the 64-bit finaliser of a well-known mixer):
  // consecutive markings differ in few bits, so every input bit must reach the top.
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

void MarkingTable::prefetch(const uint64_t* key) const {
  const size_t slot = static_cast<size_t>(hash(key, words_)) & (capacity_ - 1);
  __builtin_prefetch(&slots_[slot * words_]);
}

MarkingTable::Found MarkingTable::insert(const uint64_t* key, uint32_t id) {
  if ((size_ + 1) * 4 > capacity_ * 3) grow();
  const size_t mask = capacity_ - 1;
  size_t slot = static_cast<size_t>(hash(key, words_)) & mask;
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
      const uint64_t* s = &slots_[slot * words_];
      if (s[0] == 0) break;
      if (std::memcmp(s, key, words_ * sizeof(uint64_t)) == 0) return {slot, false};
      slot = (slot + 1) & mask;
    }
    std::memcpy(&slots_[slot * words_], key, words_ * sizeof(uint64_t));
  }
  if (with_ids_) ids_[slot] = id;
  ++size_;
  return {slot, true};
}

void MarkingTable::grow() {
  const size_t new_capacity = capacity_ * 2;
  std::vector<uint64_t> old = std::move(slots_);
  std::vector<uint32_t> old_ids = std::move(ids_);
  slots_.assign(new_capacity * words_, 0);
  if (with_ids_) ids_.assign(new_capacity, 0);
  const size_t mask = new_capacity - 1;
  for (size_t i = 0; i < capacity_; ++i) {
    const uint64_t* k = &old[i * words_];
    if (k[0] == 0) continue;
    size_t slot = static_cast<size_t>(hash(k, words_)) & mask;
    while (slots_[slot * words_] != 0) slot = (slot + 1) & mask;
    std::memcpy(&slots_[slot * words_], k, words_ * sizeof(uint64_t));
    if (with_ids_) ids_[slot] = old_ids[i];
  }
  capacity_ = new_capacity;
}

size_t MarkingTable::bytes() const {
  return slots_.capacity() * sizeof(uint64_t) + ids_.capacity() * sizeof(uint32_t);
}

}  // namespace rtplc::petri
