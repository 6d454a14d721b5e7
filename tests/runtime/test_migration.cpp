// State migration across a swap, in virtual time: a program swapped for an
// identical one mid-run must produce bit for bit the trace of an unswapped run;
// a PID whose integral time changes stays bumpless.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "io/drivers/sim/plant.h"
#include "lang/compiler.h"
#include "sched/program.h"

namespace rtplc::sched {
namespace {

const std::string kSrc = RTPLC_SOURCE_DIR;

TaskImage compile(const std::string& src) {
  auto r = lang::compile_source(src);
  EXPECT_TRUE(r.ok()) << r.diags.render("t", src);
  return std::move(*r.image);
}

std::string pid_program(double ti, const std::string& extra = "") {
  return "%%\nstime(0.1)\nF1 = dai(p0, d0, c0, \"PV\")\nF2 = asp(d0, c0, 50, \"SP\")\n"
         "F3 = pid(F2, F1, 2, " + std::to_string(ti) + ", 0.5)\nF4 = filt(F3, 0.3)\n"
         "F5 = dely(F4, 3)\nD6 = dsp(d0, c1, 1, \"EN\")\nD7 = time(D6, 0.5)\n" + extra +
         "dao(F5, p0, d0, c0, \"MV\")\nEND\n";
}

// Runs `cycles` cycles of a closed loop against 1/(s^2+s+1), swapping to
// `next` at `swap_at` (never if < 0). Returns the MV trace.
std::vector<double> run(const std::string& first, const std::string& next, int swap_at, int cycles) {
  TaskImage img = compile(first);
  auto a = std::make_unique<LoadedProgram>();
  a->image = std::move(img);
  a->arena.resize_for(a->image);
  auto plant = std::move(io::make_plant("second-order")).value();
  std::vector<double> mv;
  LoadedProgram* cur = a.get();
  std::unique_ptr<LoadedProgram> b;
  auto set_inputs = [&](LoadedProgram& p, double pv) {
    for (const Binding& bd : p.image.bindings()) {
      if (bd.dir == BindingDir::kSetpoint) p.arena.io_in[bd.io_index] = bd.init;
      if (bd.dir == BindingDir::kInput) p.arena.io_in[bd.io_index] = pv;
    }
  };
  for (int k = 0; k < cycles; ++k) {
    if (k == swap_at) {
      b = std::make_unique<LoadedProgram>();
      b->image = compile(next);
      b->arena.resize_for(b->image);
      b->migration = plan_migration(cur->image, b->image);
      apply_migration(b->migration, cur->arena, b->arena);
      cur = b.get();
    }
    set_inputs(*cur, plant->output());
    execute_cycle(cur->image, cur->arena);
    const double u = cur->arena.io_out[0];
    mv.push_back(u);
    for (int s = 0; s < 10; ++s) plant->step(u, 0.01);
  }
  return mv;
}

TEST(Migration, swapping_in_the_same_program_changes_nothing_bit_for_bit) {
  const std::string p = pid_program(3);
  const std::vector<double> plain = run(p, p, -1, 400);
  for (int at : {1, 2, 7, 100, 399}) {
    const std::vector<double> swapped = run(p, p, at, 400);
    ASSERT_EQ(std::memcmp(plain.data(), swapped.data(), plain.size() * sizeof(double)), 0)
        << "swap at cycle " << at;
  }
}

TEST(Migration, a_changed_block_elsewhere_keeps_every_matching_state) {
  // An added, unrelated block: the loop's blocks keep their state, so the MV
  // trace is still identical.
  const std::string p = pid_program(3);
  const std::string q = pid_program(3, "F9 = abs(F4)\nF8 = add(F9, F1)\n");
  auto with_extra = run(p, q, 150, 300);
  auto plain = run(p, p, -1, 300);
  EXPECT_EQ(std::memcmp(plain.data(), with_extra.data(), plain.size() * sizeof(double)), 0);
}

TEST(Migration, pid_stays_bumpless_when_its_integral_time_changes) {
  // The integral is stored already divided by Ti, so at the swap the output
  // continues from where it was; only its slope changes.
  const std::vector<double> a = run(pid_program(3), pid_program(6), 200, 260);
  const std::vector<double> plain = run(pid_program(3), pid_program(3), -1, 260);
  // The swapped cycle's output differs from the unswapped one only by this
  // cycle's integral increment, far below the loop's normal cycle-to-cycle moves.
  double max_step = 0;
  for (size_t k = 150; k < 200; ++k) max_step = std::max(max_step, std::fabs(plain[k] - plain[k - 1]));
  EXPECT_LT(std::fabs(a[203] - plain[203]), 1e-2 + max_step);
  EXPECT_EQ(a[199], plain[199]);
}

TEST(Migration, reports_what_was_kept_reset_added_and_removed) {
  const TaskImage a = compile(pid_program(3, "F9 = intg(F1, 2)\nF8 = abs(F9)\n"));
  const TaskImage b = compile(pid_program(3, "F9 = filt(F1, 2)\nF10 = abs(F9)\n"));
  const Migration m = plan_migration(a, b);
  auto has = [](const std::vector<std::string>& v, const char* n) {
    return std::find(v.begin(), v.end(), n) != v.end();
  };
  EXPECT_TRUE(has(m.kept, "F3"));   // the PID
  EXPECT_TRUE(has(m.kept, "F5"));   // the delay line
  EXPECT_TRUE(has(m.reset, "F9"));  // same id, another block: starts fresh
  EXPECT_TRUE(has(m.added, "F10"));
  EXPECT_TRUE(has(m.removed, "F8"));
}

TEST(Migration, a_delay_line_of_another_length_is_reset_not_copied) {
  const TaskImage a = compile(pid_program(3));
  std::string src = pid_program(3);
  src.replace(src.find("dely(F4, 3)"), 11, "dely(F4, 5)");
  const TaskImage b = compile(src);
  const Migration m = plan_migration(a, b);
  EXPECT_NE(std::find(m.reset.begin(), m.reset.end(), "F5"), m.reset.end());
}

}  // namespace
}  // namespace rtplc::sched
