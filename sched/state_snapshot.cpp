// The task -> control thread snapshot of retained block state (see state_snapshot.h).
#include "sched/state_snapshot.h"

#include "blocks/string_ops.h"

#include <algorithm>
#include <cctype>

namespace rtplc::sched {

static_assert(std::atomic_ref<double>::is_always_lock_free,
              "snapshots need lock-free double stores");

void StateSnapshot::prepare(std::vector<RetainedBlock> blocks) {
  blocks_ = std::make_shared<const std::vector<RetainedBlock>>(std::move(blocks));
  n_ = 0;
  for (const RetainedBlock& b : *blocks_) n_ += b.width();
  for (Buffer& b : buffers_) {
    b.data = std::make_unique<double[]>(std::max<uint32_t>(n_, 1));
    b.seq.store(0, std::memory_order_relaxed);
  }
  latest_.store(kNone, std::memory_order_relaxed);
  taken_.store(0, std::memory_order_relaxed);
  next_ = 0;
}

uint32_t StateSnapshot::begin_take() noexcept {
  const uint32_t w = next_;
  Buffer& b = buffers_[w];
  // Odd: being written. The RMW's acquire half keeps the data stores below it.
  b.seq.fetch_add(1, std::memory_order_acq_rel);
  return w;
}

void StateSnapshot::store(uint32_t buffer, uint32_t i, double v) noexcept {
  std::atomic_ref<double>(buffers_[buffer].data[i]).store(v, std::memory_order_release);
}

void StateSnapshot::end_take(uint32_t buffer, uint64_t cycle, int64_t now_ns) noexcept {
  Buffer& b = buffers_[buffer];
  b.cycle.store(cycle, std::memory_order_release);
  b.taken_ns.store(now_ns, std::memory_order_release);
  b.seq.store(b.seq.load(std::memory_order_relaxed) + 1, std::memory_order_release);
  latest_.store(buffer, std::memory_order_release);
  taken_.fetch_add(1, std::memory_order_release);
  next_ = buffer ^ 1u;
}

void StateSnapshot::take(const TaskArena& arena, int64_t now_ns) noexcept {
  if (blocks_->empty()) return;
  const uint32_t w = begin_take();
  uint32_t i = 0;
  for (const RetainedBlock& rb : *blocks_) {
    if (rb.value != RetainedBlock::kNoValue) {
      for (uint32_t k = 0; k < rb.n_value; ++k) store(w, i++, arena.values[rb.value + k]);
    }
    for (uint32_t k = 0; k < rb.n_state; ++k) store(w, i++, arena.state[rb.state + k]);
  }
  end_take(w, arena.cycles, now_ns);
}

void StateSnapshot::take_watch(const TaskArena& arena, const StatusLane& lane, int64_t now_ns) noexcept {
  if (blocks_->empty()) return;
  const uint32_t w = begin_take();
  uint32_t i = 0;
  for (const RetainedBlock& rb : *blocks_) {
    for (uint32_t k = 0; k < rb.n_value; ++k) store(w, i++, arena.values[rb.value + k]);
    store(w, i++, rb.value < lane.values.size() ? static_cast<double>(lane.values[rb.value]) : 0.0);
  }
  end_take(w, arena.cycles, now_ns);
}

bool StateSnapshot::read(std::vector<double>& out, uint64_t& cycle, int64_t& taken_ns,
                         uint32_t max_tries) const {
  out.resize(n_);
  for (uint32_t attempt = 0; attempt < max_tries; ++attempt) {
    const uint32_t w = latest_.load(std::memory_order_acquire);
    if (w == kNone) return false;
    const Buffer& b = buffers_[w];
    const uint64_t s1 = b.seq.load(std::memory_order_acquire);
    if (s1 & 1u) continue;  // the writer lapped us and is refilling this buffer
    for (uint32_t i = 0; i < n_; ++i) {
      out[i] = std::atomic_ref<double>(b.data[i]).load(std::memory_order_acquire);
    }
    const uint64_t c = b.cycle.load(std::memory_order_acquire);
    const int64_t t = b.taken_ns.load(std::memory_order_acquire);
    if (b.seq.load(std::memory_order_relaxed) == s1) {
      cycle = c;
      taken_ns = t;
      return true;
    }
  }
  return false;
}

namespace {

// "F10" selects "F10" and everything expanded under it ("F10.M4", "F10.c2").
bool selects(const std::string& wanted, std::string_view block) {
  if (block.size() < wanted.size() || block.compare(0, wanted.size(), wanted) != 0) return false;
  return block.size() == wanted.size() || block[wanted.size()] == '.';
}

// The opcode's name in lower case ("intg"), built once: every retained block
// points at it instead of holding a copy.
std::string_view lower_op_name(Op op) {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (uint32_t o = 0; o < kOpCount; ++o) {
      std::string n = op_name(static_cast<Op>(o));
      for (char& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      v.push_back(std::move(n));
    }
    return v;
  }();
  return names[static_cast<uint32_t>(op)];
}

}  // namespace

std::vector<RetainedBlock> watched_blocks(const TaskImage& image) {
  std::vector<RetainedBlock> out;
  const auto code = image.code();
  const auto blocks = image.blocks();
  std::vector<uint32_t> order(blocks.size());
  for (uint32_t i = 0; i < blocks.size(); ++i) order[blocks[i].text_index] = i;
  for (uint32_t i : order) {
    const Instr& in = code[i];
    if (!op_writes_value(in.op) || op_is_load(in.op) || in.out >= image.header().n_values) continue;
    RetainedBlock rb;
    rb.name = std::string(image.str(blocks[i].name));
    rb.kind = lower_op_name(in.op);
    rb.value = in.out;
    // A string's whole text (watched_blocks' readers show it as text).
    const double* prepared = op_param_count(in.op) ? image.params().data() + in.param : nullptr;
    // A variable's string (its end-of-cycle copy, an scopy) whole; a string
    // temporary only its length: nobody reads its text, and the task copies
    // less.
    rb.n_value = in.op == Op::SCopy ? op_value_width(in.op, prepared) : 1;
    if (rb.n_value > image.header().n_values - in.out) continue;
    rb.wide = writes_wide_string(in, prepared);
    rb.n_state = 1;  // the status, see take_watch
    out.push_back(std::move(rb));
  }
  return out;
}

std::vector<RetainedBlock> retained_blocks(const TaskImage& image, bool all,
                                           const std::vector<std::string>& names,
                                           std::vector<std::string>* unknown) {
  std::vector<RetainedBlock> out;
  std::vector<bool> used(names.size(), false);
  const auto code = image.code();
  const auto blocks = image.blocks();
  // A block's last output is state only where a cycle reads it back: the
  // blocks whose output is their state (y += ..., a filter's y, a ramp, a
  // lead-lag's previous output) and every value some block reads from the
  // previous cycle (a delayed reference). Any other output is recomputed from
  // its inputs in the first cycle, so keeping it would cost memory for nothing.
  std::vector<bool> read_next_cycle(image.header().n_values, false);
  for (const Instr& in : code) {
    if (op_is_load(in.op)) continue;
    for (uint32_t k = 0; k < in.n_in; ++k) {
      if ((in.flags & (kInstrDelayed0 << k)) != 0 && in.in[k] < read_next_cycle.size()) read_next_cycle[in.in[k]] = true;
    }
  }
  auto output_is_state = [&](const Instr& in) {
    return op_output_is_state(in.op) ||
           (in.out < read_next_cycle.size() && read_next_cycle[in.out]);
  };
  // Textual order, so the state file reads like the program.
  std::vector<uint32_t> order(blocks.size());
  for (uint32_t i = 0; i < blocks.size(); ++i) order[blocks[i].text_index] = i;
  for (uint32_t i : order) {
    const Instr& in = code[i];
    const std::string_view name = image.str(blocks[i].name);
    bool wanted = all;
    for (size_t k = 0; k < names.size(); ++k) {
      if (selects(names[k], name)) {
        wanted = true;
        used[k] = true;
      }
    }
    if (!wanted) continue;
    const double* prepared = op_param_count(in.op) ? image.params().data() + in.param : nullptr;
    const uint32_t n_state = op_state_size(in.op, prepared);
    // Inputs and set-points are not the program's state: their loads read the
    // image again in the first cycle (set-points have their own retain file).
    const bool value = op_writes_value(in.op) && !op_is_load(in.op) && output_is_state(in);
    if (n_state == 0 && !value) continue;
    RetainedBlock rb;
    rb.name = std::string(name);
    rb.kind = lower_op_name(in.op);
    rb.value = value ? in.out : RetainedBlock::kNoValue;
    rb.n_value = op_value_width(in.op, prepared);
    rb.state = in.state;
    rb.n_state = n_state;
    out.push_back(std::move(rb));
  }
  if (unknown != nullptr) {
    for (size_t k = 0; k < names.size(); ++k) {
      if (!used[k]) unknown->push_back(names[k]);
    }
  }
  return out;
}

}  // namespace rtplc::sched
