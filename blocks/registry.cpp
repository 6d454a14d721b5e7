// The 58 primitive blocks of the spec (fbd-language.md), and `good`, which the
// seed lacks: a program's view of its inputs' quality. Every contract written here is
// what the executor implements (blocks/executor.cpp) and what docs/blocks.md says.
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
  r.push_back(compute("ramp", G::kControl, A, {{"target", A}},
                      {param("rate", "units per second", 0, kBig, true)}, "its output",
                      "rate limiter / ramp generator",
                      "y moves toward target by at most rate*dt per cycle, starts at 0"));
  r.push_back(compute("amux", G::kControl, A, {{"a", A}, {"b", A}, {"sel", D}}, {}, "",
                      "analog multiplexer", "y = sel ? b : a"));
  return r;
}

const std::vector<BlockSpec>& registry() {
  static const std::vector<BlockSpec> r = build_registry();
  return r;
}

}  // namespace

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

const char* kind_name(Kind k) { return k == Kind::kAnalog ? "analog" : "digital"; }

void prepare_params(Op op, std::span<const double> p, double dt, double* out) {
  auto at = [&](size_t i) { return i < p.size() ? p[i] : 0.0; };
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
    default:
      break;
  }
}

}  // namespace rtplc
