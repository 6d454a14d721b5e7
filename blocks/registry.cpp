// The 58 primitive blocks of the spec (fbd-language.md); `good`, which the seed
// lacks: a program's view of its inputs' quality; and the IEC 61131-3 set
// (add_iec_blocks). Every contract written here is what the executor implements
// (blocks/executor.cpp) and what docs/blocks.md says.
#include "blocks/registry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "common/capacities.h"
#include "common/diagnostic.h"

namespace rtplc {
namespace {

constexpr double kBig = 1e300;  // "any finite value"
constexpr Kind A = Kind::kAnalog;
constexpr Kind D = Kind::kDigital;
constexpr Kind S = Kind::kString;

ParamSpec param(const char* name, const char* meaning, double min = -kBig, double max = kBig,
                bool min_exclusive = false, bool integer = false) {
  return ParamSpec{name, meaning, 0.0, false, min, max, min_exclusive, integer};
}
ParamSpec gain() { return ParamSpec{"k", "gain", 1.0, true, -kBig, kBig, false, false}; }

BlockSpec device_in(const char* name, IoGroup io, char dev, Kind out, const char* summary) {
  BlockSpec b{};
  b.name = name;
  b.group = BlockGroup::kInput;
  b.signature = Signature::kDeviceIn;
  b.io = io;
  b.device_kind = dev;
  b.has_output = true;
  b.out_kind = out;
  b.state = "";
  b.summary = summary;
  b.contract = out == A ? "y = the channel's value in this cycle's input snapshot"
                        : "y = the channel's value in this cycle's input snapshot (0 or 1)";
  b.errors = "a non-finite value from the driver: y holds, error counted";
  return b;
}

BlockSpec setpoint(const char* name, Kind out, const char* summary) {
  BlockSpec b = device_in(name, IoGroup::kSetp, 0, out, summary);
  b.signature = Signature::kSetpoint;
  b.contract = out == A ? "y = the set-point; starts at init (or its retained value), "
                          "changed by the operator (`rtplc set LABEL VALUE`)"
                        : "y = the digital set-point (0 or 1); starts at init (or its retained "
                          "value), changed by the operator";
  b.errors = "";
  return b;
}

BlockSpec device_out(const char* name, IoGroup io, char dev, Kind in, const char* summary) {
  BlockSpec b{};
  b.name = name;
  b.group = BlockGroup::kOutput;
  b.signature = Signature::kDeviceOut;
  b.io = io;
  b.device_kind = dev;
  b.has_output = false;
  b.out_kind = in;
  b.min_inputs = b.max_inputs = 1;
  b.input_kind[0] = in;
  b.input_names[0] = "value";
  b.state = "";
  b.summary = summary;
  b.contract = "the channel takes `value` at the end of the cycle (one writer per channel)";
  b.errors = "";
  return b;
}

struct In {
  const char* name;
  Kind kind;
};

BlockSpec compute(const char* name, BlockGroup g, Kind out, std::initializer_list<In> ins,
                  std::initializer_list<ParamSpec> ps, const char* state, const char* summary,
                  const char* contract, const char* errors = "") {
  BlockSpec b{};
  b.name = name;
  b.group = g;
  b.signature = Signature::kCompute;
  b.io = IoGroup::kNone;
  b.has_output = true;
  b.out_kind = out;
  uint8_t i = 0;
  for (const In& in : ins) {
    b.input_kind[i] = in.kind;
    b.input_names[i] = in.name;
    ++i;
  }
  b.min_inputs = b.max_inputs = i;
  uint8_t j = 0;
  for (const ParamSpec& p : ps) b.params[j++] = p;
  b.param_count = j;
  b.state = state;
  b.summary = summary;
  b.contract = contract;
  b.errors = errors;
  return b;
}

constexpr const char* kHold = "a non-finite result: y holds its previous value, error counted";

// The IEC 61131-3 set the PLCopen importer lowers standard functions and blocks
// to (lang/iec/), callable from FBD text as well. Values are doubles: an integer
// type is a double holding an integer, kept in range by `wrap` (docs/language.md,
// "IEC 61131-3 types and standard blocks", says where this differs from a PLC).
ParamSpec bits_param() {
  return ParamSpec{
      "bits", "width in bits (8, 16, 32, 64 for the IEC types)", 16, true, 1, 64, false, true};
}

void add_iec_blocks(std::vector<BlockSpec>& r) {
  using G = BlockGroup;
  struct Cmp {
    const char* name;
    const char* summary;
    const char* contract;
  };
  for (Cmp c : {Cmp{"gt", "greater than (IEC GT)", "y = 1 if a > b, else 0"},
                Cmp{"ge", "greater or equal (IEC GE)", "y = 1 if a >= b, else 0"},
                Cmp{"lt", "less than (IEC LT)", "y = 1 if a < b, else 0"},
                Cmp{"le", "less or equal (IEC LE)", "y = 1 if a <= b, else 0"},
                Cmp{"eq", "equal (IEC EQ)", "y = 1 if a == b (exact, as doubles), else 0"},
                Cmp{"ne", "not equal (IEC NE)", "y = 1 if a != b (exact, as doubles), else 0"}}) {
    r.push_back(compute(c.name, G::kIec, D, {{"a", A}, {"b", A}}, {}, "", c.summary, c.contract));
  }
  r.push_back(compute("const", G::kIec, A, {}, {param("v", "the value")}, "", "analog constant",
                      "y = v every cycle (FBD has no literal inputs; a constant an operator may "
                      "change is an `asp`)"));
  r.push_back(compute("dconst", G::kIec, D, {},
                      {param("v", "the value, 0 or 1", 0, 1, false, true)}, "", "digital constant",
                      "y = v every cycle"));
  r.push_back(compute("d2a", G::kIec, A, {{"a", D}}, {}, "", "digital to analog (BOOL_TO_*)",
                      "y = 1 if a is true, else 0"));
  r.push_back(compute("a2d", G::kIec, D, {{"a", A}}, {}, "", "analog to digital (*_TO_BOOL)",
                      "y = 1 if a != 0, else 0"));
  r.push_back(compute("mod", G::kIec, A, {{"a", A}, {"b", A}}, {}, "", "remainder (IEC MOD)",
                      "y = a - b*trunc(a/b): the sign of the dividend a (-7 mod 2 = -1); "
                      "b = 0 gives 0, as the standard's definition of MOD says (not an error)"));
  r.push_back(compute("trunc", G::kIec, A, {{"a", A}}, {}, "", "truncation (IEC TRUNC)",
                      "y = a rounded toward zero"));
  r.push_back(compute("round", G::kIec, A, {{"a", A}}, {}, "", "rounding (REAL_TO_INT and kin)",
                      "y = a rounded to the nearest integer, an exact half to the even one (2.5 -> 2, "
                      "3.5 -> 4, -2.5 -> -2), as MatIEC's REAL_TO_INT"));
  r.push_back(compute("neg", G::kIec, A, {{"a", A}}, {}, "", "negation (IEC NEG)", "y = -a"));
  r.push_back(compute("expt", G::kIec, A, {{"a", A}, {"b", A}}, {}, "", "power (IEC EXPT)",
                      "y = a^b",
                      "a < 0 with a non-integer b, 0 to a negative power, or overflow: y holds, "
                      "error counted"));
  r.push_back(compute("ln", G::kIec, A, {{"a", A}}, {}, "", "natural logarithm (IEC LN)",
                      "y = ln(a)", "a <= 0: y holds, error counted"));
  r.push_back(compute("log", G::kIec, A, {{"a", A}}, {}, "", "decimal logarithm (IEC LOG)",
                      "y = log10(a)", "a <= 0: y holds, error counted"));
  r.push_back(compute("exp", G::kIec, A, {{"a", A}}, {}, "", "exponential (IEC EXP)", "y = e^a",
                      kHold));
  r.push_back(compute(
      "wrap", G::kIec, A, {{"a", A}},
      {bits_param(),
       ParamSpec{"signed", "1 for SINT..LINT, 0 for USINT..ULINT", 1, true, 0, 1, false, true}},
      "", "integer overflow (the IEC integer types)",
      "y = trunc(a) reduced modulo 2^bits into the type's range: [-2^(bits-1), 2^(bits-1)) when "
      "signed, [0, 2^bits) when not (wrap(32768, 16) = -32768); exact while |a| < 2^53, "
      "beyond that a double cannot hold every LINT/ULINT value"));
  r.push_back(compute(
      "imul", G::kIec, A, {{"a", A}, {"b", A}},
      {bits_param(),
       ParamSpec{"signed", "1 for SINT..LINT, 0 for USINT..ULINT", 1, true, 0, 1, false, true}},
      "", "integer multiplication (MUL on the IEC integer types)",
      "y = trunc(a) * trunc(b) reduced as wrap does, computed in 64-bit integers: exact for every "
      "value of a type of up to 32 bits, where mult's double product loses bits past 2^53 "
      "(imul(4000000000, 3, 32, 0) = 3410065408)",
      "an operand that is not a number below 2^64: y holds, error counted"));
  const char* bit_note =
      "; operands are trunc(x) mod 2^bits, read as unsigned bit strings (BYTE 8, WORD 16, DWORD "
      "32, LWORD 64; above 2^53 doubles lose low bits)";
  static const std::string band_c = std::string("y = a AND b bit by bit") + bit_note;
  static const std::string bor_c = std::string("y = a OR b bit by bit") + bit_note;
  static const std::string bxor_c = std::string("y = a XOR b bit by bit") + bit_note;
  static const std::string bnot_c = std::string("y = the bits of a inverted") + bit_note;
  r.push_back(compute("band", G::kIec, A, {{"a", A}, {"b", A}}, {bits_param()}, "",
                      "bitwise AND (IEC AND on bit strings)", band_c.c_str()));
  r.push_back(compute("bor", G::kIec, A, {{"a", A}, {"b", A}}, {bits_param()}, "",
                      "bitwise OR (IEC OR on bit strings)", bor_c.c_str()));
  r.push_back(compute("bxor", G::kIec, A, {{"a", A}, {"b", A}}, {bits_param()}, "",
                      "bitwise XOR (IEC XOR on bit strings)", bxor_c.c_str()));
  r.push_back(compute("bnot", G::kIec, A, {{"a", A}}, {bits_param()}, "",
                      "bitwise NOT (IEC NOT on bit strings)", bnot_c.c_str()));
  const char* n_note = "; n = trunc(n), a negative n shifts by 0";
  static const std::string shl_c =
      std::string("y = a shifted left by n within `bits` bits, zeros in; n >= bits gives 0") +
      n_note;
  static const std::string shr_c =
      std::string("y = a shifted right by n, zeros in (logical); n >= bits gives 0") + n_note;
  static const std::string rol_c =
      std::string("y = a rotated left by n mod bits within `bits` bits") + n_note;
  static const std::string ror_c =
      std::string("y = a rotated right by n mod bits within `bits` bits") + n_note;
  r.push_back(compute("shl", G::kIec, A, {{"a", A}, {"n", A}}, {bits_param()}, "",
                      "shift left (IEC SHL)", shl_c.c_str()));
  r.push_back(compute("shr", G::kIec, A, {{"a", A}, {"n", A}}, {bits_param()}, "",
                      "shift right (IEC SHR)", shr_c.c_str()));
  r.push_back(compute("rol", G::kIec, A, {{"a", A}, {"n", A}}, {bits_param()}, "",
                      "rotate left (IEC ROL)", rol_c.c_str()));
  r.push_back(compute("ror", G::kIec, A, {{"a", A}, {"n", A}}, {bits_param()}, "",
                      "rotate right (IEC ROR)", ror_c.c_str()));
  r.push_back(compute("rtrig", G::kIec, D, {{"clk", D}}, {}, "M = clk last cycle",
                      "rising edge (IEC R_TRIG)",
                      "y = clk AND NOT M; M := clk. M starts false, so clk true in the first cycle "
                      "gives a pulse (as the standard's body and MatIEC)"));
  r.push_back(compute("ftrig", G::kIec, D, {{"clk", D}}, {}, "M = NOT clk last cycle",
                      "falling edge (IEC F_TRIG)",
                      "y = NOT clk AND NOT M; M := NOT clk. M starts false, so clk false in the "
                      "first cycle gives a pulse (the standard's body, literally)"));
  r.push_back(compute("sr", G::kIec, D, {{"s1", D}, {"r", D}}, {}, "its output",
                      "set-dominant bistable (IEC SR)", "y = s1 OR (NOT r AND y_prev), starts 0"));
  r.push_back(compute("rs", G::kIec, D, {{"s", D}, {"r1", D}}, {}, "its output",
                      "reset-dominant bistable (IEC RS)",
                      "y = NOT r1 AND (s OR y_prev), starts 0"));
  const char* timing =
      " Time is n*dt, n the task's cycles since the starting edge (0 in that cycle); PT is reached when "
      "n*dt >= PT within 1e-9*dt; PT < 0 acts as 0; PT is read at every call. Time is the cycle "
      "number, not the number of calls: called twice in one cycle (in a loop) both calls read one "
      "time; not called for some cycles (a loop that ran no iteration), its time ran on meanwhile "
      "with the inputs of its last call";
  static const std::string ton_c =
      std::string("on-delay, IEC TON's Q: y = in AND ET >= PT; ET counts while in is true, from 0 "
                  "in the cycle it rose, up to PT; in false resets it.") + timing;
  static const std::string tof_c =
      std::string("off-delay, IEC TOF's Q: y = 1 while in is true; after in falls ET counts from 0 "
                  "and y stays 1 until ET >= PT; starts 0 (in never true).") + timing;
  static const std::string tp_c =
      std::string("pulse, IEC TP's Q: a rising in (while no pulse runs) gives y = 1 for PT; not "
                  "retriggerable; in may fall during the pulse. Edge memory starts false.") +
      timing;
  static const std::string et_c =
      "the same state machine as the block without `_et` on the same inputs, giving ET in seconds: "
      "TON: 0 while in is false, min(elapsed, PT) while true; TOF: 0 while in is true, "
      "min(elapsed, PT) after it fell (0 before in was ever true); TP: elapsed during the "
      "pulse, PT after it while in stays true, else 0";
  r.push_back(compute("ton", G::kIec, D, {{"in", D}, {"pt", A}}, {}, "cycles in has been true, in, last call's cycle",
                      "on-delay timer Q (IEC TON)", ton_c.c_str()));
  r.push_back(compute("ton_et", G::kIec, A, {{"in", D}, {"pt", A}}, {}, "cycles in has been true, in, last call's cycle",
                      "on-delay timer ET (IEC TON)", et_c.c_str()));
  r.push_back(compute("tof", G::kIec, D, {{"in", D}, {"pt", A}}, {},
                      "cycles since in fell, armed, in, last call's cycle", "off-delay timer Q (IEC TOF)", tof_c.c_str()));
  r.push_back(compute("tof_et", G::kIec, A, {{"in", D}, {"pt", A}}, {},
                      "cycles since in fell, armed, in, last call's cycle", "off-delay timer ET (IEC TOF)", et_c.c_str()));
  r.push_back(compute("tp", G::kIec, D, {{"in", D}, {"pt", A}}, {},
                      "cycles since the pulse started, running, in at the last call, its cycle, its pt",
                      "pulse timer Q (IEC TP)", tp_c.c_str()));
  r.push_back(compute("tp_et", G::kIec, A, {{"in", D}, {"pt", A}}, {},
                      "cycles since the pulse started, running, in at the last call, its cycle, its pt",
                      "pulse timer ET (IEC TP)", et_c.c_str()));
  r.push_back(compute(
      "ctu", G::kIec, A, {{"cu", D}, {"r", D}},
      {ParamSpec{"pvmax", "highest count (INT: 32767)", 32767, true, -kBig, kBig, false, false}},
      "CV, cu last cycle", "up-counter CV (IEC CTU)",
      "IF r THEN CV := 0 ELSIF cu rose AND CV < pvmax THEN CV := CV + 1; y = CV. IEC's Q is "
      "ge(CV, PV). Edge memory starts false and follows cu every cycle, also while r is true"));
  r.push_back(compute(
      "ctd", G::kIec, A, {{"cd", D}, {"ld", D}, {"pv", A}},
      {ParamSpec{"pvmin", "lowest count (INT: -32768)", -32768, true, -kBig, kBig, false, false}},
      "CV, cd last cycle", "down-counter CV (IEC CTD)",
      "IF ld THEN CV := pv ELSIF cd rose AND CV > pvmin THEN CV := CV - 1; y = CV. IEC's Q is "
      "le(CV, 0)"));
  r.push_back(compute("updn", G::kIec, A, {{"cu", D}, {"cd", D}}, {}, "cu and cd last cycle",
                      "up/down edge step (for ctud)",
                      "y = +1 when cu rose and cd did not, -1 when cd rose and cu did not, else 0 "
                      "(IEC CTUD counts nothing when both rise)"));
  r.push_back(compute(
      "ctud", G::kIec, A, {{"step", A}, {"ld", D}, {"pv", A}},
      {ParamSpec{"pvmin", "lowest count (INT: -32768)", -32768, true, -kBig, kBig, false, false},
       ParamSpec{"pvmax", "highest count (INT: 32767)", 32767, true, -kBig, kBig, false, false}},
      "CV", "up/down counter CV (IEC CTUD, 5 inputs split over 3)",
      "IF ld THEN CV := pv ELSIF step > 0 AND CV < pvmax THEN CV := CV + 1 ELSIF step < 0 AND "
      "CV > pvmin THEN CV := CV - 1; y = CV. IEC CTUD(CU, CD, R, LD, PV) is step = updn(CU, CD), "
      "ld = R OR LD, pv = R ? 0 : PV; QU = ge(CV, PV), QD = le(CV, 0)"));
}

std::vector<BlockSpec> build_registry() {
  using G = BlockGroup;
  std::vector<BlockSpec> r;
  // --- Signal input (13) ---
  r.push_back(device_in("dai", IoGroup::kDio, 0, A, "direct analog input"));
  r.push_back(device_in("ddi", IoGroup::kDio, 0, D, "direct digital input"));
  r.push_back(device_in("dpi", IoGroup::kDio, 'P', A, "direct pulse input: pulses counted since start"));
  r.push_back(device_in("tra", IoGroup::kEpc, 0, A, "EPC (drive) read analog"));
  r.push_back(device_in("trd", IoGroup::kEpc, 0, D, "EPC (drive) read digital"));
  r.push_back(device_in("prx", IoGroup::kPlc, 'X', D, "PLC read X (input) bit"));
  r.push_back(device_in("pry", IoGroup::kPlc, 'Y', D, "PLC read Y (output) bit"));
  r.push_back(device_in("prm", IoGroup::kPlc, 'M', D, "PLC read M (internal relay) bit"));
  r.push_back(device_in("prr", IoGroup::kPlc, 'R', A, "PLC read register"));
  r.push_back(device_in("era", IoGroup::kEth, 0, A, "Ethernet (S7 PLC) read analog"));
  r.push_back(device_in("erd", IoGroup::kEth, 0, D, "Ethernet (S7 PLC) read digital"));
  r.push_back(setpoint("asp", A, "analog set-point"));
  r.push_back(setpoint("dsp", D, "digital set-point"));
  {
    // Not in the seed: the quality of what an input block reads, so a program
    // can switch to a safe branch when its measurement goes bad.
    BlockSpec g = compute("good", G::kInput, D, {{"input", A}}, {}, "",
                          "quality of an input: 1 while the channel an input block reads is good",
                          "y = 1 while the channel read by `input` (a device input block: dai, "
                          "prr, era, ...) is good or forced, 0 while it is bad or stale (a link "
                          "down, a value the driver cannot vouch for, a channel no driver feeds); "
                          "from the same input snapshot as the value",
                          "");
    g.reads_quality = true;
    r.push_back(g);
  }
  // --- Signal output (10) ---
  r.push_back(device_out("dao", IoGroup::kDio, 0, A, "direct analog output"));
  r.push_back(device_out("ddo", IoGroup::kDio, 0, D, "direct digital output"));
  r.push_back(device_out("twa", IoGroup::kEpc, 0, A, "EPC (drive) write analog"));
  r.push_back(device_out("twd", IoGroup::kEpc, 0, D, "EPC (drive) write digital"));
  r.push_back(device_out("pwx", IoGroup::kPlc, 'X', D, "PLC write X bit"));
  r.push_back(device_out("pwy", IoGroup::kPlc, 'Y', D, "PLC write Y bit"));
  r.push_back(device_out("pwm", IoGroup::kPlc, 'M', D, "PLC write M bit"));
  r.push_back(device_out("pwr", IoGroup::kPlc, 'R', A, "PLC write register"));
  r.push_back(device_out("ewa", IoGroup::kEth, 0, A, "Ethernet (S7 PLC) write analog"));
  r.push_back(device_out("ewd", IoGroup::kEth, 0, D, "Ethernet (S7 PLC) write digital"));
  // --- Arithmetic (16) ---
  r.push_back(compute("add", G::kArithmetic, A, {{"a", A}, {"b", A}}, {gain()}, "", "addition",
                      "y = k*(a + b)", kHold));
  r.push_back(compute("sub", G::kArithmetic, A, {{"a", A}, {"b", A}}, {gain()}, "", "subtraction",
                      "y = k*(a - b)", kHold));
  r.push_back(compute("mult", G::kArithmetic, A, {{"a", A}, {"b", A}}, {gain()}, "",
                      "multiplication", "y = k*a*b", kHold));
  r.push_back(compute("div", G::kArithmetic, A, {{"a", A}, {"b", A}}, {gain()}, "", "division",
                      "y = k*a/b", "b = 0 (or a non-finite result): y holds, error counted"));
  r.push_back(compute("abs", G::kArithmetic, A, {{"a", A}}, {}, "", "absolute value", "y = |a|"));
  r.push_back(compute("sqrt", G::kArithmetic, A, {{"a", A}}, {}, "", "square root",
                      "y = sqrt(a)", "a < 0: y holds, error counted"));
  r.push_back(compute("sin", G::kArithmetic, A, {{"a", A}}, {}, "", "sine (radians)", "y = sin(a)"));
  r.push_back(
      compute("cos", G::kArithmetic, A, {{"a", A}}, {}, "", "cosine (radians)", "y = cos(a)"));
  r.push_back(compute("tan", G::kArithmetic, A, {{"a", A}}, {}, "", "tangent (radians)",
                      "y = tan(a)", kHold));
  r.push_back(compute("asin", G::kArithmetic, A, {{"a", A}}, {}, "", "arc sine (radians)",
                      "y = asin(a)", "|a| > 1: y holds, error counted"));
  r.push_back(compute("acos", G::kArithmetic, A, {{"a", A}}, {}, "", "arc cosine (radians)",
                      "y = acos(a)", "|a| > 1: y holds, error counted"));
  r.push_back(compute("atan", G::kArithmetic, A, {{"a", A}}, {}, "", "arc tangent (radians)",
                      "y = atan(a)"));
  r.push_back(compute("max", G::kArithmetic, A, {{"a", A}, {"b", A}}, {}, "", "maximum",
                      "y = max(a, b)"));
  r.push_back(compute("min", G::kArithmetic, A, {{"a", A}, {"b", A}}, {}, "", "minimum",
                      "y = min(a, b)"));
  r.push_back(compute("inv", G::kArithmetic, A, {{"a", A}}, {}, "", "inverse", "y = 1/a",
                      "a = 0: y holds, error counted"));
  r.push_back(compute("scale", G::kArithmetic, A, {{"a", A}},
                      {param("k", "gain"), param("b", "offset")}, "", "linear scaling",
                      "y = k*a + b", kHold));
  // --- Logic (6) ---
  BlockSpec and_b = compute("and", G::kLogic, D, {{"a", D}, {"b", D}, {"c", D}}, {}, "",
                            "logical AND of 2 or 3 inputs", "y = a AND b [AND c]");
  and_b.min_inputs = 2;
  r.push_back(and_b);
  BlockSpec or_b = compute("or", G::kLogic, D, {{"a", D}, {"b", D}, {"c", D}}, {}, "",
                           "logical OR of 2 or 3 inputs", "y = a OR b [OR c]");
  or_b.min_inputs = 2;
  r.push_back(or_b);
  r.push_back(compute("not", G::kLogic, D, {{"a", D}}, {}, "", "logical NOT", "y = NOT a"));
  r.push_back(compute("exor", G::kLogic, D, {{"a", D}, {"b", D}}, {}, "", "exclusive OR",
                      "y = a XOR b"));
  r.push_back(compute(
      "time", G::kLogic, D, {{"in", D}}, {param("T", "delay (s)", 0)}, "cycles `in` has been true",
      "on-delay timer",
      "y becomes true once `in` has been true for T seconds (N = ceil(T/dt) cycles after the "
      "cycle it rose), and falls with `in`; T = 0 passes `in` through"));
  r.push_back(compute(
      "cnt", G::kLogic, D, {{"in", D}, {"reset", D}},
      {param("n", "preset count", 0, 1e9, false, true)}, "count, previous `in` (edge memory)",
      "up-counter (IEC CTU)",
      "counts rising edges of `in` (edge memory starts false and is updated every cycle); while "
      "`reset` is true the count is 0 and no edge is counted; y = count >= n"));
  // --- Control (13) ---
  BlockSpec lim = compute("lim", G::kControl, A, {{"a", A}},
                          {param("lo", "lower limit"), param("hi", "upper limit")}, "", "limiter",
                          "y = min(max(a, lo), hi); lo <= hi is checked at compile time");
  r.push_back(lim);
  r.push_back(compute("dzon", G::kControl, A, {{"a", A}}, {param("w", "half-width", 0)}, "",
                      "dead zone", "y = 0 if -w <= a <= w, else a - w*sign(a)"));
  r.push_back(compute(
      "dely", G::kControl, A, {{"a", A}},
      {param("n", "samples", 0, static_cast<double>(kMaxDelaySamples), false, true)},
      "the last n inputs", "pure delay of n samples",
      "y = a from n cycles ago (0 until n cycles have passed); n = 0 passes a through"));
  r.push_back(compute("intg", G::kControl, A, {{"a", A}},
                      {param("Ti", "integral time (s)", 0, kBig, true)}, "its output",
                      "integrator", "y += a*dt/Ti (backward Euler), starts at 0", kHold));
  BlockSpec derv = compute(
      "derv", G::kControl, A, {{"a", A}}, {param("Td", "derivative time (s)", 0)},
      "previous input", "derivative",
      "y = Td*(a - a_prev)/dt; the first cycle has no previous input and gives 0 (no start-up "
      "kick)",
      kHold);
  derv.alias = "deriv";
  r.push_back(derv);
  r.push_back(compute("filt", G::kControl, A, {{"a", A}},
                      {param("T", "time constant (s)", 0)}, "its output",
                      "first-order low-pass filter",
                      "y += dt/(T+dt)*(a - y), starts at 0; T = 0 passes a through", kHold));
  r.push_back(compute(
      "ldlg", G::kControl, A, {{"a", A}},
      {param("T1", "lead time (s)", 0), param("T2", "lag time (s)", 0)}, "previous input, its output",
      "lead-lag (T1 s + 1)/(T2 s + 1)",
      "Tustin discretisation: y = b0*a + b1*a_prev - a1*y_prev with b0 = (2T1/dt+1)/(2T2/dt+1), "
      "b1 = (1-2T1/dt)/(2T2/dt+1), a1 = (1-2T2/dt)/(2T2/dt+1); DC gain 1; starts at rest (0)",
      kHold));
  const char* pi_contract =
      "u = Kp*(e + I), I += e*dt/Ti (backward Euler, so I includes this cycle's e); Ti = 0 "
      "disables the integral. The integral is stored already divided by Ti, so a hot swap that "
      "changes Ti keeps u continuous";
  const char* pid_contract =
      "u = Kp*(e + I + Td*(e - e_prev)/dt), I += e*dt/Ti (backward Euler); Ti = 0 disables the "
      "integral; the first cycle has no previous error and its derivative term is 0";
  r.push_back(compute("pi", G::kControl, A, {{"sp", A}, {"pv", A}},
                      {param("Kp", "proportional gain"), param("Ti", "integral time (s)", 0)},
                      "integral", "PI controller, e = sp - pv", pi_contract, kHold));
  r.push_back(compute("epi", G::kControl, A, {{"e", A}},
                      {param("Kp", "proportional gain"), param("Ti", "integral time (s)", 0)},
                      "integral", "PI controller on an error input", pi_contract, kHold));
  r.push_back(compute("pid", G::kControl, A, {{"sp", A}, {"pv", A}},
                      {param("Kp", "proportional gain"), param("Ti", "integral time (s)", 0),
                       param("Td", "derivative time (s)", 0)},
                      "integral, previous error", "PID controller, e = sp - pv", pid_contract,
                      kHold));
  r.push_back(compute("epid", G::kControl, A, {{"e", A}},
                      {param("Kp", "proportional gain"), param("Ti", "integral time (s)", 0),
                       param("Td", "derivative time (s)", 0)},
                      "integral, previous error", "PID controller on an error input",
                      pid_contract, kHold));
  r.push_back(compute(
      "pidc", G::kControl, A, {{"sp", A}, {"pv", A}, {"fb", A}},
      {param("Kp", "proportional gain (negative: reverse acting)"),
       param("Ti", "integral time (s), 0 = no integral", 0), param("Td", "derivative time (s)", 0),
       param("lo", "lowest output"), param("hi", "highest output"),
       ParamSpec{"N", "derivative filter: Tf = Td/N", 10, true, 0, kBig, true, false},
       ParamSpec{"b", "set-point weight of P", 1, true, -kBig, kBig, false, false},
       ParamSpec{"c", "set-point weight of D (0: on the measurement)", 0, true, -kBig, kBig,
                 false, false}},
      "I, D, c*sp - pv, primed (and its output)",
      "PID to commission: limits, anti-windup, tracking (manual/auto), filtered D, weights",
      "u = clamp(P + I + D, lo, hi) with P = Kp*(b*sp - pv); I += Kp*dt/Ti*(sp - pv) except "
      "when that would drive u further beyond lo or hi (conditional integration: no windup); "
      "D = Tf/(Tf+dt)*D + Kp*Td/(Tf+dt)*(yd - yd_prev), yd = c*sp - pv, Tf = Td/N (0 in the first "
      "cycle: no start-up kick). fb is the value the actuator got last cycle: before each step I "
      "moves by fb - u_prev, so wiring fb to the block itself gives plain clamping, and wiring "
      "it to a manual/auto or tracking selector after the block (read last cycle) makes "
      "the output continue from the applied value: bumpless transfer both ways. lo <= hi is "
      "checked at compile time",
      kHold));
  r.push_back(compute("ramp", G::kControl, A, {{"target", A}},
                      {param("rate", "units per second", 0, kBig, true)}, "its output",
                      "rate limiter / ramp generator",
                      "y moves toward target by at most rate*dt per cycle, starts at 0"));
  r.push_back(compute("amux", G::kControl, A, {{"a", A}, {"b", A}, {"sel", D}}, {}, "",
                      "analog multiplexer", "y = sel ? b : a"));
  add_iec_blocks(r);
  return r;
}

const std::vector<BlockSpec>& registry() {
  static const std::vector<BlockSpec> r = build_registry();
  return r;
}

// The control-flow blocks the textual languages emit (ops.h, "Control flow").
// Not FBD blocks: find_block() does not know them, so no diagram can name one.
// A front end takes them from flow_block(); FlatBlock::target says which
// variable a set writes or which block a branch goes to.
std::vector<BlockSpec> build_flow_registry() {
  using G = BlockGroup;
  std::vector<BlockSpec> r;
  auto no_output = [](BlockSpec b) {
    b.has_output = false;
    return b;
  };
  const ParamSpec init{"init", "initial value", 0.0, true, -kBig, kBig, false, false};
  r.push_back(compute("var", G::kControl, A, {}, {init}, "its value", "an analog variable's home",
                      "y = init in the first cycle, then what the last set wrote"));
  r.push_back(compute("dvar", G::kControl, D, {}, {init}, "its value", "a digital variable's home",
                      "y = init in the first cycle, then what the last dset wrote"));
  r.push_back(no_output(compute("set", G::kControl, A, {{"value", A}}, {}, "", "assignment to a var",
                                "the var named by the block's target takes value")));
  r.push_back(no_output(compute("dset", G::kControl, D, {{"value", D}}, {}, "", "assignment to a dvar",
                                "the dvar named by the block's target takes value")));
  const ParamSpec lo{"lo", "the first index", 0.0, true, -1e15, 1e15, false, true};
  r.push_back(compute("pick", G::kControl, A, {{"index", A}}, {lo}, "", "an analog array element by index",
                      "y = the value of table[round(index) - lo], 0 outside the table"));
  r.push_back(compute("dpick", G::kControl, D, {{"index", A}}, {lo}, "", "a digital array element by index",
                      "y = the value of table[round(index) - lo], 0 outside the table"));
  r.push_back(no_output(compute("put", G::kControl, A, {{"index", A}, {"value", A}}, {lo}, "",
                                "write an analog array element by index",
                                "the var table[round(index) - lo] takes value; nothing outside the table")));
  r.push_back(no_output(compute("dput", G::kControl, D, {{"index", A}, {"value", D}}, {lo}, "",
                                "write a digital array element by index",
                                "the dvar table[round(index) - lo] takes value; nothing outside the table")));
  r.push_back(no_output(compute("jmp", G::kControl, D, {}, {}, "", "forward jump",
                                "execution continues at the target block")));
  r.push_back(no_output(compute("jz", G::kControl, D, {{"cond", D}}, {}, "", "forward jump if false",
                                "execution continues at the target block when cond is 0")));
  r.push_back(no_output(compute("jnz", G::kControl, D, {{"cond", D}}, {}, "", "forward jump if true",
                                "execution continues at the target block when cond is 1")));
  // Strings (ops.h, "Strings"): cap is the longest text a result holds.
  const ParamSpec cap{"cap", "the longest text it holds", 0.0, false, 0, kMaxStringLength, false, true};
  const ParamSpec type{"type", "the number's type (blocks/string_ops.h)", 0.0, false, 0, kStringFormats - 1, false, true};
  const ParamSpec dialect{"dialect", "0 MatIEC, 1 CODESYS", 0.0, false, 0, 1, false, true};
  const ParamSpec cmp{"op", "0 = 1 <> 2 < 3 <= 4 > 5 >=", 0.0, false, 0, 5, false, true};
  const ParamSpec wide{"wide", "1 for a WSTRING (UTF-16 code units)", 0.0, true, 0, 1, false, true};
  r.push_back(compute("sconst", G::kControl, S, {}, {wide}, "", "a string literal",
                      "y = the block's label (a WSTRING's: its UTF-8 as UTF-16 code units)"));
  r.push_back(compute("scopy", G::kControl, S, {{"s", S}}, {cap, wide}, "", "a string, cut to cap",
                      "y = s; into a STRING a code above 255 is '?'"));
  r.push_back(compute("ssel", G::kControl, S, {{"in0", S}, {"in1", S}, {"g", D}}, {cap}, "", "string select",
                      "y = g ? in1 : in0"));
  r.push_back(compute("scat", G::kControl, S, {{"s1", S}, {"s2", S}}, {cap}, "", "CONCAT", "y = s1 then s2"));
  r.push_back(compute("sleft", G::kControl, S, {{"s", S}, {"l", A}}, {cap}, "", "LEFT",
                      "y = the first l characters of s"));
  r.push_back(compute("sright", G::kControl, S, {{"s", S}, {"l", A}}, {cap}, "", "RIGHT",
                      "y = the last l characters of s"));
  r.push_back(compute("smid", G::kControl, S, {{"s", S}, {"l", A}, {"p", A}}, {cap}, "", "MID",
                      "y = l characters of s from position p"));
  r.push_back(compute("sins", G::kControl, S, {{"s1", S}, {"s2", S}, {"p", A}}, {cap}, "", "INSERT",
                      "y = s2 inserted into s1 after position p"));
  r.push_back(compute("sdel", G::kControl, S, {{"s", S}, {"l", A}, {"p", A}}, {cap}, "", "DELETE",
                      "y = s without l characters from position p"));
  r.push_back(compute("slen", G::kControl, A, {{"s", S}}, {}, "", "LEN", "y = the length of s"));
  r.push_back(compute("sfind", G::kControl, A, {{"s1", S}, {"s2", S}}, {}, "", "FIND",
                      "y = the position of s2 in s1, 0 when absent"));
  r.push_back(compute("scmp", G::kControl, D, {{"s1", S}, {"s2", S}}, {cmp}, "", "string comparison",
                      "y = s1 op s2, byte by byte, a prefix before the longer"));
  r.push_back(compute("sfmt", G::kControl, S, {{"x", A}}, {cap, type, dialect}, "", "a number as text",
                      "y = the text of x as its type"));
  r.push_back(compute("sparse", G::kControl, A, {{"s", S}}, {type, dialect}, "", "text as a number",
                      "y = the number s reads as"));
  r.push_back(compute("svar", G::kControl, S, {}, {cap}, "its value", "a string variable's home",
                      "y = '' in the first cycle, then what the last sset wrote"));
  r.push_back(no_output(compute("sset", G::kControl, S, {{"value", S}}, {cap}, "", "assignment to an svar",
                                "the svar named by the block's target takes value")));
  r.push_back(no_output(compute("loop", G::kControl, D, {}, {}, "", "backward jump",
                                "execution continues at the target block, at or before this one; "
                                "counted against the task's loop budget",
                                "past the budget the cycle ends and the task stops into its safe outputs")));
  return r;
}

}  // namespace

const BlockSpec* flow_block(std::string_view name) {
  static const std::vector<BlockSpec> r = build_flow_registry();
  for (const BlockSpec& b : r) {
    if (name == b.name) return &b;
  }
  return nullptr;
}

std::span<const BlockSpec> all_blocks() { return registry(); }

const BlockSpec* find_block(std::string_view name) {
  for (const BlockSpec& b : registry()) {
    if (name == b.name || (b.alias != nullptr && name == b.alias)) return &b;
  }
  return nullptr;
}

std::string suggest_block(std::string_view name) {
  std::string best;
  size_t best_d = 3;  // farther than 2 edits is no longer a typo
  for (const BlockSpec& b : registry()) {
    std::string lower(name);
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    size_t d = edit_distance(lower, b.name);
    if (d < best_d) {
      best_d = d;
      best = b.name;
    }
  }
  return best;
}

Op block_op(const BlockSpec& b, uint32_t n_inputs) {
  switch (b.signature) {
    case Signature::kDeviceIn:
    case Signature::kSetpoint:
      return b.out_kind == Kind::kAnalog ? Op::LoadA : Op::LoadD;
    case Signature::kDeviceOut:
      return b.out_kind == Kind::kAnalog ? Op::StoreA : Op::StoreD;
    case Signature::kCompute:
      break;
  }
  std::string_view n = b.name;
  struct Entry {
    const char* name;
    Op op;
  };
  static constexpr Entry kTable[] = {
      {"add", Op::Add},   {"sub", Op::Sub},   {"mult", Op::Mult}, {"div", Op::Div},
      {"abs", Op::Abs},   {"sqrt", Op::Sqrt}, {"sin", Op::Sin},   {"cos", Op::Cos},
      {"tan", Op::Tan},   {"asin", Op::Asin}, {"acos", Op::Acos}, {"atan", Op::Atan},
      {"max", Op::Max},   {"min", Op::Min},   {"inv", Op::Inv},   {"scale", Op::Scale},
      {"not", Op::Not},   {"exor", Op::Exor}, {"time", Op::Time}, {"cnt", Op::Cnt},
      {"lim", Op::Lim},   {"dzon", Op::Dzon}, {"dely", Op::Dely}, {"intg", Op::Intg},
      {"derv", Op::Derv}, {"filt", Op::Filt}, {"ldlg", Op::Ldlg}, {"pi", Op::Pi},
      {"epi", Op::Epi},   {"pid", Op::Pid},   {"epid", Op::Epid}, {"ramp", Op::Ramp},
      {"amux", Op::Amux}, {"good", Op::LoadD},
      {"gt", Op::Gt},     {"ge", Op::Ge},     {"lt", Op::Lt},     {"le", Op::Le},
      {"eq", Op::Eq},     {"ne", Op::Ne},     {"const", Op::ConstA}, {"dconst", Op::ConstD},
      {"d2a", Op::D2a},   {"a2d", Op::A2d},   {"mod", Op::Mod},   {"trunc", Op::Trunc},
      {"round", Op::Round}, {"neg", Op::Neg}, {"expt", Op::Expt}, {"ln", Op::Ln},
      {"log", Op::Log},   {"exp", Op::Exp},   {"wrap", Op::Wrap}, {"imul", Op::Imul}, {"band", Op::Band},
      {"bor", Op::Bor},   {"bxor", Op::Bxor}, {"bnot", Op::Bnot}, {"shl", Op::Shl},
      {"shr", Op::Shr},   {"rol", Op::Rol},   {"ror", Op::Ror},   {"rtrig", Op::Rtrig},
      {"ftrig", Op::Ftrig}, {"sr", Op::Sr},   {"rs", Op::Rs},     {"ton", Op::Ton},
      {"ton_et", Op::TonEt}, {"tof", Op::Tof}, {"tof_et", Op::TofEt}, {"tp", Op::Tp},
      {"tp_et", Op::TpEt}, {"ctu", Op::Ctu},  {"ctd", Op::Ctd},   {"updn", Op::Updn},
      {"ctud", Op::Ctud}, {"pidc", Op::Pidc},
      {"var", Op::Var},   {"dvar", Op::Var},  {"set", Op::Set},   {"dset", Op::Set},
      {"jmp", Op::Jmp},   {"jz", Op::Jz},     {"jnz", Op::Jnz},   {"loop", Op::Loop},
      {"pick", Op::Pick}, {"dpick", Op::Pick}, {"put", Op::Put},  {"dput", Op::Put},
      {"sconst", Op::SConst}, {"scopy", Op::SCopy}, {"ssel", Op::SSel}, {"scat", Op::SCat},
      {"sleft", Op::SLeft}, {"sright", Op::SRight}, {"smid", Op::SMid}, {"sins", Op::SIns},
      {"sdel", Op::SDel}, {"slen", Op::SLen}, {"sfind", Op::SFind}, {"scmp", Op::SCmp},
      {"sfmt", Op::SFmt}, {"sparse", Op::SParse}, {"svar", Op::SVar}, {"sset", Op::SSet},
  };
  if (n == "and") return n_inputs == 3 ? Op::And3 : Op::And2;
  if (n == "or") return n_inputs == 3 ? Op::Or3 : Op::Or2;
  for (const Entry& e : kTable) {
    if (n == e.name) return e.op;
  }
  return Op::Add;  // unreachable for registry entries; covered by a test
}

const char* group_name(BlockGroup g) {
  switch (g) {
    case BlockGroup::kInput: return "Signal input";
    case BlockGroup::kOutput: return "Signal output";
    case BlockGroup::kArithmetic: return "Arithmetic";
    case BlockGroup::kLogic: return "Logic";
    case BlockGroup::kControl: return "Control";
    case BlockGroup::kIec: return "IEC 61131-3";
  }
  return "?";
}

const char* io_group_name(IoGroup g) {
  switch (g) {
    case IoGroup::kNone: return "-";
    case IoGroup::kDio: return "DIO";
    case IoGroup::kEpc: return "EPC";
    case IoGroup::kPlc: return "PLC";
    case IoGroup::kEth: return "ETH";
    case IoGroup::kSetp: return "SETP";
  }
  return "?";
}

const char* kind_name(Kind k) {
  return k == Kind::kAnalog ? "analog" : k == Kind::kDigital ? "digital" : "string";
}

void prepare_params(Op op, std::span<const double> p, double dt, double* out) {
  auto at = [&](size_t i) { return i < p.size() ? p[i] : 0.0; };
  if (op_is_string(op)) {
    // As written (SConst's text is laid out by the compiler from its label).
    for (uint32_t k = 0; k < op_param_count(op) && op != Op::SConst; ++k) out[k] = at(k);
    return;
  }
  switch (op) {
    case Op::Add: case Op::Sub: case Op::Mult: case Op::Div:
      out[0] = p.empty() ? 1.0 : p[0];
      break;
    case Op::Scale: case Op::Lim:
      out[0] = at(0);
      out[1] = at(1);
      break;
    case Op::Dzon: case Op::Dely: case Op::Cnt:
      out[0] = at(0);
      break;
    case Op::Time:
      // Counting cycles avoids accumulating floating-point time; the small slack
      // keeps T = 0.3 at dt = 0.1 at 3 cycles rather than 4.
      out[0] = std::ceil(at(0) / dt - 1e-9);
      if (out[0] < 0) out[0] = 0;
      break;
    case Op::Intg:
      out[0] = dt / at(0);
      break;
    case Op::Derv:
      out[0] = at(0) / dt;
      break;
    case Op::Filt:
      out[0] = dt / (at(0) + dt);
      break;
    case Op::Ldlg: {
      double n1 = 2.0 * at(0) / dt, n2 = 2.0 * at(1) / dt;
      out[0] = (n1 + 1.0) / (n2 + 1.0);
      out[1] = (1.0 - n1) / (n2 + 1.0);
      out[2] = (1.0 - n2) / (n2 + 1.0);
      break;
    }
    case Op::Pi: case Op::Epi:
      out[0] = at(0);
      out[1] = at(1) > 0 ? dt / at(1) : 0.0;
      break;
    case Op::Pid: case Op::Epid:
      out[0] = at(0);
      out[1] = at(1) > 0 ? dt / at(1) : 0.0;
      out[2] = at(2) / dt;
      break;
    case Op::Ramp:
      out[0] = at(0) * dt;
      break;
    case Op::ConstA: case Op::ConstD: case Op::Ctu: case Op::Ctd: case Op::Var:
      out[0] = at(0);
      break;
    case Op::Ctud:
      out[0] = at(0);
      out[1] = at(1);
      break;
    case Op::Ton: case Op::TonEt: case Op::Tof: case Op::TofEt: case Op::Tp: case Op::TpEt:
      out[0] = dt;
      break;
    case Op::Pidc: {
      // Kp, Ti, Td, lo, hi, N, b, c -> Kp, Kp*dt/Ti, Tf/(Tf+dt), Kp*Td/(Tf+dt), b, c, lo, hi.
      const double kp = at(0), ti = at(1), td = at(2), n = p.size() > 5 ? p[5] : 10.0;
      const double tf = n > 0 ? td / n : 0.0;
      out[0] = kp;
      out[1] = ti > 0 ? kp * dt / ti : 0.0;
      out[2] = tf / (tf + dt);
      out[3] = kp * td / (tf + dt);
      out[4] = p.size() > 6 ? p[6] : 1.0;
      out[5] = at(7);
      out[6] = at(3);
      out[7] = at(4);
      break;
    }
    case Op::Wrap: case Op::Imul: {
      const double m = std::ldexp(1.0, static_cast<int>(at(0)));
      out[0] = m;
      out[1] = at(1) != 0.0 ? m / 2 : m;  // where a value starts to read as negative
      break;
    }
    case Op::Band: case Op::Bor: case Op::Bxor: case Op::Bnot:
    case Op::Shl: case Op::Shr: case Op::Rol: case Op::Ror:
      out[0] = std::ldexp(1.0, static_cast<int>(at(0)));
      out[1] = at(0);
      break;
    default:
      break;
  }
}

}  // namespace rtplc
