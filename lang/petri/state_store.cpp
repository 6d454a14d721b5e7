// Bit-packed markings and their open-addressing hash set (see state_store.h;
// issue item 4, "Speed and memory").
#include "lang/petri/state_store.h"

#include <sys/mman.h>
#include <algorithm>

#include <cstring>
#include <new>

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
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return bits[a] > bits[b]; });
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
  slots_ = allocate(capacity_ * words_, &base_, &mapped_);
  if (with_ids_) ids_.assign(capacity_, 0);
}

MarkingTable::~MarkingTable() {
  if (base_) munmap(base_, mapped_);
  if (old_base_) munmap(old_base_, old_mapped_);
}

uint64_t* MarkingTable::allocate(size_t n_words, void** base, size_t* mapped) {
  constexpr size_t kHuge = size_t{2} << 20;
  const size_t bytes = n_words * sizeof(uint64_t);
  const size_t len = bytes >= kHuge ? bytes + kHuge : bytes;  // room to align to 2 MB
  void* p = mmap(nullptr, len, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) throw std::bad_alloc();
  *base = p;
  *mapped = len;
  auto addr = reinterpret_cast<uintptr_t>(p);
  if (bytes >= kHuge) {
    addr = (addr + kHuge - 1) & ~(uintptr_t{kHuge} - 1);
    (void)madvise(reinterpret_cast<void*>(addr), bytes, MADV_HUGEPAGE);  // a hint only
  }
  return reinterpret_cast<uint64_t*>(addr);
}

void MarkingTable::grow() {
  const size_t new_capacity = capacity_ * 2;
  void* new_base = nullptr;
  size_t new_mapped = 0;
  uint64_t* fresh = allocate(new_capacity * words_, &new_base, &new_mapped);
  std::vector<uint32_t> new_ids;
  if (with_ids_) new_ids.assign(new_capacity, 0);
  const size_t mask = new_capacity - 1;
  for (size_t i = 0; i < capacity_; ++i) {
    const uint64_t* k = slots_ + i * words_;
    if (k[0] == 0) continue;
    size_t slot = static_cast<size_t>(hash(k, words_)) & mask;
    while (fresh[slot * words_] != 0) slot = (slot + 1) & mask;
    std::memcpy(fresh + slot * words_, k, words_ * sizeof(uint64_t));
    if (with_ids_) new_ids[slot] = ids_[i];
  }
  munmap(base_, mapped_);
  base_ = new_base;
  mapped_ = new_mapped;
  slots_ = fresh;
  ids_ = std::move(new_ids);
  capacity_ = new_capacity;
}

void MarkingTable::begin_shared_grow() {
  old_slots_ = slots_;
  old_base_ = base_;
  old_mapped_ = mapped_;
  old_capacity_ = capacity_;
  capacity_ *= 2;
  slots_ = allocate(capacity_ * words_, &base_, &mapped_);
  with_ids_ = false;
  ids_ = {};
}

void MarkingTable::end_shared_grow() {
  if (old_base_) munmap(old_base_, old_mapped_);
  old_slots_ = nullptr;
  old_base_ = nullptr;
  old_mapped_ = 0;
  old_capacity_ = 0;
}

size_t MarkingTable::bytes() const {
  return capacity_ * words_ * sizeof(uint64_t) + ids_.capacity() * sizeof(uint32_t);
}

}  // namespace rtplc::petri
