// One interpreter body over runs of same-opcode instructions. Built as computed
// goto under GCC/Clang and as a switch elsewhere (Lua's vmdispatch idea). Because
// the compiler groups independent blocks of one opcode into runs, dispatch is paid
// once per run and the inner loops are as tight as hand-written array code.
//
// Error rule (spec "Domain errors"): an analog result is committed only when
// finite; otherwise the output and the block's state keep their previous values
// and the block's error counter increments. This one check covers division by
// zero, sqrt of a negative, asin/acos outside [-1, 1], inv(0) and overflow.
#include "blocks/executor.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace rtplc {

void TaskArena::resize_for(const TaskImage& image) {
  const ImageHeader& h = image.header();
  values.assign(h.n_values, 0.0);
  state.assign(h.n_state, 0.0);
  errors.assign(h.n_instr, 0);
  io_in.assign(h.n_io_in, 0.0);
  io_out.assign(h.n_io_out, 0.0);
  total_errors = 0;
  cycles = 0;
}

void TaskArena::reset() {
  std::fill(values.begin(), values.end(), 0.0);
  std::fill(state.begin(), state.end(), 0.0);
  std::fill(errors.begin(), errors.end(), 0u);
  std::fill(io_out.begin(), io_out.end(), 0.0);
  total_errors = 0;
  cycles = 0;
}

ExecContext make_context(const TaskImage& image, TaskArena& a) {
  ExecContext c;
  c.code = image.code().data();
  c.runs = image.runs().data();
  c.n_runs = image.header().n_runs;
  c.params = image.params().data();
  c.values = a.values.data();
  c.state = a.state.data();
  c.errors = a.errors.data();
  c.io_in = a.io_in.data();
  c.io_out = a.io_out.data();
  c.total_errors = &a.total_errors;
  c.cycles = &a.cycles;
  return c;
}

namespace {

#if defined(__GNUC__)
#define RTPLC_LIKELY(x) __builtin_expect(!!(x), 1)
#else
#define RTPLC_LIKELY(x) (x)
#endif

// NaN fails both comparisons, so this rejects NaN and +-Inf with one test.
inline bool finite(double y) { return std::fabs(y) <= DBL_MAX; }
inline double b2d(bool b) { return b ? 1.0 : 0.0; }
inline bool d2b(double v) { return v != 0.0; }

}  // namespace

void execute_cycle(const ExecContext& ctx) noexcept {
  const Instr* const code = ctx.code;
  const double* const P = ctx.params;
  double* const V = ctx.values;
  double* const S = ctx.state;
  const double* const IN = ctx.io_in;
  double* const OUT = ctx.io_out;
  uint64_t new_errors = 0;

  // Rare path: count an error against the instruction and the task.
#define FAIL(ip)                               \
  do {                                         \
    ++ctx.errors[(ip) - code];                 \
    ++new_errors;                              \
  } while (0)
  // Commit an analog result or fail.
#define COMMIT(ip, y)                          \
  do {                                         \
    const double y_ = (y);                     \
    if (RTPLC_LIKELY(finite(y_))) V[(ip)->out] = y_; \
    else FAIL(ip);                             \
  } while (0)
#define A0 V[I->in[0]]
#define A1 V[I->in[1]]
#define A2 V[I->in[2]]
#define LOOP for (; I != E; ++I)

#if defined(__GNUC__)
  static const void* const kDispatch[] = {
#define RTPLC_LABEL(name) &&L_##name,
      RTPLC_OPS(RTPLC_LABEL)
#undef RTPLC_LABEL
  };
#define VMCASE(name) L_##name:
#define VMBREAK continue
#define VMDISPATCH(op) goto* kDispatch[static_cast<uint8_t>(op)];
#else
#define VMCASE(name) case Op::name:
#define VMBREAK continue
#define VMDISPATCH(op) switch (op)
#endif

  const Run* const runs_end = ctx.runs + ctx.n_runs;
  for (const Run* r = ctx.runs; r != runs_end; ++r) {
    const Instr* I = code + r->begin;
    const Instr* const E = code + r->end;
    VMDISPATCH(r->op) {
      VMCASE(LoadA) {
        LOOP COMMIT(I, IN[I->in[0]]);
        VMBREAK;
      }
      VMCASE(LoadD) {
        LOOP V[I->out] = b2d(d2b(IN[I->in[0]]) && IN[I->in[0]] == IN[I->in[0]]);
        VMBREAK;
      }
      VMCASE(StoreA) {
        LOOP OUT[I->out] = A0;
        VMBREAK;
      }
      VMCASE(StoreD) {
        LOOP OUT[I->out] = b2d(d2b(A0));
        VMBREAK;
      }
      VMCASE(Add) {
        LOOP COMMIT(I, P[I->param] * (A0 + A1));
        VMBREAK;
      }
      VMCASE(Sub) {
        LOOP COMMIT(I, P[I->param] * (A0 - A1));
        VMBREAK;
      }
      VMCASE(Mult) {
        LOOP COMMIT(I, P[I->param] * A0 * A1);
        VMBREAK;
      }
      VMCASE(Div) {
        LOOP {
          const double b = A1;
          if (b != 0.0) COMMIT(I, P[I->param] * A0 / b);
          else FAIL(I);
        }
        VMBREAK;
      }
      VMCASE(Abs) {
        LOOP V[I->out] = std::fabs(A0);
        VMBREAK;
      }
      VMCASE(Sqrt) {
        LOOP {
          const double a = A0;
          if (a >= 0.0) V[I->out] = std::sqrt(a);
          else FAIL(I);
        }
        VMBREAK;
      }
      VMCASE(Sin) {
        LOOP V[I->out] = std::sin(A0);
        VMBREAK;
      }
      VMCASE(Cos) {
        LOOP V[I->out] = std::cos(A0);
        VMBREAK;
      }
      VMCASE(Tan) {
        LOOP COMMIT(I, std::tan(A0));
        VMBREAK;
      }
      VMCASE(Asin) {
        LOOP {
          const double a = A0;
          if (a >= -1.0 && a <= 1.0) V[I->out] = std::asin(a);
          else FAIL(I);
        }
        VMBREAK;
      }
      VMCASE(Acos) {
        LOOP {
          const double a = A0;
          if (a >= -1.0 && a <= 1.0) V[I->out] = std::acos(a);
          else FAIL(I);
        }
        VMBREAK;
      }
      VMCASE(Atan) {
        LOOP V[I->out] = std::atan(A0);
        VMBREAK;
      }
      VMCASE(Max) {
        LOOP V[I->out] = std::max(A0, A1);
        VMBREAK;
      }
      VMCASE(Min) {
        LOOP V[I->out] = std::min(A0, A1);
        VMBREAK;
      }
      VMCASE(Inv) {
        LOOP {
          const double a = A0;
          if (a != 0.0) COMMIT(I, 1.0 / a);
          else FAIL(I);
        }
        VMBREAK;
      }
      VMCASE(Scale) {
        LOOP COMMIT(I, P[I->param] * A0 + P[I->param + 1]);
        VMBREAK;
      }
      VMCASE(And2) {
        LOOP V[I->out] = b2d(d2b(A0) && d2b(A1));
        VMBREAK;
      }
      VMCASE(And3) {
        LOOP V[I->out] = b2d(d2b(A0) && d2b(A1) && d2b(A2));
        VMBREAK;
      }
      VMCASE(Or2) {
        LOOP V[I->out] = b2d(d2b(A0) || d2b(A1));
        VMBREAK;
      }
      VMCASE(Or3) {
        LOOP V[I->out] = b2d(d2b(A0) || d2b(A1) || d2b(A2));
        VMBREAK;
      }
      VMCASE(Not) {
        LOOP V[I->out] = b2d(!d2b(A0));
        VMBREAK;
      }
      VMCASE(Exor) {
        LOOP V[I->out] = b2d(d2b(A0) != d2b(A1));
        VMBREAK;
      }
      VMCASE(Time) {
        LOOP {
          double* s = S + I->state;  // s[0] = cycles `in` has been true (saturates at N)
          const double n = P[I->param];
          if (d2b(A0)) {
            V[I->out] = b2d(s[0] >= n);
            if (s[0] < n) s[0] += 1.0;
          } else {
            s[0] = 0.0;
            V[I->out] = 0.0;
          }
        }
        VMBREAK;
      }
      VMCASE(Cnt) {
        LOOP {
          double* s = S + I->state;  // s[0] = count, s[1] = previous `in`
          const bool in = d2b(A0);
          if (d2b(A1)) {
            s[0] = 0.0;
          } else if (in && s[1] == 0.0 && s[0] < 4.0e15) {
            s[0] += 1.0;
          }
          s[1] = b2d(in);
          V[I->out] = b2d(s[0] >= P[I->param]);
        }
        VMBREAK;
      }
      VMCASE(Lim) {
        LOOP V[I->out] = std::min(std::max(A0, P[I->param]), P[I->param + 1]);
        VMBREAK;
      }
      VMCASE(Dzon) {
        LOOP {
          const double a = A0, w = P[I->param];
          V[I->out] = a > w ? a - w : (a < -w ? a + w : 0.0);
        }
        VMBREAK;
      }
      VMCASE(Dely) {
        LOOP {
          const auto n = static_cast<uint32_t>(P[I->param]);
          if (n == 0) {
            V[I->out] = A0;
            continue;
          }
          double* s = S + I->state;  // s[0] = next index, s[1..n] = ring
          auto idx = static_cast<uint32_t>(s[0]);
          if (idx >= n) idx = 0;  // defensive: a migrated or corrupt index never escapes
          const double a = A0;
          V[I->out] = s[1 + idx];
          s[1 + idx] = a;
          s[0] = static_cast<double>(idx + 1 == n ? 0 : idx + 1);
        }
        VMBREAK;
      }
      VMCASE(Intg) {
        LOOP COMMIT(I, V[I->out] + A0 * P[I->param]);
        VMBREAK;
      }
      VMCASE(Derv) {
        LOOP {
          double* s = S + I->state;  // s[0] = previous input, s[1] = primed
          const double a = A0;
          const double y = s[1] != 0.0 ? (a - s[0]) * P[I->param] : 0.0;
          if (RTPLC_LIKELY(finite(y))) {
            V[I->out] = y;
            s[0] = a;
            s[1] = 1.0;
          } else {
            FAIL(I);
          }
        }
        VMBREAK;
      }
      VMCASE(Filt) {
        LOOP {
          const double y = V[I->out];
          COMMIT(I, y + P[I->param] * (A0 - y));
        }
        VMBREAK;
      }
      VMCASE(Ldlg) {
        LOOP {
          double* s = S + I->state;  // s[0] = previous input; previous output = own slot
          const double* p = P + I->param;
          const double a = A0;
          const double y = p[0] * a + p[1] * s[0] - p[2] * V[I->out];
          if (RTPLC_LIKELY(finite(y))) {
            V[I->out] = y;
            s[0] = a;
          } else {
            FAIL(I);
          }
        }
        VMBREAK;
      }
      VMCASE(Pi) {
        LOOP {
          double* s = S + I->state;  // s[0] = integral already divided by Ti
          const double* p = P + I->param;
          const double e = A0 - A1;
          const double integ = s[0] + e * p[1];
          const double u = p[0] * (e + integ);
          if (RTPLC_LIKELY(finite(u))) {
            V[I->out] = u;
            s[0] = integ;
          } else {
            FAIL(I);
          }
        }
        VMBREAK;
      }
      VMCASE(Epi) {
        LOOP {
          double* s = S + I->state;
          const double* p = P + I->param;
          const double e = A0;
          const double integ = s[0] + e * p[1];
          const double u = p[0] * (e + integ);
          if (RTPLC_LIKELY(finite(u))) {
            V[I->out] = u;
            s[0] = integ;
          } else {
            FAIL(I);
          }
        }
        VMBREAK;
      }
      VMCASE(Pid) {
        LOOP {
          double* s = S + I->state;  // s[0] = integral/Ti, s[1] = previous error, s[2] = primed
          const double* p = P + I->param;
          const double e = A0 - A1;
          const double integ = s[0] + e * p[1];
          const double d = s[2] != 0.0 ? (e - s[1]) * p[2] : 0.0;
          const double u = p[0] * (e + integ + d);
          if (RTPLC_LIKELY(finite(u))) {
            V[I->out] = u;
            s[0] = integ;
            s[1] = e;
            s[2] = 1.0;
          } else {
            FAIL(I);
          }
        }
        VMBREAK;
      }
      VMCASE(Epid) {
        LOOP {
          double* s = S + I->state;
          const double* p = P + I->param;
          const double e = A0;
          const double integ = s[0] + e * p[1];
          const double d = s[2] != 0.0 ? (e - s[1]) * p[2] : 0.0;
          const double u = p[0] * (e + integ + d);
          if (RTPLC_LIKELY(finite(u))) {
            V[I->out] = u;
            s[0] = integ;
            s[1] = e;
            s[2] = 1.0;
          } else {
            FAIL(I);
          }
        }
        VMBREAK;
      }
      VMCASE(Ramp) {
        LOOP {
          const double y = V[I->out], step = P[I->param];
          const double diff = A0 - y;
          V[I->out] = diff > step ? y + step : (diff < -step ? y - step : A0);
        }
        VMBREAK;
      }
      VMCASE(Amux) {
        LOOP V[I->out] = d2b(A2) ? A1 : A0;
        VMBREAK;
      }
    }
  }
  ++*ctx.cycles;
  if (new_errors != 0) *ctx.total_errors += new_errors;
#undef FAIL
#undef COMMIT
#undef A0
#undef A1
#undef A2
#undef LOOP
#undef VMCASE
#undef VMBREAK
#undef VMDISPATCH
}

}  // namespace rtplc
