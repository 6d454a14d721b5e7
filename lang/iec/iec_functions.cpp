// The IEC 61131-3 standard functions and blocks, lowered to primitive blocks
// (lang/iec/iec_functions.h). Each lowering appends blocks through the Emitter
// and returns the producer of each formal output, in order.
#include "lang/iec/iec_functions.h"

#include <algorithm>
#include <cctype>
#include <initializer_list>
#include <unordered_map>

namespace rtplc::lang::iec {
namespace {

using Out = Result<std::vector<uint32_t>>;

uint32_t arg(const IecCall& c, size_t k) {
  return k < c.inputs.size() ? c.inputs[k] : kUnconnected;
}
bool wants(const IecCall& c, size_t k) {
  return c.wanted.empty() || (k < c.wanted.size() && c.wanted[k]);
}
Out one(uint32_t v) {
  return std::vector<uint32_t>{v};
}
size_t count(const IecFunction& f, const IecCall& c) {
  return f.extensible ? std::max(c.inputs.size(), f.inputs.size()) : f.inputs.size();
}

Result<void> numeric(const IecFunction& f, const IecCall& c) {
  if (c.type == IecType::kBool) return make_error(f.name + " takes numbers, not BOOL");
  return {};
}

// ---- arithmetic ----
Out chain(const IecFunction& f, Emitter& e, const IecCall& c, const char* prim, bool wrap,
          std::initializer_list<double> params = {}) {
  if (auto r = numeric(f, c); !r) return make_error(r.error());
  uint32_t acc = e.analog_or_zero(arg(c, 0));
  for (size_t k = 1; k < count(f, c); ++k) acc = e.block(prim, {acc, e.analog_or_zero(arg(c, k))}, params);
  return one(wrap ? e.wrap(acc, c.type) : acc);
}
Out lower_add(const IecFunction& f, Emitter& e, const IecCall& c) {
  return chain(f, e, c, "add", true);
}
// On an integer type every product is `imul`, exact in 64-bit integers and
// wrapped into the type (a double product rounds past 2^53 before any wrap).
Out lower_mul(const IecFunction& f, Emitter& e, const IecCall& c) {
  const IecTypeInfo& t = type_info(c.type);
  if (!t.integer || c.type == IecType::kBool) return chain(f, e, c, "mult", true);
  // imul wraps each product already; a lone operand is wrapped as a product would be.
  return chain(f, e, c, "imul", count(f, c) <= 1, {static_cast<double>(t.bits), t.is_signed ? 1.0 : 0.0});
}
Out lower_sub(const IecFunction& f, Emitter& e, const IecCall& c) {
  return chain(f, e, c, "sub", true);
}
// Integer DIV truncates toward zero: wrap() truncates before it wraps.
Out lower_div(const IecFunction& f, Emitter& e, const IecCall& c) {
  return chain(f, e, c, "div", true);
}
Out lower_mod(const IecFunction& f, Emitter& e, const IecCall& c) {
  return chain(f, e, c, "mod", false);
}
Out lower_expt(const IecFunction& f, Emitter& e, const IecCall& c) {
  return chain(f, e, c, "expt", false);
}
Out lower_max(const IecFunction& f, Emitter& e, const IecCall& c) {
  return chain(f, e, c, "max", false);
}
Out lower_min(const IecFunction& f, Emitter& e, const IecCall& c) {
  return chain(f, e, c, "min", false);
}

// One-input functions: the primitive is the lower-case name (ABS -> abs), except
// where `prim` says otherwise; ABS and NEG wrap on integers (ABS(-32768) = -32768).
Out unary(const IecFunction& f, Emitter& e, const IecCall& c, const char* prim, bool wrap) {
  if (auto r = numeric(f, c); !r) return make_error(r.error());
  const uint32_t v = e.block(prim, {e.analog_or_zero(arg(c, 0))});
  return one(wrap ? e.wrap(v, c.type) : v);
}
#define RTPLC_UNARY(fn, prim, wrap)                            \
  Out fn(const IecFunction& f, Emitter& e, const IecCall& c) { \
    return unary(f, e, c, prim, wrap);                         \
  }
RTPLC_UNARY(lower_abs, "abs", true)
RTPLC_UNARY(lower_neg, "neg", true)
RTPLC_UNARY(lower_sqrt, "sqrt", false)
RTPLC_UNARY(lower_ln, "ln", false)
RTPLC_UNARY(lower_log, "log", false)
RTPLC_UNARY(lower_exp, "exp", false)
RTPLC_UNARY(lower_sin, "sin", false)
RTPLC_UNARY(lower_cos, "cos", false)
RTPLC_UNARY(lower_tan, "tan", false)
RTPLC_UNARY(lower_asin, "asin", false)
RTPLC_UNARY(lower_acos, "acos", false)
RTPLC_UNARY(lower_atan, "atan", false)
#undef RTPLC_UNARY

Out lower_trunc(const IecFunction&, Emitter& e, const IecCall& c) {
  const uint32_t v = e.analog_or_zero(arg(c, 0));
  // TRUNC's result is an integer type; wrap() truncates, then keeps its range.
  return one(type_info(c.type).integer ? e.wrap(v, c.type) : e.block("trunc", {v}));
}

Out lower_move(const IecFunction&, Emitter& e, const IecCall& c) {
  const uint32_t v = arg(c, 0);
  if (v == kUnconnected) return one(e.constant(0, type_info(c.type).kind()));
  return one(v);
}

// ---- comparisons: GT(a, b, c) is a > b AND b > c ----
Out compare(const IecFunction& f, Emitter& e, const IecCall& c, const char* prim) {
  const size_t n = count(f, c);
  uint32_t acc = kUnconnected;
  for (size_t k = 0; k + 1 < n; ++k) {
    const uint32_t r =
        e.block(prim, {e.analog_or_zero(arg(c, k)), e.analog_or_zero(arg(c, k + 1))});
    acc = acc == kUnconnected ? r : e.block("and", {acc, r});
  }
  return one(acc);
}
Out lower_gt(const IecFunction& f, Emitter& e, const IecCall& c) {
  return compare(f, e, c, "gt");
}
Out lower_ge(const IecFunction& f, Emitter& e, const IecCall& c) {
  return compare(f, e, c, "ge");
}
Out lower_lt(const IecFunction& f, Emitter& e, const IecCall& c) {
  return compare(f, e, c, "lt");
}
Out lower_le(const IecFunction& f, Emitter& e, const IecCall& c) {
  return compare(f, e, c, "le");
}
Out lower_eq(const IecFunction& f, Emitter& e, const IecCall& c) {
  return compare(f, e, c, "eq");
}
Out lower_ne(const IecFunction& f, Emitter& e, const IecCall& c) {
  return compare(f, e, c, "ne");
}

// ---- selection ----
uint32_t as_type(Emitter& e, uint32_t v, IecType t) {
  return t == IecType::kBool ? e.digital(v) : v;
}

Out lower_sel(const IecFunction&, Emitter& e, const IecCall& c) {
  const uint32_t y = e.block("amux", {e.analog_or_zero(arg(c, 1)), e.analog_or_zero(arg(c, 2)),
                                      e.digital_or_false(arg(c, 0))});
  return one(as_type(e, y, c.type));
}

// MUX(K, IN0, ..., INn): a chain of amux on K = j; a K outside 0..n gives IN0.
Out lower_mux(const IecFunction& f, Emitter& e, const IecCall& c) {
  const size_t n = count(f, c);
  const uint32_t k = e.analog_or_zero(arg(c, 0));
  uint32_t acc = e.analog_or_zero(arg(c, 1));
  for (size_t j = 2; j < n; ++j) {
    const uint32_t is_j = e.block("eq", {k, e.constant(static_cast<double>(j - 1), Kind::kAnalog)});
    acc = e.block("amux", {acc, e.analog_or_zero(arg(c, j)), is_j});
  }
  return one(as_type(e, acc, c.type));
}

// LIMIT(MN, IN, MX) = MIN(MAX(IN, MN), MX).
Out lower_limit(const IecFunction&, Emitter& e, const IecCall& c) {
  const uint32_t lo = e.block("max", {e.analog_or_zero(arg(c, 1)), e.analog_or_zero(arg(c, 0))});
  return one(e.block("min", {lo, e.analog_or_zero(arg(c, 2))}));
}

// ---- logic: BOOL -> and/or/exor/not; bit strings and integers -> bitwise ----
Out logic(const IecFunction& f, Emitter& e, const IecCall& c, const char* bool_prim,
          const char* bit_prim) {
  const IecTypeInfo& t = type_info(c.type);
  const size_t n = count(f, c);
  if (c.type == IecType::kBool) {
    uint32_t acc = e.digital_or_false(arg(c, 0));
    for (size_t k = 1; k < n; ++k) acc = e.block(bool_prim, {acc, e.digital_or_false(arg(c, k))});
    return one(acc);
  }
  if (!t.integer)
    return make_error(f.name + " takes BOOL or a bit string (BYTE..LWORD), not " + t.name);
  uint32_t acc = e.analog_or_zero(arg(c, 0));
  for (size_t k = 1; k < n; ++k) {
    acc = e.block(bit_prim, {acc, e.analog_or_zero(arg(c, k))}, {static_cast<double>(t.bits)});
  }
  return one(t.bit_string ? acc : e.wrap(acc, c.type));  // AND on INT reads the result as INT again
}
Out lower_and(const IecFunction& f, Emitter& e, const IecCall& c) {
  return logic(f, e, c, "and", "band");
}
Out lower_or(const IecFunction& f, Emitter& e, const IecCall& c) {
  return logic(f, e, c, "or", "bor");
}
Out lower_xor(const IecFunction& f, Emitter& e, const IecCall& c) {
  return logic(f, e, c, "exor", "bxor");
}
Out lower_not(const IecFunction& f, Emitter& e, const IecCall& c) {
  const IecTypeInfo& t = type_info(c.type);
  if (c.type == IecType::kBool) return one(e.block("not", {e.digital_or_false(arg(c, 0))}));
  if (!t.integer)
    return make_error(f.name + " takes BOOL or a bit string (BYTE..LWORD), not " + t.name);
  const uint32_t v = e.block("bnot", {e.analog_or_zero(arg(c, 0))}, {static_cast<double>(t.bits)});
  return one(t.bit_string ? v : e.wrap(v, c.type));
}

Out shift(const IecFunction& f, Emitter& e, const IecCall& c, const char* prim) {
  const IecTypeInfo& t = type_info(c.type);
  if (!t.integer) return make_error(f.name + " takes a bit string (BYTE..LWORD), not " + t.name);
  const uint32_t v = e.block(prim, {e.analog_or_zero(arg(c, 0)), e.analog_or_zero(arg(c, 1))},
                             {static_cast<double>(t.bits)});
  return one(t.bit_string ? v : e.wrap(v, c.type));
}
Out lower_shl(const IecFunction& f, Emitter& e, const IecCall& c) {
  return shift(f, e, c, "shl");
}
Out lower_shr(const IecFunction& f, Emitter& e, const IecCall& c) {
  return shift(f, e, c, "shr");
}
Out lower_rol(const IecFunction& f, Emitter& e, const IecCall& c) {
  return shift(f, e, c, "rol");
}
Out lower_ror(const IecFunction& f, Emitter& e, const IecCall& c) {
  return shift(f, e, c, "ror");
}

// TOD_TO_TIME, DATE_TO_DT...: neither the standard nor MatIEC defines them.
Out lower_time_to_time(const IecFunction& f, Emitter&, const IecCall&) {
  return make_error(f.name + " is no conversion of the standard (between time types it has DT_TO_DATE and "
                             "DT_TO_TOD); the date functions give the rest: SUB_TOD_TOD(t, TOD#00:00) is the TIME "
                             "since midnight, CONCAT_DATE_TOD(d, TOD#00:00) the DT a DATE starts");
}

Out lower_convert(const IecFunction& f, Emitter& e, const IecCall& c) {
  const IecType from = f.typed ? f.from : c.type;
  if (!f.typed && time_grid(from) != 0 && time_grid(f.to) != 0 && from != f.to) {
    // TO_DATE and TO_TOD of a DT are DT_TO_DATE and DT_TO_TOD.
    if (from == IecType::kDt && (f.to == IecType::kDate || f.to == IecType::kTod)) {
      const IecFunction* g = find_iec(std::string("DT_TO_") + type_info(f.to).name);
      if (g != nullptr) return g->lower(*g, e, c);
    }
    return make_error(f.name + " of a " + type_info(from).name +
                      ": no conversion of the standard between these time types (it has DT_TO_DATE and DT_TO_TOD)");
  }
  const uint32_t v = arg(c, 0);
  const uint32_t x = v == kUnconnected ? e.constant(0, type_info(from).kind()) : v;
  return one(e.convert(x, from, f.to));
}

// ---- function blocks ----
Out timer(Emitter& e, const IecCall& c, const char* q_prim, const char* et_prim) {
  const uint32_t in = e.digital_or_false(arg(c, 0)), pt = e.analog_or_zero(arg(c, 1));
  const uint32_t q = wants(c, 0) ? e.block(q_prim, {in, pt}, {}, "Q") : kUnconnected;
  const uint32_t et = wants(c, 1) ? e.block(et_prim, {in, pt}, {}, "ET") : kUnconnected;
  return std::vector<uint32_t>{q, et};
}
Out lower_ton(const IecFunction&, Emitter& e, const IecCall& c) {
  return timer(e, c, "ton", "ton_et");
}
Out lower_tof(const IecFunction&, Emitter& e, const IecCall& c) {
  return timer(e, c, "tof", "tof_et");
}
Out lower_tp(const IecFunction&, Emitter& e, const IecCall& c) {
  return timer(e, c, "tp", "tp_et");
}

Out lower_rtrig(const IecFunction&, Emitter& e, const IecCall& c) {
  return one(e.block("rtrig", {e.digital_or_false(arg(c, 0))}, {}, "Q"));
}
Out lower_ftrig(const IecFunction&, Emitter& e, const IecCall& c) {
  return one(e.block("ftrig", {e.digital_or_false(arg(c, 0))}, {}, "Q"));
}
Out lower_sr(const IecFunction&, Emitter& e, const IecCall& c) {
  return one(
      e.block("sr", {e.digital_or_false(arg(c, 0)), e.digital_or_false(arg(c, 1))}, {}, "Q1"));
}
Out lower_rs(const IecFunction&, Emitter& e, const IecCall& c) {
  return one(
      e.block("rs", {e.digital_or_false(arg(c, 0)), e.digital_or_false(arg(c, 1))}, {}, "Q1"));
}

// The counter's CV type: the typed variant's (CTU_DINT), else the call's if it
// is an integer type, else INT (MatIEC's CTU).
const IecTypeInfo& counter_type(const IecFunction& f, const IecCall& c) {
  if (f.typed) return type_info(f.to);
  return type_info(c.type).integer ? type_info(c.type) : type_info(IecType::kInt);
}

// The counters count where the standard's bodies say, with the limits MatIEC
// (its counter.txt) and CODESYS (PV: "upper limit for incrementing") give
// PVmax and PVmin: CTU up while CV < PV, CTD down while CV > 0, CTUD both.
// Each is one `ctud` whose step is gated on last cycle's CV (the read of the
// ctud, made before it, is a delayed one): step = updn(CU, CD), +1, -1 or 0
// on the rising edges (whose memories follow CU and CD every cycle, as the
// R_TRIG instances do), counted only when the limit allows it.
uint32_t gated_counter(Emitter& e, uint32_t step, uint32_t up_limit, bool up, bool down, uint32_t ld,
                       uint32_t load, const IecTypeInfo& t) {
  const uint32_t zero = e.constant(0, Kind::kAnalog);
  // The limit checks read CV, made last: their first input is set to it below.
  std::vector<uint32_t> reads_cv;
  uint32_t up_ok = 0, down_ok = 0;
  if (up) reads_cv.push_back(up_ok = e.block("lt", {zero, up_limit}));
  if (down) reads_cv.push_back(down_ok = e.block("gt", {zero, zero}));
  uint32_t ok = up ? up_ok : down_ok;
  if (up && down) {
    const uint32_t rising = e.block("gt", {step, zero});
    ok = e.block("or", {e.block("and", {rising, up_ok}),
                        e.block("and", {e.block("not", {rising}), down_ok})});
  }
  const uint32_t counted = e.block("amux", {zero, step, ok});
  const uint32_t cv = e.block("ctud", {counted, ld, load}, {t.min_value(), t.max_value()}, "CV");
  for (uint32_t i : reads_cv) e.program().blocks[i].in[0] = cv;  // last cycle's CV
  return cv;
}

Out lower_ctu(const IecFunction& f, Emitter& e, const IecCall& c) {
  const IecTypeInfo& t = counter_type(f, c);
  const uint32_t cu = e.digital_or_false(arg(c, 0)), r = e.digital_or_false(arg(c, 1));
  const uint32_t pv = e.analog_or_zero(arg(c, 2));
  const uint32_t step = e.block("updn", {cu, e.constant(0, Kind::kDigital)});
  const uint32_t cv = gated_counter(e, step, pv, true, false, r, e.constant(0, Kind::kAnalog), t);
  const uint32_t q = e.block("ge", {cv, pv}, {}, "Q");
  return std::vector<uint32_t>{q, cv};
}

Out lower_ctd(const IecFunction& f, Emitter& e, const IecCall& c) {
  const IecTypeInfo& t = counter_type(f, c);
  const uint32_t cd = e.digital_or_false(arg(c, 0)), ld = e.digital_or_false(arg(c, 1));
  const uint32_t pv = e.analog_or_zero(arg(c, 2));
  const uint32_t step = e.block("updn", {e.constant(0, Kind::kDigital), cd});
  const uint32_t cv = gated_counter(e, step, pv, false, true, ld, pv, t);
  const uint32_t q = e.block("le", {cv, e.constant(0, Kind::kAnalog)}, {}, "Q");
  return std::vector<uint32_t>{q, cv};
}

// CTUD(CU, CD, R, LD, PV): five inputs over three-input blocks (docs/language.md).
Out lower_ctud(const IecFunction& f, Emitter& e, const IecCall& c) {
  const IecTypeInfo& t = counter_type(f, c);
  const uint32_t step =
      e.block("updn", {e.digital_or_false(arg(c, 0)), e.digital_or_false(arg(c, 1))});
  const uint32_t r = e.digital_or_false(arg(c, 2));
  const uint32_t ld = e.block("or", {r, e.digital_or_false(arg(c, 3))});
  const uint32_t pv = e.analog_or_zero(arg(c, 4));
  const uint32_t load = e.block("amux", {pv, e.constant(0, Kind::kAnalog), r});
  const uint32_t cv = gated_counter(e, step, pv, true, true, ld, load, t);
  const uint32_t qu = e.block("ge", {cv, pv}, {}, "QU");
  const uint32_t qd = e.block("le", {cv, e.constant(0, Kind::kAnalog)}, {}, "QD");
  return std::vector<uint32_t>{qu, qd, cv};
}

// ---- the table ----
// ---- dates and times of day (docs/st.md, "Dates and times of day") ----
// DATE and DT are seconds since 1970-01-01, TOD seconds since midnight, TIME
// seconds. Each result lands on its type's grid as a variable of that type
// would (microseconds for DATE and DT and what is computed from them,
// nanoseconds for TOD and TIME from TODs), so a difference of two DTs is
// exact microseconds, not the doubles' rounding of 1.7e9 s.
struct DateFunction {
  const char* name;
  std::vector<const char*> inputs;
  const char* prim;  // add, sub, mult, div; mod for DT_TO_TOD; "date" for DT_TO_DATE
  double per;        // the result's grid: 1e6 (us) or 1e9 (ns); 0: none needed
  IecType to;
  const char* lowers_to;
};
const std::vector<DateFunction>& date_functions() {
  static const std::vector<DateFunction> t = {
      {"ADD_TIME", {"IN1", "IN2"}, "add", 1e9, IecType::kTime, "add, on the ns grid"},
      {"SUB_TIME", {"IN1", "IN2"}, "sub", 1e9, IecType::kTime, "sub, on the ns grid"},
      {"MULTIME", {"IN1", "IN2"}, "mult", 1e9, IecType::kTime, "mult (TIME * a number), on the ns grid"},
      {"MUL_TIME", {"IN1", "IN2"}, "mult", 1e9, IecType::kTime, "mult (TIME * a number), on the ns grid"},
      {"DIVTIME", {"IN1", "IN2"}, "div", 1e9, IecType::kTime,
       "div (TIME / a number; by 0 the block holds and counts an error), on the ns grid"},
      {"DIV_TIME", {"IN1", "IN2"}, "div", 1e9, IecType::kTime,
       "div (TIME / a number; by 0 the block holds and counts an error), on the ns grid"},
      {"ADD_TOD_TIME", {"IN1", "IN2"}, "add", 1e9, IecType::kTod, "add, on the ns grid"},
      {"ADD_DT_TIME", {"IN1", "IN2"}, "add", 1e6, IecType::kDt, "add, on the us grid"},
      {"SUB_DATE_DATE", {"IN1", "IN2"}, "sub", 1e6, IecType::kTime, "sub, on the us grid"},
      {"SUB_TOD_TIME", {"IN1", "IN2"}, "sub", 1e9, IecType::kTod, "sub, on the ns grid"},
      {"SUB_TOD_TOD", {"IN1", "IN2"}, "sub", 1e9, IecType::kTime, "sub, on the ns grid"},
      {"SUB_DT_TIME", {"IN1", "IN2"}, "sub", 1e6, IecType::kDt, "sub, on the us grid"},
      {"SUB_DT_DT", {"IN1", "IN2"}, "sub", 1e6, IecType::kTime, "sub, on the us grid"},
      {"CONCAT_DATE_TOD", {"IN1", "IN2"}, "add", 1e6, IecType::kDt, "add, on the us grid"},
      {"DT_TO_TOD", {"IN"}, "mod", 1e6, IecType::kTod, "mod(IN, 86400), on the us grid"},
      {"DATE_AND_TIME_TO_TIME_OF_DAY", {"IN"}, "mod", 1e6, IecType::kTod, "mod(IN, 86400), on the us grid"},
      {"DT_TO_DATE", {"IN"}, "date", 0, IecType::kDate, "sub(IN, mod(IN, 86400))"},
      {"DATE_AND_TIME_TO_DATE", {"IN"}, "date", 0, IecType::kDate, "sub(IN, mod(IN, 86400))"},
  };
  return t;
}
Out lower_date(const IecFunction& f, Emitter& e, const IecCall& c) {
  const auto& all = date_functions();
  const auto it = std::find_if(all.begin(), all.end(), [&](const DateFunction& d) { return f.name == d.name; });
  if (it == all.end()) return make_error(f.name + ": not a date function");
  const uint32_t a = e.analog_or_zero(arg(c, 0));
  const std::string_view prim = it->prim;
  uint32_t v = 0;
  if (prim == "mod" || prim == "date") {
    // DT counts from 1970, so IN >= 0 and fmod's remainder is the time of day.
    const uint32_t tod = e.block("mod", {a, e.constant(86400, Kind::kAnalog)});
    v = prim == "mod" ? tod : e.block("sub", {a, tod});
  } else {
    v = e.block(prim, {a, e.analog_or_zero(arg(c, 1))});
  }
  if (it->per > 0) {
    v = e.block("div", {e.block("round", {e.block("scale", {v}, {it->per, 0.0})}), e.constant(it->per, Kind::kAnalog)});
  }
  return one(v);
}

// ---- BCD (IEC 61131-3 ed. 2 table 22, MatIEC's __bcd_to_uint / __uint_to_bcd) ----
// The bit string of `bits` bits holding the same digits: BYTE, WORD, DWORD, LWORD.
IecType bit_string_of(uint8_t bits) {
  return bits <= 8 ? IecType::kByte : bits <= 16 ? IecType::kWord : bits <= 32 ? IecType::kDword : IecType::kLword;
}

// BCD_TO_INT(w): each nibble of the bit string is a decimal digit, the lowest
// the units; a nibble above 9 makes the input no BCD and the result 0, as
// MatIEC's (its ENO false). The nibbles come from the typed name's bit string,
// else from the operand's (a literal: 64 bits).
Out lower_bcd_to(const IecFunction& f, Emitter& e, const IecCall& c) {
  const IecType from = f.typed ? f.from : c.type;
  // The operand's width: its bit string's, or its integer type's (an INT read
  // from %IW0 holds 16 bits); 64 for a literal.
  const uint8_t bits = type_info(from).integer ? type_info(from).bits : 64;
  const double w = bits;
  // Its bits as an unsigned number of that width (a 64-bit mask is no double:
  // band reads the operand modulo 2^bits by itself).
  const uint32_t x = e.block("band", {e.analog_or_zero(arg(c, 0)), e.analog_or_zero(arg(c, 0))}, {w});
  const uint32_t fifteen = e.constant(15, Kind::kAnalog), ten = e.constant(10, Kind::kAnalog);
  uint32_t sum = kUnconnected, bad = kUnconnected;
  double scale = 1;
  for (int k = 0; k < bits / 4; ++k, scale *= 10) {
    const uint32_t shifted = k == 0 ? x : e.block("shr", {x, e.constant(4.0 * k, Kind::kAnalog)}, {w});
    const uint32_t nib = e.block("band", {shifted, fifteen}, {w});
    const uint32_t no_digit = e.block("ge", {nib, ten});
    bad = bad == kUnconnected ? no_digit : e.block("or", {bad, no_digit});
    const uint32_t part = k == 0 ? nib : e.block("scale", {nib}, {scale, 0.0});
    sum = sum == kUnconnected ? part : e.block("add", {sum, part});
  }
  return one(e.wrap(e.block("amux", {sum, e.constant(0, Kind::kAnalog), bad}), f.to));
}

// INT_TO_BCD(n): the decimal digits of n, one per nibble, as many as the bit
// string holds (the higher ones dropped, as MatIEC's cast drops them); a
// negative n has no BCD and gives 0.
Out lower_to_bcd(const IecFunction& f, Emitter& e, const IecCall& c) {
  const uint8_t bits = type_info(f.to).bits;
  uint32_t rest = e.block("trunc", {e.analog_or_zero(arg(c, 0))});
  const uint32_t negative = e.block("lt", {rest, e.constant(0, Kind::kAnalog)});
  const uint32_t ten = e.constant(10, Kind::kAnalog);
  uint32_t sum = kUnconnected;
  double weight = 1;
  for (int k = 0; k < bits / 4; ++k, weight *= 16) {
    const uint32_t digit = e.block("mod", {rest, ten});
    const uint32_t part = k == 0 ? digit : e.block("scale", {digit}, {weight, 0.0});
    sum = sum == kUnconnected ? part : e.block("add", {sum, part});
    if (k + 1 < bits / 4) rest = e.block("trunc", {e.block("div", {rest, ten})});
  }
  return one(e.block("amux", {sum, e.constant(0, Kind::kAnalog), negative}));
}

IecFunction fn(const char* name, std::vector<const char*> ins, IecLower lower, const char* to,
               bool extensible = false) {
  IecFunction f;
  f.name = name;
  f.function_block = false;
  f.inputs = std::move(ins);
  f.outputs = {"OUT"};
  f.extensible = extensible;
  f.min_inputs = static_cast<uint32_t>(f.inputs.size());
  f.lower = lower;
  f.lowers_to = to;
  return f;
}

IecFunction fb(const char* name, std::vector<const char*> ins, std::vector<const char*> outs,
               IecLower lower, const char* to) {
  IecFunction f = fn(name, std::move(ins), lower, to);
  f.function_block = true;
  f.outputs = std::move(outs);
  return f;
}

std::vector<IecFunction> build_table() {
  std::vector<IecFunction> t;
  t.push_back(fn("ADD", {"IN1", "IN2"}, lower_add, "add chain; integers: + wrap", true));
  t.push_back(fn("MUL", {"IN1", "IN2"}, lower_mul, "mult chain; integers: imul chain", true));
  t.push_back(fn("SUB", {"IN1", "IN2"}, lower_sub, "sub; integers: + wrap"));
  t.push_back(
      fn("DIV", {"IN1", "IN2"}, lower_div, "div; integers: + wrap (truncates toward zero)"));
  t.push_back(fn("MOD", {"IN1", "IN2"}, lower_mod, "mod"));
  t.push_back(fn("EXPT", {"IN1", "IN2"}, lower_expt, "expt"));
  t.push_back(fn("MOVE", {"IN"}, lower_move, "nothing: OUT is IN's producer"));
  t.push_back(fn("ABS", {"IN"}, lower_abs, "abs; integers: + wrap"));
  t.push_back(fn("NEG", {"IN"}, lower_neg, "neg; integers: + wrap"));
  t.push_back(fn("SQRT", {"IN"}, lower_sqrt, "sqrt"));
  t.push_back(fn("LN", {"IN"}, lower_ln, "ln"));
  t.push_back(fn("LOG", {"IN"}, lower_log, "log"));
  t.push_back(fn("EXP", {"IN"}, lower_exp, "exp"));
  t.push_back(fn("SIN", {"IN"}, lower_sin, "sin"));
  t.push_back(fn("COS", {"IN"}, lower_cos, "cos"));
  t.push_back(fn("TAN", {"IN"}, lower_tan, "tan"));
  t.push_back(fn("ASIN", {"IN"}, lower_asin, "asin"));
  t.push_back(fn("ACOS", {"IN"}, lower_acos, "acos"));
  t.push_back(fn("ATAN", {"IN"}, lower_atan, "atan"));
  t.push_back(fn("TRUNC", {"IN"}, lower_trunc, "trunc; to an integer type: wrap"));
  t.push_back(fn("GT", {"IN1", "IN2"}, lower_gt, "gt, and-chained for more inputs", true));
  t.push_back(fn("GE", {"IN1", "IN2"}, lower_ge, "ge, and-chained for more inputs", true));
  t.push_back(fn("LT", {"IN1", "IN2"}, lower_lt, "lt, and-chained for more inputs", true));
  t.push_back(fn("LE", {"IN1", "IN2"}, lower_le, "le, and-chained for more inputs", true));
  t.push_back(fn("EQ", {"IN1", "IN2"}, lower_eq, "eq, and-chained for more inputs", true));
  t.push_back(fn("NE", {"IN1", "IN2"}, lower_ne, "ne"));
  t.push_back(fn("SEL", {"G", "IN0", "IN1"}, lower_sel, "amux(IN0, IN1, G)"));
  t.push_back(fn("MUX", {"K", "IN0", "IN1"}, lower_mux,
                 "amux chain on eq(K, j); K outside 0..n gives IN0", true));
  t.push_back(fn("LIMIT", {"MN", "IN", "MX"}, lower_limit, "min(max(IN, MN), MX)"));
  t.push_back(fn("MAX", {"IN1", "IN2"}, lower_max, "max chain", true));
  t.push_back(fn("MIN", {"IN1", "IN2"}, lower_min, "min chain", true));
  t.push_back(fn("AND", {"IN1", "IN2"}, lower_and, "BOOL: and; bit strings: band", true));
  t.push_back(fn("OR", {"IN1", "IN2"}, lower_or, "BOOL: or; bit strings: bor", true));
  t.push_back(fn("XOR", {"IN1", "IN2"}, lower_xor, "BOOL: exor; bit strings: bxor", true));
  t.push_back(fn("NOT", {"IN"}, lower_not, "BOOL: not; bit strings: bnot"));
  t.push_back(fn("SHL", {"IN", "N"}, lower_shl, "shl(IN, N, bits)"));
  t.push_back(fn("SHR", {"IN", "N"}, lower_shr, "shr(IN, N, bits)"));
  t.push_back(fn("ROL", {"IN", "N"}, lower_rol, "rol(IN, N, bits)"));
  t.push_back(fn("ROR", {"IN", "N"}, lower_ror, "ror(IN, N, bits)"));
  t.push_back(fb("TON", {"IN", "PT"}, {"Q", "ET"}, lower_ton, "ton (Q), ton_et (ET)"));
  t.push_back(fb("TOF", {"IN", "PT"}, {"Q", "ET"}, lower_tof, "tof (Q), tof_et (ET)"));
  t.push_back(fb("TP", {"IN", "PT"}, {"Q", "ET"}, lower_tp, "tp (Q), tp_et (ET)"));
  t.push_back(fb("R_TRIG", {"CLK"}, {"Q"}, lower_rtrig, "rtrig"));
  t.push_back(fb("F_TRIG", {"CLK"}, {"Q"}, lower_ftrig, "ftrig"));
  t.push_back(fb("SR", {"S1", "R"}, {"Q1"}, lower_sr, "sr"));
  t.push_back(fb("RS", {"S", "R1"}, {"Q1"}, lower_rs, "rs"));
  t.push_back(fb("CTU", {"CU", "R", "PV"}, {"Q", "CV"}, lower_ctu, "updn, lt, amux, ctud (CV), ge(CV, PV) (Q)"));
  t.push_back(fb("CTD", {"CD", "LD", "PV"}, {"Q", "CV"}, lower_ctd, "updn, gt, amux, ctud (CV), le(CV, 0) (Q)"));
  t.push_back(fb("CTUD", {"CU", "CD", "R", "LD", "PV"}, {"QU", "QD", "CV"}, lower_ctud,
                 "updn, or, lt, gt, and, not, amux, ctud (CV), ge (QU), le (QD)"));
  // The typed counters of the third edition: the same blocks with the type's limits.
  for (IecType ty :
       {IecType::kInt, IecType::kDint, IecType::kLint, IecType::kUdint, IecType::kUlint}) {
    const std::string suffix = std::string("_") + type_info(ty).name;
    const size_t base = t.size();
    for (const char* c : {"CTU", "CTD", "CTUD"}) {
      for (size_t k = 0; k < base; ++k) {
        if (t[k].name == c) {
          IecFunction v = t[k];
          v.name += suffix;
          v.typed = true;
          v.to = ty;
          t.push_back(v);
          break;
        }
      }
    }
  }
  for (const DateFunction& d : date_functions()) {
    IecFunction v = fn(d.name, d.inputs, lower_date, d.lowers_to);
    v.typed = true;
    v.to = d.to;
    t.push_back(v);
  }
  // BCD: BCD_TO_INT (from the operand's bit string) and WORD_BCD_TO_INT, INT_TO_BCD
  // (into the bit string of the integer's width) and INT_TO_BCD_WORD.
  for (uint8_t a = 0; a <= static_cast<uint8_t>(IecType::kLword); ++a) {
    const auto n = static_cast<IecType>(a);
    const IecTypeInfo& ni = type_info(n);
    if (!ni.integer || ni.bit_string) continue;
    IecFunction to_int = fn("", {"IN"}, lower_bcd_to, "band, shr, scale, add per nibble; 0 when a nibble is above 9");
    to_int.name = std::string("BCD_TO_") + ni.name;
    to_int.to = n;
    t.push_back(to_int);
    IecFunction from_int = fn("", {"IN"}, lower_to_bcd, "mod, div, scale, add per digit; 0 when IN < 0");
    from_int.name = std::string(ni.name) + "_TO_BCD";
    from_int.to = bit_string_of(ni.bits);
    from_int.typed = true;
    from_int.from = n;
    t.push_back(from_int);
    for (uint8_t b = static_cast<uint8_t>(IecType::kByte); b <= static_cast<uint8_t>(IecType::kLword); ++b) {
      const auto bs = static_cast<IecType>(b);
      IecFunction typed_to = to_int;
      typed_to.name = std::string(type_info(bs).name) + "_BCD_TO_" + ni.name;
      typed_to.typed = true;
      typed_to.from = bs;
      t.push_back(typed_to);
      IecFunction typed_from = from_int;
      typed_from.name = std::string(ni.name) + "_TO_BCD_" + type_info(bs).name;
      typed_from.to = bs;
      t.push_back(typed_from);
    }
  }
  // Conversions: every X_TO_Y, and the third edition's TO_Y (from the operand
  // type). Between two time types the standard has only DT_TO_DATE and DT_TO_TOD
  // (the date table above); the others are refused by name.
  for (uint8_t a = 0; a <= static_cast<uint8_t>(IecType::kDt); ++a) {
    const auto to = static_cast<IecType>(a);
    IecFunction g = fn("", {"IN"}, lower_convert, "see the conversion rules");
    g.name = std::string("TO_") + type_info(to).name;
    g.to = to;
    t.push_back(g);
    for (uint8_t b = 0; b <= static_cast<uint8_t>(IecType::kDt); ++b) {
      if (a == b) continue;
      const auto from = static_cast<IecType>(b);
      IecFunction v = g;
      v.name = std::string(type_info(from).name) + "_TO_" + type_info(to).name;
      v.typed = true;
      v.from = from;
      if (time_grid(from) != 0 && time_grid(to) != 0) {
        if (from == IecType::kDt && (to == IecType::kDate || to == IecType::kTod)) continue;
        v.lower = lower_time_to_time;
        v.lowers_to = "refused: no such conversion in the standard";
      }
      t.push_back(v);
    }
  }
  return t;
}

const std::vector<IecFunction>& table() {
  static const std::vector<IecFunction> t = build_table();
  return t;
}

std::string upper(std::string_view s) {
  std::string u(s);
  for (char& ch : u) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return u;
}

}  // namespace

std::span<const IecFunction> all_iec_functions() {
  return table();
}

const IecFunction* find_iec(std::string_view name) {
  static const std::unordered_map<std::string, size_t> index = [] {
    std::unordered_map<std::string, size_t> m;
    for (size_t i = 0; i < table().size(); ++i) m.emplace(table()[i].name, i);
    return m;
  }();
  auto it = index.find(upper(name));
  return it == index.end() ? nullptr : &table()[it->second];
}

int iec_input_index(const IecFunction& f, std::string_view formal) {
  const std::string u = upper(formal);
  for (size_t k = 0; k < f.inputs.size(); ++k) {
    if (u == f.inputs[k]) return static_cast<int>(k);
  }
  if (!f.extensible || f.inputs.empty()) return -1;
  // IN1, IN2, ... (or IN0, IN1, ... for MUX): the number past the last listed one.
  const std::string last = f.inputs.back();
  const size_t digits = last.find_first_of("0123456789");
  if (digits == std::string::npos || u.compare(0, digits, last, 0, digits) != 0 ||
      u.size() == digits)
    return -1;
  int n = 0;
  for (size_t i = digits; i < u.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(u[i])) || n > 1000) return -1;
    n = n * 10 + (u[i] - '0');
  }
  const int last_n = std::stoi(last.substr(digits));
  const int pos = static_cast<int>(f.inputs.size()) - 1 + (n - last_n);
  return pos >= 0 ? pos : -1;
}

int iec_output_index(const IecFunction& f, std::string_view formal) {
  const std::string u = upper(formal);
  for (size_t k = 0; k < f.outputs.size(); ++k) {
    if (u == f.outputs[k]) return static_cast<int>(k);
  }
  return -1;
}

bool iec_input_sets_type(const IecFunction& f, size_t k) {
  if (k >= f.inputs.size()) return true;  // IN3.. of an extensible function
  const std::string_view formal = f.inputs[k];
  return formal != "G" && formal != "K" && formal != "N";
}

IecType iec_result_type(const IecFunction& f, IecType type) {
  if (f.lower == lower_convert || f.lower == lower_date || f.lower == lower_bcd_to || f.lower == lower_to_bcd) return f.to;
  if (f.lower == lower_trunc && !type_info(type).integer) return IecType::kLint;
  return type;
}

Kind iec_output_kind(const IecFunction& f, size_t k, IecType type) {
  // Lowered into a scratch program with every input unconnected: the kinds
  // come from the lowering itself, so there is no second list to keep in step.
  CheckedProgram scratch;
  Emitter e(scratch, "", SourcePos{});
  IecCall call;
  call.type = type;
  const auto outs = f.lower(f, e, call);
  if (!outs || k >= outs->size() || (*outs)[k] == kUnconnected) return Kind::kAnalog;
  return e.kind_of((*outs)[k]);
}

std::string iec_functions_markdown() {
  std::string s =
      "# IEC 61131-3 standard functions and blocks\n\n"
      "Generated by `rtplc blocks --iec` from the table in lang/iec/iec_functions.cpp; a test\n"
      "fails if this file and the table disagree. How each standard function or block lowers to\n"
      "the primitive blocks of [blocks.md](blocks.md); the semantic choices (types, rounding,\n"
      "timers, counters) are in [language.md](language.md), \"IEC 61131-3 types and standard\n"
      "blocks\". Names are matched in any case. An overloaded function takes its operand type "
      "from\n"
      "the caller: on an integer type ADD, SUB, DIV, ABS, NEG wrap their result (`wrap`) and MUL\n"
      "multiplies exactly in 64-bit integers and wraps (`imul`);\n"
      "AND, OR, XOR, NOT are bitwise on bit strings and logical on BOOL.\n\n"
      "| IEC name | kind | inputs | outputs | lowers to |\n"
      "|---|---|---|---|---|\n";
  for (const IecFunction& f : table()) {
    if (f.lower == lower_convert || f.lower == lower_bcd_to || (f.typed && f.lower != lower_date)) continue;
    std::string ins;
    for (const char* i : f.inputs) ins += (ins.empty() ? "" : ", ") + std::string(i);
    if (f.extensible) ins += ", ...";
    std::string outs;
    for (const char* o : f.outputs) outs += (outs.empty() ? "" : ", ") + std::string(o);
    s += "| `" + f.name + "` | " + (f.function_block ? "block" : "function") + " | " + ins + " | " +
         outs + " | " + f.lowers_to + " |\n";
  }
  s += "| `CTU_INT` .. `CTUD_ULINT` | block | as CTU, CTD, CTUD | as CTU, CTD, CTUD | the same, "
       "with the type's "
       "limits |\n";
  s += "| `BCD_TO_INT` .. `BCD_TO_ULINT`, `WORD_BCD_TO_INT`... | function | IN | OUT | one decimal digit per "
       "nibble (band, shr, scale, add); 0 when a nibble is above 9 |\n";
  s += "| `INT_TO_BCD` .. `ULINT_TO_BCD`, `INT_TO_BCD_WORD`... | function | IN | OUT | one decimal digit per "
       "nibble of the bit string of the integer's width (mod, div, scale, add); 0 when IN < 0 |\n";
  s += "| `X_TO_Y`, `TO_Y` | function | IN | OUT | the conversion rules above (round, wrap, d2a, "
       "a2d, TIME and the dates as the editor counts them: docs/st.md; between time types only DT_TO_DATE, "
       "DT_TO_TOD) |\n";
  return s;
}

}  // namespace rtplc::lang::iec
