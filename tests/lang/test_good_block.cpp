// The `good` block (a program's view of its inputs' quality): what the
// compiler makes of it, and what the checks refuse, with the position.
#include <gtest/gtest.h>

#include <string>

#include "blocks/executor.h"
#include "lang/compiler.h"

namespace rtplc::lang {
namespace {

std::string errors_of(const std::string& src) {
  CompileResult r = compile_source(src);
  EXPECT_FALSE(r.ok());
  return r.diags.render("p.fbd", src);
}

TEST(GoodBlock, reads_the_quality_of_its_input_blocks_channel_into_a_slot_of_its_own) {
  const std::string src =
      "%%\nF1 = prr(p1, d0, c0, \"Level\")\nD2 = good(F1)\nD3 = ddi(p0, d0, c4, \"Run\")\n"
      "D4 = good(D3)\nD5 = and(D2, D4)\nF6 = asp(d0, c0, -5, \"Fallback\")\n"
      "F7 = amux(F6, F1, D5)\ndao(F7, p0, d0, c9, \"Safe\")\nEND\n";
  CompileResult r = compile_source(src);
  ASSERT_TRUE(r.ok()) << r.diags.render("p.fbd", src);
  const TaskImage& img = *r.image;
  int quality = 0;
  for (const Binding& b : img.bindings()) {
    if (b.dir != BindingDir::kQuality) continue;
    ++quality;
    const std::string label = img.str(b.label);
    // The same channel (key and label) as the input it watches, its own slot.
    for (const Binding& v : img.bindings()) {
      if (v.dir != BindingDir::kInput || img.str(v.label) != label) continue;
      EXPECT_EQ(binding_key(v), binding_key(b)) << label;
      EXPECT_EQ(v.kind, b.kind) << label;
      EXPECT_NE(v.io_index, b.io_index) << label;
    }
    EXPECT_TRUE(label == "Level" || label == "Run") << label;
  }
  EXPECT_EQ(quality, 2);
  // The executor loads it as a digital input: 1 in the slot, 1 out.
  TaskArena arena(img);
  for (const Binding& b : img.bindings()) {
    if (b.dir == BindingDir::kInput) arena.io_in[b.io_index] = std::string(img.str(b.label)) == "Level" ? 7 : 1;
    if (b.dir == BindingDir::kSetpoint) arena.io_in[b.io_index] = b.init;
  }
  auto run_with = [&](double q_level) {
    for (const Binding& b : img.bindings()) {
      if (b.dir == BindingDir::kQuality) arena.io_in[b.io_index] = std::string(img.str(b.label)) == "Level" ? q_level : 1;
    }
    execute_cycle(make_context(img, arena));
    for (const Binding& b : img.bindings()) {
      if (b.dir == BindingDir::kOutput) return arena.io_out[b.io_index];
    }
    return -1.0;
  };
  EXPECT_EQ(run_with(1), 7);   // good: the measurement
  EXPECT_EQ(run_with(0), -5);  // bad: the safe branch
  EXPECT_NE(explain(r).find("quality"), std::string::npos);
}

TEST(GoodBlock, takes_only_an_input_block_and_says_so_at_the_block) {
  const std::string computed = errors_of(
      "%%\nF1 = asp(d0, c0, 1, \"SP\")\nF2 = sqrt(F1)\nD3 = good(F2)\nddo(D3, p0, d0, c1, \"Ok\")\nEND\n");
  EXPECT_NE(computed.find("p.fbd:4:"), std::string::npos) << computed;
  EXPECT_NE(computed.find("good reads the quality of an input block"), std::string::npos) << computed;
  EXPECT_NE(computed.find("F2 is sqrt, which reads no channel"), std::string::npos) << computed;

  const std::string setpoint =
      errors_of("%%\nF1 = asp(d0, c0, 1, \"SP\")\nD3 = good(F1)\nddo(D3, p0, d0, c1, \"Ok\")\nEND\n");
  EXPECT_NE(setpoint.find("a set-point, which is always good"), std::string::npos) << setpoint;

  const std::string arity = errors_of("%%\nF1 = dai(p0, d0, c0, \"PV\")\nD3 = good(F1, 2)\nddo(D3, p0, d0, c1, \"Ok\")\nEND\n");
  EXPECT_NE(arity.find("good takes good(input)"), std::string::npos) << arity;

  // Its result is digital: an analog id for it is refused as for any block.
  const std::string kind = errors_of("%%\nF1 = dai(p0, d0, c0, \"PV\")\nF3 = good(F1)\ndao(F3, p0, d0, c1, \"Ok\")\nEND\n");
  EXPECT_NE(kind.find("p.fbd:3:"), std::string::npos) << kind;
}

}  // namespace
}  // namespace rtplc::lang
