// The block registry: the 58 blocks of the spec and `good`, consistent metadata, and the
// generated reference docs/blocks.md kept in step with it.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "blocks/ops.h"
#include "blocks/registry.h"

namespace rtplc {
namespace {

TEST(Registry, has_the_58_blocks_of_the_five_groups_good_and_the_iec_set) {
  std::map<BlockGroup, int> per_group;
  for (const BlockSpec& b : all_blocks()) per_group[b.group]++;
  EXPECT_EQ(all_blocks().size(), 60u + static_cast<size_t>(per_group[BlockGroup::kIec]));
  EXPECT_EQ(per_group[BlockGroup::kIec], 42);
  EXPECT_EQ(per_group[BlockGroup::kInput], 14);  // 13 of the seed and `good`
  EXPECT_EQ(per_group[BlockGroup::kOutput], 10);
  EXPECT_EQ(per_group[BlockGroup::kArithmetic], 16);
  EXPECT_EQ(per_group[BlockGroup::kLogic], 6);
  EXPECT_EQ(per_group[BlockGroup::kControl], 14);  // 13 of the seed and `pidc`
}

TEST(Registry, names_are_unique_and_every_seed_name_is_known) {
  std::set<std::string> names;
  for (const BlockSpec& b : all_blocks()) EXPECT_TRUE(names.insert(b.name).second) << b.name;
  for (const char* n :
       {"dai", "ddi", "dpi", "tra", "trd", "prx", "pry", "prm", "prr", "era", "erd", "asp", "dsp",
        "dao", "ddo", "twa", "twd", "pwx", "pwy", "pwm", "pwr", "ewa", "ewd", "add", "sub", "mult",
        "div", "abs", "sqrt", "sin", "cos", "tan", "asin", "acos", "atan", "max", "min", "inv",
        "scale", "and", "or", "not", "exor", "time", "cnt", "lim", "dzon", "dely", "intg", "derv",
        "filt", "ldlg", "pi", "epi", "pid", "epid", "ramp", "amux"}) {
    EXPECT_NE(find_block(n), nullptr) << n;
  }
}

TEST(Registry, accepts_both_spellings_of_the_derivative) {
  ASSERT_NE(find_block("deriv"), nullptr);
  EXPECT_EQ(find_block("deriv"), find_block("derv"));
  EXPECT_EQ(find_block("PID"), nullptr);  // block names are lower case
}

TEST(Registry, suggests_the_closest_name_for_a_typo) {
  EXPECT_EQ(suggest_block("pdi"), "ddi");
  EXPECT_EQ(suggest_block("filter"), "filt");
  EXPECT_EQ(suggest_block("xyzzyq"), "");
}

TEST(Registry, every_block_maps_to_an_opcode_that_reads_its_inputs) {
  for (const BlockSpec& b : all_blocks()) {
    for (uint32_t n = b.min_inputs; n <= b.max_inputs; ++n) {
      const Op op = block_op(b, n);
      if (b.signature == Signature::kDeviceIn || b.signature == Signature::kSetpoint || b.reads_quality) {
        EXPECT_TRUE(op_is_load(op)) << b.name;  // `good` loads the quality the task wrote
        continue;
      }
      EXPECT_EQ(op_input_count(op), n) << b.name;
      EXPECT_EQ(op_output_digital(op), b.out_kind == Kind::kDigital) << b.name;
      if (b.signature == Signature::kCompute) {
        // Every literal parameter has a prepared counterpart (params never vanish).
        EXPECT_GE(op_param_count(op), b.param_count) << b.name;
      }
    }
  }
  // The opcodes a compute block can reach are all distinct except and/or arity.
  std::set<Op> seen;
  for (const BlockSpec& b : all_blocks()) {
    if (b.signature != Signature::kCompute || b.reads_quality) continue;
    EXPECT_TRUE(seen.insert(block_op(b, b.max_inputs)).second) << b.name;
  }
}

TEST(Registry, prepared_parameters_fold_the_period) {
  double out[3];
  const double filt[] = {0.9};
  prepare_params(Op::Filt, filt, 0.1, out);
  EXPECT_DOUBLE_EQ(out[0], 0.1 / (0.9 + 0.1));
  const double pid[] = {2, 4, 0.5};
  prepare_params(Op::Pid, pid, 0.1, out);
  EXPECT_DOUBLE_EQ(out[0], 2);
  EXPECT_DOUBLE_EQ(out[1], 0.1 / 4);
  EXPECT_DOUBLE_EQ(out[2], 0.5 / 0.1);
  const double pi_no_integral[] = {2, 0};
  prepare_params(Op::Pi, pi_no_integral, 0.1, out);
  EXPECT_DOUBLE_EQ(out[1], 0.0);
  const double t[] = {0.3};
  prepare_params(Op::Time, t, 0.1, out);
  EXPECT_DOUBLE_EQ(out[0], 3.0);  // not 4 because of 0.3/0.1 = 2.9999999999999996
}

TEST(Registry, generated_docs_match_the_committed_reference) {
  std::ifstream f(std::string(RTPLC_SOURCE_DIR) + "/docs/blocks.md");
  ASSERT_TRUE(f) << "docs/blocks.md is missing; run: rtplc blocks --markdown > docs/blocks.md";
  std::stringstream ss;
  ss << f.rdbuf();
  EXPECT_EQ(ss.str(), blocks_markdown())
      << "docs/blocks.md is out of date; run: rtplc blocks --markdown > docs/blocks.md";
}

}  // namespace
}  // namespace rtplc
