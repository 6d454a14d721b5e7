// The measuring tank closed loop (docs/sfc.md, "The measuring tank"):
// examples/tank.sfc against the measuring-tank plant of `rtplc sim`.
#include <gtest/gtest.h>

#include <string>

#include "io/drivers/sim/plant.h"
#include "lang/compiler.h"
#include "sim/sim_loop.h"

namespace rtplc {
namespace {

int column(const io::SimTrace& tr, const std::string& name) {
  for (size_t c = 0; c < tr.columns.size(); ++c) {
    if (tr.columns[c] == name) return static_cast<int>(c);
  }
  ADD_FAILURE() << "no column " << name;
  return 0;
}

TEST(SfcSim, the_tank_measures_again_and_again_one_step_at_a_time) {
  lang::CompileResult r = lang::compile_file(RTPLC_SOURCE_DIR "/examples/tank.sfc");
  ASSERT_TRUE(r.ok());
  auto plant = io::make_plant("measuring-tank");
  ASSERT_TRUE(plant) << plant.error();
  io::SimOptions opt;
  opt.duration = 40;
  auto tr = io::run_closed_loop(*r.image, **plant, opt);
  ASSERT_TRUE(tr) << tr.error();
  const size_t level = static_cast<size_t>(column(*tr, "plant.level"));
  const size_t v1 = static_cast<size_t>(column(*tr, "valve1")),
               v2 = static_cast<size_t>(column(*tr, "valve2"));
  size_t step_col[7];
  for (int i = 0; i < 7; ++i)
    step_col[i] = static_cast<size_t>(column(*tr, "tank.S" + std::to_string(i)));
  int cycles = 0;
  double top = 0;
  for (size_t k = 0; k < tr->rows.size(); ++k) {
    const auto& row = tr->rows[k];
    int active = 0;
    for (size_t c : step_col) active += row[c] == 1 ? 1 : 0;
    ASSERT_EQ(active, 1) << "t = " << row[0];
    ASSERT_FALSE(row[v1] == 1 && row[v2] == 1) << "never both valves, t = " << row[0];
    top = std::max(top, row[level]);
    if (k > 0 && row[step_col[6]] == 1 && tr->rows[k - 1][step_col[6]] == 0) ++cycles;
  }
  EXPECT_GE(cycles, 3) << "fill, measure, drain, back to waiting";
  EXPECT_GE(top, 0.9);
  EXPECT_LT(top, 1.0) << "valve 1 closes at LS1, the tank never overflows";
}

TEST(SfcSim, the_plant_names_the_output_it_misses) {
  lang::CompileResult r = lang::compile_source(
      "SFC x\nOUTPUT Q = ddo(p0, d1, c0, \"valve1\")\n"
      "INITIAL STEP A\nN Q\nEND_STEP\n"
      "TRANSITION t FROM A TO A WHEN TRUE\n");
  ASSERT_TRUE(r.ok());
  auto plant = io::make_plant("measuring-tank");
  ASSERT_TRUE(plant);
  auto tr = io::run_closed_loop(*r.image, **plant, io::SimOptions{});
  ASSERT_FALSE(tr);
  EXPECT_NE(tr.error().find("\"valve2\""), std::string::npos) << tr.error();
}

}  // namespace
}  // namespace rtplc
