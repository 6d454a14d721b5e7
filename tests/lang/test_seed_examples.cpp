// Both examples of the seed compile verbatim: as the spec quotes them, and the
// PID example exactly as the paper prints it (blank lines, no second '%%').
#include <gtest/gtest.h>

#include "lang/compiler.h"

namespace rtplc::lang {
namespace {

const std::string kSrc = RTPLC_SOURCE_DIR;

TEST(SeedExamples, figure_4_compiles_with_one_delayed_reference) {
  CompileResult r = compile_file(kSrc + "/examples/seed_loop.fbd");
  ASSERT_TRUE(r.ok()) << r.diags.render("seed_loop.fbd", "");
  EXPECT_EQ(r.image->header().n_instr, 7u);
  EXPECT_EQ(r.image->bindings().size(), 3u);
  int delayed = 0;
  for (const FlatBlock& b : r.program.blocks) {
    for (uint32_t k = 0; k < b.n_in; ++k) delayed += b.delayed[k];
  }
  EXPECT_EQ(delayed, 1);  // F21 reads F41
  EXPECT_EQ(r.diags.error_count(), 0u);
}

TEST(SeedExamples, pid_example_compiles_as_the_spec_quotes_it) {
  CompileResult r = compile_file(kSrc + "/examples/seed_pid.fbd");
  ASSERT_TRUE(r.ok()) << r.diags.render("seed_pid.fbd", "");
  EXPECT_EQ(r.program.macro_calls, 1u);
  EXPECT_EQ(r.image->header().n_instr, 7u);
  EXPECT_DOUBLE_EQ(r.image->period_s(), 0.1);
  EXPECT_EQ(r.diags.warning_count(), 0u);
}

TEST(SeedExamples, pid_example_compiles_as_the_paper_prints_it) {
  CompileResult paper = compile_file(kSrc + "/tests/lang/data/seed_pid_paper.fbd");
  CompileResult spec = compile_file(kSrc + "/examples/seed_pid.fbd");
  ASSERT_TRUE(paper.ok()) << paper.diags.render("paper", "");
  ASSERT_TRUE(spec.ok());
  // Same program: same code, parameters and bindings (only source positions differ).
  ASSERT_EQ(paper.image->code().size(), spec.image->code().size());
  for (size_t i = 0; i < spec.image->code().size(); ++i) {
    EXPECT_EQ(paper.image->code()[i].op, spec.image->code()[i].op);
    EXPECT_EQ(paper.image->code()[i].in[0], spec.image->code()[i].in[0]);
  }
  EXPECT_EQ(std::vector<double>(paper.image->params().begin(), paper.image->params().end()),
            std::vector<double>(spec.image->params().begin(), spec.image->params().end()));
}

}  // namespace
}  // namespace rtplc::lang
