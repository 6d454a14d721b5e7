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
    case Op::SConst: case Op::SSel: case Op::SCat: case Op::SLeft: case Op::SRight:
    case Op::SMid: case Op::SIns: case Op::SDel: case Op::SCmp: case Op::SVar: case Op::SSet:
      return 1;
    case Op::Scale: case Op::Lim: case Op::Pi: case Op::Epi: case Op::Wrap: case Op::Imul: case Op::Pick: case Op::Put:
    case Op::Band: case Op::Bor: case Op::Bxor: case Op::Bnot:
    case Op::Shl: case Op::Shr: case Op::Rol: case Op::Ror: case Op::Ctud: case Op::SParse: case Op::SCopy:
      return 2;
    case Op::Ldlg: case Op::Pid: case Op::Epid: case Op::SFmt:
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
  if (op == Op::SConst && prepared != nullptr) return fixed + static_cast<uint32_t>(prepared[0]);
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
    case Op::Var: case Op::Jmp: case Op::Loop: case Op::SConst: case Op::SVar:
      return 0;
    case Op::Add: case Op::Sub: case Op::Mult: case Op::Div:
    case Op::Max: case Op::Min: case Op::And2: case Op::Or2: case Op::Exor:
    case Op::Pi: case Op::Pid: case Op::Cnt:
    case Op::Gt: case Op::Ge: case Op::Lt: case Op::Le: case Op::Eq: case Op::Ne:
    case Op::Mod: case Op::Expt: case Op::Band: case Op::Bor: case Op::Bxor:
    case Op::Shl: case Op::Shr: case Op::Rol: case Op::Ror: case Op::Sr: case Op::Rs:
    case Op::Ton: case Op::TonEt: case Op::Tof: case Op::TofEt: case Op::Tp: case Op::TpEt:
    case Op::Ctu: case Op::Updn: case Op::Put: case Op::Imul:
    case Op::SCat: case Op::SLeft: case Op::SRight: case Op::SFind: case Op::SCmp:
      return 2;
    case Op::And3: case Op::Or3: case Op::Amux: case Op::Ctd: case Op::Ctud:
    case Op::Pidc: case Op::SSel: case Op::SMid: case Op::SIns: case Op::SDel:
      return 3;
    default:
      return 1;
  }
}

bool op_writes_value(Op op) {
  return !op_is_store(op) && op != Op::Set && op != Op::Put && op != Op::SSet && !op_is_branch(op);
}
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
    case Op::Ton: case Op::Tof: case Op::Tp: case Op::SCmp:
      return true;
    default:
      return false;
  }
}

bool op_output_string(Op op) {
  switch (op) {
    case Op::SConst: case Op::SCopy: case Op::SSel: case Op::SCat: case Op::SLeft: case Op::SRight:
    case Op::SMid: case Op::SIns: case Op::SDel: case Op::SFmt: case Op::SVar:
      return true;
    default:
      return false;
  }
}

bool op_input_is_string(Op op, uint32_t k) {
  switch (op) {
    case Op::SCopy: case Op::SLeft: case Op::SRight: case Op::SMid: case Op::SDel: case Op::SLen:
    case Op::SParse: case Op::SSet:
      return k == 0;
    case Op::SCat: case Op::SIns: case Op::SFind: case Op::SCmp: case Op::SSel:
      return k <= 1;
    default:
      return false;
  }
}

uint32_t op_value_width(Op op, const double* prepared) {
  if (!op_output_string(op) || prepared == nullptr) return 1;
  return 1 + static_cast<uint32_t>(prepared[0]);
}

}  // namespace rtplc
