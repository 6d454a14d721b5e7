// State migration for hot swap (spec runtime.md, "Hot swap", step 2).
#include "sched/program.h"

#include <atomic>

#include <algorithm>
#include <string_view>
#include <unordered_map>

namespace rtplc::sched {

namespace {
std::atomic<uint64_t> g_live_programs{0};
}  // namespace

LoadedProgram::LoadedProgram() { g_live_programs.fetch_add(1, std::memory_order_relaxed); }
LoadedProgram::~LoadedProgram() { g_live_programs.fetch_sub(1, std::memory_order_relaxed); }
uint64_t LoadedProgram::live_count() { return g_live_programs.load(std::memory_order_relaxed); }

namespace {

// Adjacent single copies become one ranged copy: migrating a 10,000-block task
// whose layout did not change is then a handful of block moves.
void push_copy(std::vector<Migration::Copy>& v, uint32_t from, uint32_t to, uint32_t len) {
  if (len == 0) return;
  if (!v.empty()) {
    Migration::Copy& last = v.back();
    if (last.from + last.len == from && last.to + last.len == to) {
      last.len += len;
      return;
    }
  }
  v.push_back({from, to, len});
}

uint32_t state_size(const TaskImage& img, const Instr& in) {
  return op_state_size(in.op, op_param_count(in.op) ? img.params().data() + in.param : nullptr);
}

uint32_t value_width(const TaskImage& img, const Instr& in) {
  return op_value_width(in.op, op_param_count(in.op) ? img.params().data() + in.param : nullptr);
}

}  // namespace

Migration plan_migration(const TaskImage& old_image, const TaskImage& next) {
  Migration m;
  m.active = true;
  struct Old {
    uint32_t index;
    bool used;
  };
  std::unordered_map<std::string_view, Old> by_name;
  const auto old_blocks = old_image.blocks();
  for (uint32_t i = 0; i < old_blocks.size(); ++i) {
    by_name.emplace(old_image.str(old_blocks[i].name), Old{i, false});
  }
  const auto new_blocks = next.blocks();
  // Walk in textual order so the report reads like the program.
  std::vector<uint32_t> order(new_blocks.size());
  for (uint32_t i = 0; i < new_blocks.size(); ++i) order[new_blocks[i].text_index] = i;
  for (uint32_t i : order) {
    const Instr& ni = next.code()[i];
    const std::string_view name = next.str(new_blocks[i].name);
    const uint32_t n_state = state_size(next, ni);
    auto it = by_name.find(name);
    if (it == by_name.end()) {
      m.added.emplace_back(name);
      continue;
    }
    it->second.used = true;
    const Instr& oi = old_image.code()[it->second.index];
    const bool same = oi.op == ni.op && state_size(old_image, oi) == n_state &&
                      value_width(old_image, oi) == value_width(next, ni);
    if (!same) {
      if (n_state > 0 || op_writes_value(ni.op)) m.reset.emplace_back(name);
      continue;
    }
    if (op_writes_value(ni.op)) push_copy(m.values, oi.out, ni.out, value_width(next, ni));
    push_copy(m.state, oi.state, ni.state, n_state);
    if (n_state > 0 || op_writes_value(ni.op)) m.kept.emplace_back(name);
  }
  for (const auto& [name, old] : by_name) {
    if (!old.used) m.removed.emplace_back(name);
  }
  std::sort(m.removed.begin(), m.removed.end());
  return m;
}

void apply_migration(const Migration& m, const TaskArena& from, TaskArena& to) noexcept {
  for (const Migration::Copy& c : m.values) {
    std::copy_n(from.values.data() + c.from, c.len, to.values.data() + c.to);
  }
  for (const Migration::Copy& c : m.state) {
    std::copy_n(from.state.data() + c.from, c.len, to.state.data() + c.to);
  }
  to.cycles = from.cycles;
}

}  // namespace rtplc::sched
