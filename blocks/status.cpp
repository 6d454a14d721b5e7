// The status lane's pass (see status.h).
#include "blocks/status.h"

#include <algorithm>

namespace rtplc {

StatusRule op_status_rule(Op op) {
  switch (op) {
    case Op::LoadA:
    case Op::LoadD:
      return StatusRule::kLoad;
    case Op::StoreA:
    case Op::StoreD:
      return StatusRule::kStore;
    case Op::ConstA:
    case Op::ConstD:
    case Op::SConst:
      return StatusRule::kSource;
    case Op::Amux:
    case Op::SSel:
      return StatusRule::kSelect;
    case Op::And2:
    case Op::And3:
      return StatusRule::kAnd;
    case Op::Or2:
    case Op::Or3:
      return StatusRule::kOr;
    case Op::Var:
    case Op::SVar:
      return StatusRule::kVar;
    case Op::Set:
    case Op::SSet:
      return StatusRule::kSet;
    case Op::Pick:
      return StatusRule::kPick;
    case Op::Put:
      return StatusRule::kPut;
    case Op::Jmp:
    case Op::Jz:
    case Op::Jnz:
    case Op::Loop:
      return StatusRule::kBranch;
    default:
      return StatusRule::kWorst;
  }
}

void StatusLane::resize_for(const TaskImage& image) {
  const ImageHeader& h = image.header();
  // Nothing is vouched for before the first read of the inputs.
  in.assign(h.n_io_in, static_cast<uint8_t>(Lane::kBad));
  values.assign(h.n_values, static_cast<uint8_t>(Lane::kGood));
  out.assign(h.n_io_out, static_cast<uint8_t>(Lane::kBad));
  errors_seen.assign(h.n_instr, 0);
  rule.resize(h.n_instr);
  const std::span<const Instr> code = image.code();
  n_vars = 0;
  has_flow = false;
  for (size_t i = 0; i < code.size() && i < rule.size(); ++i) {
    const StatusRule r = op_status_rule(code[i].op);
    rule[i] = static_cast<uint8_t>(r);
    n_vars += r == StatusRule::kVar;
    has_flow = has_flow || r == StatusRule::kVar || r == StatusRule::kSet || r == StatusRule::kBranch ||
               r == StatusRule::kPut;
  }
  errors_at_pass = 0;
  settled = false;
  in_dirty = true;
}

bool propagate_status(const TaskImage& image, const TaskArena& arena, StatusLane& lane) noexcept {
  const std::span<const Instr> code = image.code();
  if (lane.values.size() != arena.values.size() || lane.errors_seen.size() != code.size() ||
      arena.errors.size() != code.size() || lane.rule.size() != code.size()) {
    return true;  // not sized for this image: nothing can be vouched for
  }
  uint8_t* st = lane.values.data();
  const double* v = arena.values.data();
  uint8_t worst_value = 0;
  bool any_output_not_good = false;
  // Error counters only move when their sum does: most passes skip them.
  const bool erred = arena.total_errors != lane.errors_at_pass;
  lane.in_dirty = false;
  const bool flow = lane.has_flow;
  if (flow) {
    for (size_t i = 0; i < code.size(); ++i) {
      if (static_cast<StatusRule>(lane.rule[i]) == StatusRule::kVar) st[code[i].out] = 0;
    }
  }
  const uint32_t max_rounds = flow ? 2 * lane.n_vars + 1 : 1;
  for (uint32_t round = 0; round < max_rounds; ++round) {
    bool var_worsened = false;
    for (size_t i = 0; i < code.size(); ++i) {
      const Instr& I = code[i];
      uint8_t s = 0;
      auto rule = static_cast<StatusRule>(lane.rule[i]);
      if (flow && (rule == StatusRule::kSelect || rule == StatusRule::kAnd || rule == StatusRule::kOr)) {
        rule = StatusRule::kWorst;
      }
      switch (rule) {
        case StatusRule::kLoad:
          s = lane.in[I.in[0]];
          break;
        case StatusRule::kStore:
          lane.out[I.out] = st[I.in[0]];
          any_output_not_good |= st[I.in[0]] != 0;
          continue;
        case StatusRule::kSource:
          break;
        case StatusRule::kSelect: {
          const uint8_t sa = st[I.in[0]], sb = st[I.in[1]], ssel = st[I.in[2]];
          uint8_t branch = std::max(sa, sb);
          // The selector's value as the block read it: a delayed selector's slot
          // already holds this cycle's value, so then both branches count.
          if ((I.flags & kInstrDelayed2) == 0) branch = v[I.in[2]] != 0.0 ? sb : sa;
          s = std::max(ssel, branch);
          break;
        }
        case StatusRule::kAnd:
        case StatusRule::kOr: {
          // The value a good input must have to decide the result by itself.
          const bool decisive = rule == StatusRule::kOr;
          bool decided = false;
          for (uint32_t k = 0; k < I.n_in && k < 3; ++k) {
            s = std::max(s, st[I.in[k]]);
            // (a delayed input read last cycle's value, which its slot no longer holds)
            const bool delayed = (I.flags & (kInstrDelayed0 << k)) != 0;
            decided |= !delayed && st[I.in[k]] == 0 && (v[I.in[k]] != 0.0) == decisive;
          }
          if (decided) s = 0;
          break;
        }
        case StatusRule::kWorst:
          for (uint32_t k = 0; k < I.n_in && k < 3; ++k) s = std::max(s, st[I.in[k]]);
          break;
        case StatusRule::kVar:
          // Its status is what the Sets wrote into it (reset above); the
          // initial value itself is a constant.
          if (erred && arena.errors[i] != lane.errors_seen[i]) lane.errors_seen[i] = arena.errors[i];
          worst_value = std::max(worst_value, st[I.out]);
          continue;
        case StatusRule::kSet:
          if (st[I.in[0]] > st[I.out]) {
            st[I.out] = st[I.in[0]];
            var_worsened = true;
          }
          worst_value = std::max(worst_value, st[I.out]);
          continue;
        case StatusRule::kPick: {
          const double* P = image.params().data() + I.param;
          s = st[I.in[0]];
          for (uint32_t k = 0; k < static_cast<uint32_t>(P[0]); ++k) s = std::max(s, st[static_cast<uint32_t>(P[2 + k])]);
          break;
        }
        case StatusRule::kPut: {
          const double* P = image.params().data() + I.param;
          const uint8_t w = std::max(st[I.in[0]], st[I.in[1]]);
          for (uint32_t k = 0; k < static_cast<uint32_t>(P[0]); ++k) {
            uint8_t& t = st[static_cast<uint32_t>(P[2 + k])];
            if (w > t) {
              t = w;
              var_worsened = true;
            }
            worst_value = std::max(worst_value, t);
          }
          continue;
        }
        case StatusRule::kBranch:
          if (erred && arena.errors[i] != lane.errors_seen[i]) lane.errors_seen[i] = arena.errors[i];
          continue;
      }
      // A block that erred this cycle held its last value: usable, not current.
      if (erred && arena.errors[i] != lane.errors_seen[i]) {
        lane.errors_seen[i] = arena.errors[i];
        s = std::max(s, static_cast<uint8_t>(Lane::kUncertain));
      }
      // A later round never makes a value better than an earlier one found it
      // (the error mark above is seen in the first round only).
      if (round > 0) s = std::max(s, st[I.out]);
      st[I.out] = s;
      worst_value = std::max(worst_value, s);
    }
    if (!var_worsened) break;
  }
  lane.errors_at_pass = arena.total_errors;
  lane.settled = worst_value == 0 && !any_output_not_good;
  return any_output_not_good;
}

}  // namespace rtplc
