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
    case Op::ConstA: case Op::ConstD:
    case Op::Ton: case Op::TonEt: case Op::Tof: case Op::TofEt: case Op::Tp: case Op::TpEt:
    case Op::Ctu: case Op::Ctd: case Op::Var:
      return 1;
    case Op::Scale: case Op::Lim: case Op::Pi: case Op::Epi: case Op::Wrap: case Op::Imul: case Op::Pick: case Op::Put:
    case Op::Band: case Op::Bor: case Op::Bxor: case Op::Bnot:
    case Op::Shl: case Op::Shr: case Op::Rol: case Op::Ror: case Op::Ctud:
      return 2;
    case Op::Ldlg: case Op::Pid: case Op::Epid:
      return 3;
    case Op::Pidc:
      return 8;
    default:
      return 0;
  }
}

uint32_t instr_param_count(Op op, const double* prepared) {
  const uint32_t fixed = op_param_count(op);
  if ((op == Op::Pick || op == Op::Put) && prepared != nullptr) {
    return fixed + static_cast<uint32_t>(prepared[0]);
  }
  return fixed;
}

uint32_t op_state_size(Op op, const double* prepared) {
  switch (op) {
    case Op::Time: case Op::Ldlg: case Op::Pi: case Op::Epi:
    case Op::Rtrig: case Op::Ftrig: case Op::Ctud: case Op::Var:
      return 1;
    case Op::Cnt: case Op::Derv:
    case Op::Ctu: case Op::Ctd: case Op::Updn:
      return 2;
    case Op::Pid: case Op::Epid: case Op::Ton: case Op::TonEt:
      return 3;
    case Op::Pidc: case Op::Tof: case Op::TofEt:
      return 4;
    case Op::Tp: case Op::TpEt:
      return 5;
    case Op::Dely:
      // [0] = next ring index, [1..n] = ring. n was range-checked before prepare.
      return prepared == nullptr ? 1 : 1 + static_cast<uint32_t>(prepared[0]);
    default:
      return 0;
  }
}

uint32_t op_input_count(Op op) {
  switch (op) {
    case Op::LoadA: case Op::LoadD: case Op::ConstA: case Op::ConstD:
    case Op::Var: case Op::Jmp: case Op::Loop:
      return 0;
    case Op::Add: case Op::Sub: case Op::Mult: case Op::Div:
    case Op::Max: case Op::Min: case Op::And2: case Op::Or2: case Op::Exor:
    case Op::Pi: case Op::Pid: case Op::Cnt:
    case Op::Gt: case Op::Ge: case Op::Lt: case Op::Le: case Op::Eq: case Op::Ne:
    case Op::Mod: case Op::Expt: case Op::Band: case Op::Bor: case Op::Bxor:
    case Op::Shl: case Op::Shr: case Op::Rol: case Op::Ror: case Op::Sr: case Op::Rs:
    case Op::Ton: case Op::TonEt: case Op::Tof: case Op::TofEt: case Op::Tp: case Op::TpEt:
    case Op::Ctu: case Op::Updn: case Op::Put: case Op::Imul:
      return 2;
    case Op::And3: case Op::Or3: case Op::Amux: case Op::Ctd: case Op::Ctud:
    case Op::Pidc:
      return 3;
    default:
      return 1;
  }
}

bool op_writes_value(Op op) { return !op_is_store(op) && op != Op::Set && op != Op::Put && !op_is_branch(op); }
bool op_is_branch(Op op) { return op == Op::Jmp || op == Op::Jz || op == Op::Jnz || op == Op::Loop; }
bool op_output_is_state(Op op) {
  return op == Op::Intg || op == Op::Filt || op == Op::Ramp || op == Op::Ldlg || op == Op::Var;
}
bool op_is_load(Op op) { return op == Op::LoadA || op == Op::LoadD; }
bool op_is_store(Op op) { return op == Op::StoreA || op == Op::StoreD; }

bool op_output_digital(Op op) {
  switch (op) {
    case Op::LoadD: case Op::StoreD:
    case Op::And2: case Op::And3: case Op::Or2: case Op::Or3:
    case Op::Not: case Op::Exor: case Op::Time: case Op::Cnt:
    case Op::Gt: case Op::Ge: case Op::Lt: case Op::Le: case Op::Eq: case Op::Ne:
    case Op::ConstD: case Op::A2d: case Op::Rtrig: case Op::Ftrig: case Op::Sr: case Op::Rs:
    case Op::Ton: case Op::Tof: case Op::Tp:
      return true;
    default:
      return false;
  }
}

}  // namespace rtplc
