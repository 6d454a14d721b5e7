// Opcode metadata shared by the compiler, the image verifier and the executor.
#include "blocks/ops.h"

namespace rtplc {

const char* op_name(Op op) {
  switch (op) {
#define RTPLC_OP_NAME(name) \
  case Op::name:            \
    return #name;
    RTPLC_OPS(RTPLC_OP_NAME)
#undef RTPLC_OP_NAME
  }
  return "?";
}

uint32_t op_param_count(Op op) {
  switch (op) {
    case Op::Add: case Op::Sub: case Op::Mult: case Op::Div:
    case Op::Dzon: case Op::Dely: case Op::Time: case Op::Cnt:
    case Op::Intg: case Op::Derv: case Op::Filt: case Op::Ramp:
      return 1;
    case Op::Scale: case Op::Lim: case Op::Pi: case Op::Epi:
      return 2;
    case Op::Ldlg: case Op::Pid: case Op::Epid:
      return 3;
    default:
      return 0;
  }
}

uint32_t op_state_size(Op op, const double* prepared) {
  switch (op) {
    case Op::Time: case Op::Ldlg: case Op::Pi: case Op::Epi:
      return 1;
    case Op::Cnt: case Op::Derv:
      return 2;
    case Op::Pid: case Op::Epid:
      return 3;
    case Op::Dely:
      // [0] = next ring index, [1..n] = ring. n was range-checked before prepare.
      return prepared == nullptr ? 1 : 1 + static_cast<uint32_t>(prepared[0]);
    default:
      return 0;
  }
}

uint32_t op_input_count(Op op) {
  switch (op) {
    case Op::LoadA: case Op::LoadD:
      return 0;
    case Op::Add: case Op::Sub: case Op::Mult: case Op::Div:
    case Op::Max: case Op::Min: case Op::And2: case Op::Or2: case Op::Exor:
    case Op::Pi: case Op::Pid: case Op::Cnt:
      return 2;
    case Op::And3: case Op::Or3: case Op::Amux:
      return 3;
    default:
      return 1;
  }
}

bool op_writes_value(Op op) { return op != Op::StoreA && op != Op::StoreD; }
bool op_is_load(Op op) { return op == Op::LoadA || op == Op::LoadD; }
bool op_is_store(Op op) { return op == Op::StoreA || op == Op::StoreD; }

bool op_output_digital(Op op) {
  switch (op) {
    case Op::LoadD: case Op::StoreD:
    case Op::And2: case Op::And3: case Op::Or2: case Op::Or3:
    case Op::Not: case Op::Exor: case Op::Time: case Op::Cnt:
      return true;
    default:
      return false;
  }
}

}  // namespace rtplc
