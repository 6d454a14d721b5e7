// The executor's instruction set: one opcode per primitive block semantics.
// One line per opcode (Lua's lopcodes.h idea). V = value arena, S = state arena,
// P = prepared parameter pool (coefficients already folded with dt), IN/OUT = the
// task's I/O buffers. "err" = the block's error counter increments and its output
// (and state) hold their previous values; nothing non-finite is ever stored.
//
//  op        operands           semantics                                        P (prepared)        S
//  LoadA     out <- IN[in0]     analog input / set-point                           -                   -
//  LoadD     out <- IN[in0]     digital input / set-point (normalised 0/1)         -                   -
//  StoreA    OUT[out] <- in0    analog output                                      -                   -
//  StoreD    OUT[out] <- in0    digital output (normalised 0/1)                    -                   -
//  Add       k*(a+b)                                                               k                   -
//  Sub       k*(a-b)                                                               k                   -
//  Mult      k*a*b                                                                 k                   -
//  Div       k*a/b              b == 0 -> err                                      k                   -
//  Abs Sqrt Sin Cos Tan Asin Acos Atan   f(a)   domain error -> err                -                   -
//  Max Min   max/min(a,b)                                                          -                   -
//  Inv       1/a                a == 0 -> err                                      -                   -
//  Scale     k*a+b                                                                 k b                 -
//  And2 And3 Or2 Or3 Not Exor   boolean                                            -                   -
//  Time      on-delay           true once in held true N cycles                    N                   count
//  Cnt       up-counter         rising edges of in, reset has priority             n                   count edge
//  Lim       clamp(a,lo,hi)                                                        lo hi               -
//  Dzon      dead zone                                                             w                   -
//  Dely      a from n samples ago                                                  n                   idx ring[n]
//  Intg      y += a*dt/Ti                                                          dt/Ti               (y = own output)
//  Derv      Td*(a-a')/dt       first cycle outputs 0                              Td/dt               a' primed
//  Filt      y += dt/(T+dt)*(a-y)                                                  alpha               (y = own output)
//  Ldlg      Tustin (T1 s+1)/(T2 s+1)                                              b0 b1 a1            x'
//  Pi Epi    Kp*(e + I), I += e*dt/Ti                                              Kp dt/Ti            I
//  Pid Epid  Kp*(e + I + Td*(e-e')/dt)                                             Kp dt/Ti Td/dt      I e' primed
//  Ramp      y moves to target by <= rate*dt                                       rate*dt             (y = own output)
//  Amux      sel ? b : a                                                           -                   -
// IEC 61131-3 set (docs/language.md, "IEC 61131-3 types and standard blocks"):
//  Gt Ge Lt Le Eq Ne   a OP b -> 0/1                                               -                   -
//  ConstA ConstD       y = v (no inputs)                                           v                   -
//  D2a A2d   kind change: y = (a != 0)                                             -                   -
//  Mod       a - b*trunc(a/b) (fmod), b == 0 -> 0                                  -                   -
//  Trunc Round Neg     toward zero / nearest, ties to even / -a                    -                   -
//  Expt Ln Log Exp     a^b, ln a, log10 a, e^a    domain error -> err              -                   -
//  Wrap      trunc(a) wrapped into the integer type's range                        2^bits half         -
//  Imul      trunc(a)*trunc(b) wrapped as Wrap, in 64-bit integers (exact)          2^bits half         -
//  Band Bor Bxor Bnot  bitwise on trunc(a) mod 2^bits                              2^bits bits         -
//  Shl Shr Rol Ror     shift/rotate a by n bits within `bits`                      2^bits bits         -
//  Rtrig Ftrig         edge of in (IEC R_TRIG / F_TRIG)                            -                   M
//  Sr Rs     bistables, set / reset dominant                                       -                   (y = own output)
//  Ton Tof Tp          IEC timers' Q; *Et the same machine's ET (s); time is the   dt                  e [armed|running]
//                      cycle number, so calls in one cycle read one time                           in last [pt]
//  Ctu Ctd   counter value CV (IEC CTU / CTD)                                      pvmax | pvmin       cv edge
//  Updn      +1 on a rising cu, -1 on a rising cd, 0 otherwise or both             -                   edges
//  Ctud      CV of IEC CTUD from updn's step, load, pv                             pvmin pvmax         cv
//  Pidc      commissioning PID: limits, conditional integration, tracking of the   Kp ki ad bd         I D' y' primed
//            applied output fb, filtered derivative, set-point weights b, c        b c lo hi           (u' = own output)
// Control flow (the textual languages' variables, branches and loops; docs/st.md,
// "Loops"). A branch is alone in its run and names a *run* index in `out`:
//  Var       a variable's home slot: holds until a Set writes it; v in the first   v                   primed
//            cycle (its output is its state, as Intg's)
//  Set       V[out] <- in0; `out` is a Var's slot (Set has no slot of its own)     -                   -
//  Jmp       continue at run `out`, forward                                        -                   -
//  Jz Jnz    continue at run `out`, forward, when in0 == 0 / in0 != 0              -                   -
//  Loop      continue at run `out` <= its own (a backward edge): one iteration of  -                   -
//            the task's per-cycle budget; past it the cycle ends and the task
//            faults (ExecContext::loop_fault)
//  Pick      y = V[table[k]], k = round(in0) - lo; 0 when k is outside the table   n lo table[n]       -
//  Put       V[table[k]] <- in1, k as Pick; each table slot a Var's; nothing when   n lo table[n]       -
//            k is outside (an array element written through an index known only
//            at run time)
// Strings (docs/st.md, "Strings"). A string value takes 1 + cap value slots from
// `out` on: V[out] is its length n (0..cap), V[out+1+i] the code of character
// i < n: a byte (0..255) of a STRING, a UTF-16 code unit (0..65535) of a
// WSTRING. P[0] is cap (SConst: its length). s1 s2 = string inputs;
// positions are 1-based, as the standard's; a result longer than cap is cut.
//  SConst    y = the literal                                                  n codes[n]          -
//  SCopy     y = s1; into a STRING (P[1] = 0) a code above 255 is '?'         cap wide            -
//  SSel      y = in2 ? s2 : s1 (in2 numeric; Amux's layout)                  cap                 -
//  SCat      y = s1 then s2 (CONCAT)                                          cap                 -
//  SLeft SRight   y = the first / last in1 characters of s1                   cap                 -
//  SMid      y = in1 characters of s1 from position in2                       cap                 -
//  SIns      y = s2 inserted into s1 after position in2                       cap                 -
//  SDel      y = s1 without in1 characters from position in2                  cap                 -
//  SLen      y = the length of s1                                             -                   -
//  SFind     y = the position of s2 in s1, 0 when it is not there             -                   -
//  SCmp      y = s1 OP s2 byte-wise, OP = P[0]: 0 = 1 <> 2 < 3 <= 4 > 5 >=     op                  -
//  SFmt      y = the text of number in0 as type P[1], dialect P[2]            cap type dialect    -
//            (blocks/string_ops.h)
//  SParse    y = the number text s1 reads as type P[0], dialect P[1]          type dialect        -
//  SVar      a string variable's home in a loop: holds until an SSet writes   cap                 -
//  SSet      the SVar at `out` takes s1 (cut to its cap P[0])                 cap                 -
#pragma once

#include <cstdint>

namespace rtplc {

#define RTPLC_OPS(X)                                                                       \
  X(LoadA) X(LoadD) X(StoreA) X(StoreD)                                                    \
  X(Add) X(Sub) X(Mult) X(Div) X(Abs) X(Sqrt) X(Sin) X(Cos) X(Tan) X(Asin) X(Acos) X(Atan) \
  X(Max) X(Min) X(Inv) X(Scale)                                                            \
  X(And2) X(And3) X(Or2) X(Or3) X(Not) X(Exor) X(Time) X(Cnt)                              \
  X(Lim) X(Dzon) X(Dely) X(Intg) X(Derv) X(Filt) X(Ldlg) X(Pi) X(Epi) X(Pid) X(Epid)       \
  X(Ramp) X(Amux)                                                                          \
  X(Gt) X(Ge) X(Lt) X(Le) X(Eq) X(Ne) X(ConstA) X(ConstD) X(D2a) X(A2d)                     \
  X(Mod) X(Trunc) X(Round) X(Neg) X(Expt) X(Ln) X(Log) X(Exp) X(Wrap)                       \
  X(Band) X(Bor) X(Bxor) X(Bnot) X(Shl) X(Shr) X(Rol) X(Ror)                                \
  X(Rtrig) X(Ftrig) X(Sr) X(Rs) X(Ton) X(TonEt) X(Tof) X(TofEt) X(Tp) X(TpEt)               \
  X(Ctu) X(Ctd) X(Updn) X(Ctud) X(Pidc)                                                    \
  X(Var) X(Set) X(Jmp) X(Jz) X(Jnz) X(Loop) X(Pick) X(Put)                                 \
  X(Imul)                                                                                  \
  X(SConst) X(SCopy) X(SSel) X(SCat) X(SLeft) X(SRight) X(SMid) X(SIns) X(SDel)            \
  X(SLen) X(SFind) X(SCmp) X(SFmt) X(SParse) X(SVar) X(SSet)

enum class Op : uint8_t {
#define RTPLC_OP_ENUM(name) name,
  RTPLC_OPS(RTPLC_OP_ENUM)
#undef RTPLC_OP_ENUM
};

inline constexpr uint8_t kOpCount = 0
#define RTPLC_OP_COUNT(name) +1
    RTPLC_OPS(RTPLC_OP_COUNT)
#undef RTPLC_OP_COUNT
    ;

const char* op_name(Op op);

// Prepared parameters an instruction of this opcode reads from the pool (for
// Pick and Put, the fixed part: n and lo; their table of n slots follows).
uint32_t op_param_count(Op op);
// All the parameters one instruction reads: op_param_count, plus the table of
// Pick and Put, whose length is their first prepared parameter `p[0]`.
uint32_t instr_param_count(Op op, const double* prepared);
inline constexpr uint32_t kMaxPickTable = 4096;  // elements of one array

// State doubles the opcode needs; for Dely it depends on its prepared n, passed in
// `prepared_params` (may be null for every other op).
uint32_t op_state_size(Op op, const double* prepared_params);

// How many value-slot inputs the opcode reads (LoadA/LoadD read the I/O buffer instead).
uint32_t op_input_count(Op op);

bool op_writes_value(Op op);   // false for the two stores
bool op_is_load(Op op);
bool op_is_store(Op op);
bool op_output_digital(Op op);
// The opcodes whose result is a string (ops.h, "Strings"): their value takes
// op_value_width() slots.
bool op_output_string(Op op);
// Value slots one instruction's result takes: 1, or 1 + cap for a string
// (`prepared` its prepared parameters, P[0] = cap).
uint32_t op_value_width(Op op, const double* prepared);
// The string opcodes (SConst .. SSet): never in an affine run.
inline bool op_is_string(Op op) { return op >= Op::SConst && op <= Op::SSet; }
// Whether input k of `op` reads a string (the head of a string result).
bool op_input_is_string(Op op, uint32_t k);
// SFmt's and SParse's formats (blocks/string_ops.h), 0 .. kStringFormats - 1.
inline constexpr uint32_t kStringFormats = 10;
// The longest string a value may hold (its cap), in characters.
inline constexpr uint32_t kMaxStringLength = 1024;

// The opcodes whose semantics is one kernel over an accessor (blocks/kernels.inc),
// with the prepared parameters (NP) and state doubles (NS) one instruction reads:
// the interpreter dispatches them alike and the native code calls their kernels.
#define RTPLC_KERNEL_OPS(X) \
  X(Add, 1, 0) X(Sub, 1, 0) X(Mult, 1, 0) X(Div, 1, 0) X(Abs, 0, 0) \
  X(Sqrt, 0, 0) X(Sin, 0, 0) X(Cos, 0, 0) X(Tan, 0, 0) X(Asin, 0, 0) \
  X(Acos, 0, 0) X(Atan, 0, 0) X(Max, 0, 0) X(Min, 0, 0) X(Inv, 0, 0) \
  X(Scale, 2, 0) X(And2, 0, 0) X(And3, 0, 0) X(Or2, 0, 0) X(Or3, 0, 0) \
  X(Not, 0, 0) X(Exor, 0, 0) X(Time, 1, 1) X(Cnt, 1, 2) X(Lim, 2, 0) \
  X(Dzon, 1, 0) X(Intg, 1, 0) X(Derv, 1, 2) X(Filt, 1, 0) X(Ldlg, 3, 1) \
  X(Pi, 2, 1) X(Epi, 2, 1) X(Pid, 3, 3) X(Epid, 3, 3) X(Ramp, 1, 0) \
  X(Amux, 0, 0) X(Gt, 0, 0) X(Ge, 0, 0) X(Lt, 0, 0) X(Le, 0, 0) \
  X(Eq, 0, 0) X(Ne, 0, 0) X(ConstA, 1, 0) X(ConstD, 1, 0) X(D2a, 0, 0) \
  X(A2d, 0, 0) X(Mod, 0, 0) X(Trunc, 0, 0) X(Round, 0, 0) X(Neg, 0, 0) \
  X(Expt, 0, 0) X(Ln, 0, 0) X(Log, 0, 0) X(Exp, 0, 0) X(Wrap, 2, 0) \
  X(Imul, 2, 0) X(Band, 2, 0) X(Bor, 2, 0) X(Bxor, 2, 0) X(Bnot, 2, 0) \
  X(Shl, 2, 0) X(Shr, 2, 0) X(Rol, 2, 0) X(Ror, 2, 0) X(Rtrig, 0, 1) \
  X(Ftrig, 0, 1) X(Sr, 0, 0) X(Rs, 0, 0) X(Ctu, 1, 2) X(Ctd, 1, 2) \
  X(Updn, 0, 2) X(Ctud, 2, 1) X(Pidc, 8, 4)

// Jmp, Jz, Jnz, Loop: instructions that choose the next run.
bool op_is_branch(Op op);
// The opcodes whose output is also their state (read back next cycle): the
// integrator, filter, ramp, lead-lag, and a variable's home.
bool op_output_is_state(Op op);

}  // namespace rtplc
