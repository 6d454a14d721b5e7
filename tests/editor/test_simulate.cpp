// The editor's simulation against `rtplc sim`'s own loop: the seed's PID loop
// opened as a diagram and simulated from the page's request gives the same
// cycles, the same CSV and the same step figures as run_closed_loop on the
// example file; a diagram that does not compile answers with the compiler's
// verdict; bad requests (plant, duration, steps) are refused naming the field.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "editor/simulate.h"
#include "io/drivers/sim/plant.h"
#include "lang/compiler.h"
#include "sim/sim_loop.h"

namespace rtplc::editor {
namespace {

using nlohmann::json;

std::string seed_pid_text() {
  std::ifstream f(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd");
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST(EditorSimulate, gives_what_rtplc_sim_gives_for_the_same_program_and_plant) {
  auto d = from_text(seed_pid_text());
  ASSERT_TRUE(d) << d.error();
  const json req = {{"plant", "fopdt:K=2,T=4,L=0.5"},
                    {"duration", 40},
                    {"steps", json::array({{{"label", "Setpoint"}, {"value", 60}, {"at", 20}}})}};
  auto out = simulate(*d, req);
  ASSERT_TRUE(out) << out.error();
  ASSERT_TRUE((*out)["compiles"].get<bool>()) << out->dump();

  lang::CompileResult c = lang::compile_file(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd");
  ASSERT_TRUE(c.ok());
  auto plant = io::make_plant("fopdt:K=2,T=4,L=0.5");
  ASSERT_TRUE(plant);
  io::SimOptions opt;
  opt.duration = 40;
  opt.steps.push_back({"Setpoint", 60, 20});
  auto tr = io::run_closed_loop(*c.image, **plant, opt);
  ASSERT_TRUE(tr) << tr.error();
  const auto m = io::step_metrics(*tr);

  EXPECT_EQ((*out)["cycles"].get<size_t>(), tr->rows.size());
  EXPECT_EQ((*out)["columns"].get<std::vector<std::string>>(), tr->columns);
  std::string csv = io::csv_header_line(tr->columns);
  for (const auto& r : tr->rows) csv += io::csv_row_line(r.data(), r.size());
  EXPECT_EQ((*out)["csv"].get<std::string>(), csv);
  EXPECT_EQ((*out)["figures"].get<std::string>(), io::format_metrics(*tr, m));
  ASSERT_EQ((*out)["metrics"].size(), m.size());
  ASSERT_EQ(m.size(), 2u);  // from the start, and the step at 20 s
  EXPECT_DOUBLE_EQ((*out)["metrics"][1]["at"].get<double>(), m[1].at);
  EXPECT_DOUBLE_EQ((*out)["metrics"][1]["overshoot_pct"].get<double>(), m[1].overshoot_pct);
  EXPECT_DOUBLE_EQ((*out)["metrics"][1]["rise_time"].get<double>(), m[1].rise_time);
  EXPECT_EQ((*out)["pv"].get<int>(), tr->pv_column);
  // The plot rows are a thinning of the trace: first and last rows kept.
  const json& rows = (*out)["rows"];
  ASSERT_LE(rows.size(), kPlotRows + 1);
  EXPECT_EQ(rows.front().get<std::vector<double>>(), tr->rows.front());
  EXPECT_EQ(rows.back().get<std::vector<double>>(), tr->rows.back());
}

TEST(EditorSimulate, answers_with_the_compilers_verdict_when_the_diagram_does_not_compile) {
  auto d = from_text("%%\nF1 = asp(d0, c0, 1, \"SP\")\ndao(F7, p0, d0, c0, \"OUT\")\nEND\n");
  ASSERT_TRUE(d) << d.error();
  auto out = simulate(*d, json::object());
  ASSERT_TRUE(out) << out.error();
  EXPECT_FALSE((*out)["compiles"].get<bool>());
  ASSERT_FALSE((*out)["diagnostics"].empty());
  EXPECT_EQ((*out)["diagnostics"][0]["block"], 1);
  EXPECT_FALSE(out->contains("csv"));
}

TEST(EditorSimulate, refuses_bad_requests_naming_what_is_wrong) {
  auto d = from_text(seed_pid_text());
  ASSERT_TRUE(d);
  struct Case {
    json req;
    const char* says;
  } cases[] = {
      {{{"plant", "no-such-plant"}}, "plant no-such-plant"},
      {{{"duration", 0}}, "duration"},
      {{{"duration", 1e9}}, "duration"},
      {{{"duration", "long"}}, "duration must be a number"},
      {{{"steps", json::array({{{"label", "Setpoint"}, {"value", 1}, {"at", 99}}})}}, "within the run"},
      {{{"steps", json::array({{{"value", 1}, {"at", 1}}})}}, "a step is"},
      {{{"steps", "Setpoint=1@2"}}, "steps must be a list"},
  };
  for (const Case& c : cases) {
    auto out = simulate(*d, c.req);
    ASSERT_FALSE(out) << c.req.dump();
    EXPECT_NE(out.error().find(c.says), std::string::npos) << c.req.dump() << ": " << out.error();
  }
}

}  // namespace
}  // namespace rtplc::editor
