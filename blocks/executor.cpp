// One interpreter over runs of same-opcode instructions (see image.h). Each
// opcode's semantics is written once, as a kernel over an "accessor" that says
// where element j's operands live:
//   - IndexedAccess reads them through the instruction (any run);
//   - AffineAccess reads them from plain arrays (runs the compiler proved affine),
//     in a loop the compiler may vectorise — no index loads, no branches.
// Dispatch happens once per run, as computed goto under GCC/Clang or a switch
// elsewhere (the vmdispatch idea of Lua's lvm.c).
//
// Error rule (docs/blocks.md): an analog result is committed only when finite;
// otherwise the output and the block's state keep their previous values and the
// block's error counter increments. Commits are written as selects rather than
// branches so affine loops stay vectorisable; the count of failures is summed
// per run and added to the task's total once.
#include "blocks/executor.h"
#include "blocks/int_math.h"
#include "blocks/string_ops.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <cstring>

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
  loop_fault = 0;
}

void TaskArena::reset() {
  std::fill(values.begin(), values.end(), 0.0);
  std::fill(state.begin(), state.end(), 0.0);
  std::fill(errors.begin(), errors.end(), 0u);
  std::fill(io_out.begin(), io_out.end(), 0.0);
  total_errors = 0;
  cycles = 0;
  loop_fault = 0;
}

ExecContext make_context(const TaskImage& image, TaskArena& a) {
  ExecContext c;
  c.code = image.code().data();
  c.runs = image.runs().data();
  c.n_runs = image.header().n_runs;
  c.params = image.params().data();
  c.values = a.values.data();
  c.n_values = static_cast<uint32_t>(a.values.size());
  c.state = a.state.data();
  c.errors = a.errors.data();
  c.io_in = a.io_in.data();
  c.io_out = a.io_out.data();
  c.total_errors = &a.total_errors;
  c.cycles = &a.cycles;
  c.loop_budget = a.loop_budget;
  c.loop_fault = &a.loop_fault;
  return c;
}

namespace exec_generic {
#include "blocks/executor_body.inc"
}  // namespace exec_generic

#if defined(RTPLC_HAVE_AVX2_EXECUTOR)
namespace exec_avx2 {
uint64_t execute_runs_impl(const ExecContext& ctx, uint32_t first, uint32_t last) noexcept;  // executor_avx2.cpp
}
#endif

namespace {

using RunsFn = uint64_t (*)(const ExecContext&, uint32_t, uint32_t) noexcept;

// Chosen once, before main: the AVX2 body on CPUs that have it (about twice as
// fast on wide runs), the baseline body otherwise. RTPLC_EXECUTOR=generic forces
// the baseline, for comparison and for the tests that check both agree.
bool pick_avx2() {
#if defined(RTPLC_HAVE_AVX2_EXECUTOR)
  const char* force = std::getenv("RTPLC_EXECUTOR");
  const bool generic = force != nullptr && std::strcmp(force, "generic") == 0;
  __builtin_cpu_init();
  return !generic && __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

const bool g_avx2 = pick_avx2();
#if defined(RTPLC_HAVE_AVX2_EXECUTOR)
const RunsFn g_runs = g_avx2 ? exec_avx2::execute_runs_impl : exec_generic::execute_runs_impl;
#else
const RunsFn g_runs = exec_generic::execute_runs_impl;
#endif

// The native code hands back the runs it does not compile (native_abi.h).
uint64_t interpret_run(const void* context, uint32_t run) {
  return g_runs(*static_cast<const ExecContext*>(context), run, run + 1);
}

uint64_t run_native(const ExecContext& ctx) noexcept {
  const RtplcNativeFrame frame{ctx.params, ctx.values,     ctx.state,     ctx.errors,
                               ctx.loop_budget, ctx.loop_fault, &interpret_run, &ctx};
  return ctx.native(&frame);
}

// One cycle: the loop fault cleared, the program run (by a body or as native
// code), the cycle and its failures counted.
template <class Program>
void run_cycle(const ExecContext& ctx, Program program) noexcept {
  if (ctx.loop_fault != nullptr) *ctx.loop_fault = 0;
  const uint64_t bad = program();
  ++*ctx.cycles;
  if (bad != 0) *ctx.total_errors += bad;
}

}  // namespace

void execute_cycle(const ExecContext& ctx) noexcept {
  run_cycle(ctx, [&ctx] { return ctx.native != nullptr ? run_native(ctx) : g_runs(ctx, 0, ctx.n_runs); });
}

bool executor_body_available(ExecutorBody body) {
#if defined(RTPLC_HAVE_AVX2_EXECUTOR)
  if (body == ExecutorBody::kAvx2) {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2");
  }
#endif
  return body == ExecutorBody::kBaseline;
}

void execute_cycle_on(ExecutorBody body, const ExecContext& ctx) noexcept {
  RunsFn runs = exec_generic::execute_runs_impl;
#if defined(RTPLC_HAVE_AVX2_EXECUTOR)
  if (body == ExecutorBody::kAvx2 && executor_body_available(body)) runs = exec_avx2::execute_runs_impl;
#endif
  (void)body;
  run_cycle(ctx, [&ctx, runs] { return runs(ctx, 0, ctx.n_runs); });
}

const char* executor_variant() { return g_avx2 ? "avx2" : "baseline"; }

}  // namespace rtplc
