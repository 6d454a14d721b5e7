// The editor's model against the real front end: every example loads as a
// diagram and saves back to a program the compiler turns into the same image
// (image_identity); the automatic layout puts inputs on top, outputs at the
// bottom, no two blocks on one cell, every wire between placed blocks; the
// sidecar and the page's JSON give back what they were given; the compiler's
// errors land on the block and argument they concern; malformed input from
// the page is refused with a reason.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "blocks/registry.h"
#include "editor/diagram.h"
#include "lang/compiler.h"

namespace rtplc::editor {
namespace {

using nlohmann::json;

static std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::vector<std::filesystem::path> fbd_examples() {
  std::vector<std::filesystem::path> out;
  for (const auto& e : std::filesystem::directory_iterator(std::string(RTPLC_SOURCE_DIR) + "/examples")) {
    if (e.path().extension() == ".fbd") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

static Diagram load(const std::string& text) {
  auto d = from_text(text);
  EXPECT_TRUE(d.ok()) << (d.ok() ? "" : d.error());
  return d.ok() ? std::move(d).value() : Diagram{};
}

TEST(EditorRoundTrip, every_example_saved_from_its_diagram_compiles_to_the_same_program) {
  const auto files = fbd_examples();
  ASSERT_GE(files.size(), 10u);
  size_t compiled = 0;
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    const std::string text = slurp(f);
    const lang::CompileResult original = lang::compile_source(text);
    Diagram d = load(text);
    auto_layout(d);
    // Through the page's JSON and back, as the browser does.
    auto back = diagram_from_json(json::parse(diagram_json(d).dump()));
    ASSERT_TRUE(back.ok()) << back.error();
    const CheckResult saved = check(*back);
    if (original.ok()) {
      ASSERT_TRUE(saved.ok) << saved.rendered << "\n" << saved.text;
      EXPECT_EQ(saved.identity, image_identity(*original.image)) << saved.text;
      ++compiled;
    } else {
      // A program with errors keeps exactly its errors (a line a message
      // names is the saved text's).
      std::vector<std::string> want, got;
      const std::regex line_no("line [0-9]+");
      for (const Diagnostic& x : original.diags.items()) want.push_back(std::regex_replace(x.message, line_no, "line N"));
      for (const BlockDiagnostic& x : saved.diagnostics) got.push_back(std::regex_replace(x.diag.message, line_no, "line N"));
      EXPECT_EQ(got, want);
    }
    // Saving again changes nothing: the text is stable.
    EXPECT_EQ(to_text(load(saved.text)), saved.text);
  }
  EXPECT_GE(compiled, 10u);
}

TEST(EditorRoundTrip, the_identity_sees_a_changed_gain_and_ignores_spacing_and_comments) {
  const std::string a = slurp(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd");
  const auto base = lang::compile_source(a);
  ASSERT_TRUE(base.ok());
  std::string spaced = "// a comment\n\n" + a;
  const auto b = lang::compile_source(spaced);
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(image_identity(*b.image), image_identity(*base.image));
  EXPECT_NE(b.image->header().source_hash, base.image->header().source_hash);
  Diagram d = load(a);
  for (DBlock& blk : d.blocks) {
    if (blk.macro) blk.args[2].number = 5;  // the PID's gain
  }
  const CheckResult changed = check(d);
  ASSERT_TRUE(changed.ok) << changed.rendered;
  EXPECT_NE(changed.identity, image_identity(*base.image));
}

// The layout's promises, on every example.
TEST(EditorLayout, inputs_above_computations_above_outputs_one_block_a_cell_every_wire_drawn) {
  for (const auto& f : fbd_examples()) {
    SCOPED_TRACE(f.filename().string());
    Diagram d = load(slurp(f));
    auto_layout(d);
    std::set<std::pair<int, int>> cells;
    int lowest_input = -1, highest_output = 1 << 30, lowest_compute = -1, highest_compute = 1 << 30;
    for (const DBlock& b : d.blocks) {
      ASSERT_GE(b.col, 0) << b.kind;
      ASSERT_GE(b.row, 0) << b.kind;
      EXPECT_TRUE(cells.insert({b.col, b.row}).second) << "two blocks on " << b.col << "," << b.row;
      const BlockSpec* s = b.macro ? nullptr : find_block(b.kind);
      const bool in = s && (s->signature == Signature::kDeviceIn || s->signature == Signature::kSetpoint);
      const bool out = s && s->signature == Signature::kDeviceOut;
      if (in) lowest_input = std::max(lowest_input, b.row);
      if (out) highest_output = std::min(highest_output, b.row);
      if (!in && !out) {
        lowest_compute = std::max(lowest_compute, b.row);
        highest_compute = std::min(highest_compute, b.row);
      }
    }
    EXPECT_LT(lowest_input, highest_output);
    if (lowest_compute >= 0) {
      EXPECT_LT(lowest_input, highest_compute);
      EXPECT_LT(lowest_compute, highest_output);
    }
    // Every wire joins two placed blocks (or names a block that does not
    // exist, which the compiler reports).
    const json j = diagram_json(d);
    for (const json& w : j["wires"]) {
      if (w["from_block"].is_null()) continue;
      const json& from = j["blocks"][w["from_block"].get<size_t>()];
      const json& to = j["blocks"][w["to_block"].get<size_t>()];
      EXPECT_GE(from["col"].get<int>(), 0);
      EXPECT_GE(to["col"].get<int>(), 0);
      if (!w["feedback"].get<bool>()) {
        EXPECT_LT(from["row"].get<int>(), to["row"].get<int>()) << w.dump();
      }
    }
    for (const DMacro& m : d.macros) {
      std::set<std::pair<int, int>> mc;
      for (const DBlock& b : m.blocks) {
        EXPECT_GE(b.row, 1) << "row 0 of a macro is its formals'";
        EXPECT_TRUE(mc.insert({b.col, b.row}).second);
      }
    }
  }
}

TEST(EditorLayout, the_seed_pid_loop_on_its_grid) {
  Diagram d = load(slurp(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd"));
  auto_layout(d);
  ASSERT_EQ(d.blocks.size(), 4u);  // dai, asp, the PID macro, dao
  EXPECT_EQ(d.blocks[0].row, 0);
  EXPECT_EQ(d.blocks[1].row, 0);
  EXPECT_EQ(d.blocks[2].row, 1);
  EXPECT_EQ(d.blocks[3].row, 2);
  // The macro sits between its inputs; the output under the macro.
  EXPECT_EQ(d.blocks[3].col, d.blocks[2].col);
  EXPECT_EQ(d.cols, 7);
  EXPECT_EQ(d.rows, 5);
}

TEST(EditorLayout, a_row_wider_than_the_grid_spills_onto_the_next_row) {
  std::string text = "%%\nstime(0.1)\n";
  for (int k = 0; k < 10; ++k)
    text += "F" + std::to_string(k + 1) + " = asp(d0, c" + std::to_string(k) + ", 1, \"S" + std::to_string(k) + "\")\n";
  text += "dao(F1, p0, d0, c0, \"OUT\")\nEND\n";
  Diagram d = load(text);
  auto_layout(d);
  std::set<int> input_rows;
  for (size_t i = 0; i < 10; ++i) {
    EXPECT_LT(d.blocks[i].col, 7);
    input_rows.insert(d.blocks[i].row);
  }
  EXPECT_EQ(input_rows, (std::set<int>{0, 1}));
  EXPECT_EQ(d.blocks[10].row, 2);
}

TEST(EditorLayout, the_sidecar_keeps_cells_and_new_blocks_find_free_ones) {
  const std::string text = slurp(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd");
  Diagram d = load(text);
  auto_layout(d);
  d.blocks[0].col = 5;  // the user moved ProcVal
  d.blocks[0].row = 0;
  const json sidecar = layout_json(d);
  EXPECT_EQ(sidecar["cells"]["F1"], json::array({5, 0}));
  EXPECT_EQ(sidecar["cells"]["out:ManiVal"], json::array({d.blocks[3].col, d.blocks[3].row}));
  Diagram again = load(text);
  ASSERT_TRUE(apply_layout(again, sidecar).ok());
  auto_layout(again);
  EXPECT_EQ(again.blocks[0].col, 5);
  EXPECT_EQ(layout_json(again), sidecar);
  // A sidecar from an older text: the block it does not know gets a free cell.
  Diagram grown = load(text);
  grown.blocks.insert(grown.blocks.begin() + 2, DBlock{"F3", "filt", false, {{DArg::Kind::kRef, "F1", 0}, {DArg::Kind::kNumber, "", 2}}, -1, -1});
  ASSERT_TRUE(apply_layout(grown, sidecar).ok());
  auto_layout(grown);
  std::set<std::pair<int, int>> cells;
  for (const DBlock& b : grown.blocks) EXPECT_TRUE(cells.insert({b.col, b.row}).second);
  EXPECT_FALSE(apply_layout(grown, json{{"format", "something else"}}).ok());
}

TEST(EditorCheck, an_error_lands_on_its_block_and_argument_with_the_checks_message) {
  Diagram d = load(slurp(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd"));
  d.blocks[3].args[0].text = "F9";  // dao reads a block that does not exist
  const CheckResult r = check(d, "pid.fbd");
  EXPECT_FALSE(r.ok);
  ASSERT_FALSE(r.diagnostics.empty());
  const BlockDiagnostic& e = r.diagnostics[0];
  ASSERT_TRUE(e.block.has_value());
  EXPECT_EQ(*e.block, 3u);
  ASSERT_TRUE(e.arg.has_value());
  EXPECT_EQ(*e.arg, 0u);
  EXPECT_EQ(e.macro, "");
  EXPECT_NE(e.diag.message.find("F9"), std::string::npos) << e.diag.message;
  EXPECT_NE(r.rendered.find("pid.fbd:" + std::to_string(e.diag.pos.line) + ":"), std::string::npos) << r.rendered;
  // Inside a macro: a parameter out of its range.
  Diagram m = load(slurp(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd"));
  ASSERT_EQ(m.macros.size(), 1u);
  m.macros[0].blocks[2].args[0].text = "M9";
  const CheckResult rm = check(m);
  EXPECT_FALSE(rm.ok);
  ASSERT_FALSE(rm.diagnostics.empty());
  EXPECT_EQ(rm.diagnostics[0].macro, "PID");
  EXPECT_EQ(rm.diagnostics[0].block, std::optional<size_t>(2));
}

TEST(EditorJson, the_page_cannot_smuggle_text_into_the_program) {
  Diagram d = load(slurp(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd"));
  json j = diagram_json(d);
  auto refused = [&](json bad, const std::string& why) {
    auto r = diagram_from_json(bad);
    EXPECT_FALSE(r.ok()) << bad.dump();
    if (!r.ok()) {
      EXPECT_NE(r.error().find(why), std::string::npos) << r.error();
    }
  };
  json a = j;
  a["blocks"][0]["args"][3] = {{"string", "PV\")\nF2 = asp("}};
  refused(a, "label");
  a = j;
  a["blocks"][0]["kind"] = "dai(p0); x";
  refused(a, "kind");
  a = j;
  a["blocks"][0]["args"][0] = {{"device", "p0, d1"}};
  refused(a, "device");
  a = j;
  a["blocks"][1]["args"][2] = {{"number", "50"}};
  refused(a, "argument 3");
  a = j;
  a["blocks"] = "none";
  refused(a, "blocks");
  a = j;
  a["macros"][0]["analog"] = "two";
  refused(a, "malformed");
  // And what it may send comes back as it was.
  auto ok = diagram_from_json(j);
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(diagram_json(*ok), j);
}

TEST(EditorText, a_syntax_error_is_refused_with_its_position) {
  DiagnosticList diags;
  auto d = from_text("%%\nF1 = dai(p0, d0, c0 \"X\")\nEND\n", &diags);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().rfind("2:", 0), 0u) << d.error();
  EXPECT_TRUE(diags.has_errors());
}

}  // namespace
}  // namespace rtplc::editor

#include <sys/stat.h>
#include <unistd.h>

#include "editor/workspace.h"
#include "tests/support/scratch.h"

namespace rtplc::editor {
namespace {

TEST(EditorWorkspace, saves_and_loads_programs_with_their_sidecars_and_never_through_a_link) {
  test::Scratch dir{"rtplc-workspace"};
  auto w = Workspace::open(dir.path("ws"));
  ASSERT_TRUE(w.ok()) << w.error();
  const json layout = {{"format", "rtplc-fbd-layout"}, {"version", 1}, {"cells", json::object()}};
  ASSERT_TRUE(w->save("loop.fbd", "%%\nEND\n", &layout).ok());
  ASSERT_TRUE(w->save("plain.fbd", "%%\nEND\n", nullptr).ok());
  auto files = w->list();
  ASSERT_TRUE(files.ok());
  ASSERT_EQ(files->size(), 2u);
  EXPECT_EQ((*files)[0].name, "loop.fbd");
  EXPECT_TRUE((*files)[0].has_layout);
  EXPECT_FALSE((*files)[1].has_layout);
  auto f = w->load("loop.fbd");
  ASSERT_TRUE(f.ok()) << f.error();
  EXPECT_EQ(f->text, "%%\nEND\n");
  ASSERT_TRUE(f->layout.has_value());
  EXPECT_EQ(*f->layout, layout);
  // Names that leave the folder, or are not programs, are refused.
  for (const char* bad : {"../x.fbd", "a/b.fbd", ".hidden.fbd", "x.txt", "x..fbd", ""}) {
    EXPECT_FALSE(w->save(bad, "%%\nEND\n", nullptr).ok()) << bad;
    EXPECT_FALSE(w->load(bad).ok()) << bad;
  }
  // A link planted in the workspace is neither listed, read nor written through.
  const std::string secret = dir.path("secret.fbd");
  {
    std::ofstream(secret) << "secret";
  }
  ASSERT_EQ(::symlink(secret.c_str(), dir.path("ws/link.fbd").c_str()), 0);
  files = w->list();
  ASSERT_TRUE(files.ok());
  EXPECT_EQ(files->size(), 2u);
  EXPECT_FALSE(w->load("link.fbd").ok());
  EXPECT_FALSE(w->save("link.fbd", "overwritten", nullptr).ok());
  EXPECT_EQ(slurp(secret), "secret");
  ASSERT_EQ(::symlink(secret.c_str(), dir.path("ws/plain.fbd.layout").c_str()), 0);
  EXPECT_FALSE(w->save("plain.fbd", "%%\nEND\n", &layout).ok());
  EXPECT_EQ(slurp(secret), "secret");
}

}  // namespace
}  // namespace rtplc::editor
