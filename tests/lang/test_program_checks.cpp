// The language-neutral checks (lang/program_checks.h) on hand-built flat
// programs, with no FBD text: the entry point the SFC and PLCopen XML front ends
// call. Also checks that what the FBD front end produces passes them unchanged.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "lang/compiler.h"
#include "lang/program_checks.h"

namespace rtplc::lang {
namespace {

// A compute block: `written` reads the blocks at `inputs`.
FlatBlock compute(const std::string& written, const std::string& name, std::vector<uint32_t> inputs,
                  std::vector<double> params, uint32_t line) {
  FlatBlock b;
  b.written = written;
  b.name = name;
  b.pos = SourcePos{line, 1};
  b.n_in = static_cast<uint32_t>(inputs.size());
  for (size_t k = 0; k < inputs.size() && k < 3; ++k) {
    b.in[k] = inputs[k];
    b.in_pos[k] = SourcePos{line, static_cast<uint32_t>(10 + 4 * k)};
  }
  b.params = std::move(params);
  return b;
}

FlatBlock setpoint(const std::string& written, const std::string& name, uint16_t d, uint32_t c,
                   double init, const std::string& label, uint32_t line) {
  FlatBlock b = compute(written, name, {}, {}, line);
  b.d = d;
  b.c = c;
  b.init = init;
  b.label = label;
  return b;
}

FlatBlock output(const std::string& written, uint32_t value, uint16_t p, uint16_t d, uint32_t c,
                 const std::string& label, uint32_t line) {
  FlatBlock b = compute(written, "", {value}, {}, line);
  b.p = p;
  b.d = d;
  b.c = c;
  b.label = label;
  return b;
}

struct Checked {
  CheckedProgram program;
  DiagnosticList diags;
  std::vector<const Diagnostic*> errors() const {
    std::vector<const Diagnostic*> e;
    for (const Diagnostic& d : diags.items()) {
      if (d.severity == Severity::kError) e.push_back(&d);
    }
    return e;
  }
};

Checked check(std::vector<FlatBlock> blocks) {
  Checked r;
  r.program.blocks = std::move(blocks);
  check_flat_program(r.program, r.diags);
  return r;
}

// Expects exactly one error, at line `line`, whose message contains `text`.
void expect_error(std::vector<FlatBlock> blocks, uint32_t line, const std::string& text) {
  Checked r = check(std::move(blocks));
  ASSERT_EQ(r.errors().size(), 1u) << (r.diags.items().empty() ? "" : r.diags.items()[0].message);
  EXPECT_EQ(r.errors()[0]->pos.line, line);
  EXPECT_NE(r.errors()[0]->message.find(text), std::string::npos) << r.errors()[0]->message;
}

TEST(ProgramChecks, accepts_a_valid_program_and_completes_it) {
  Checked r = check({
      setpoint("asp", "SP", 0, 0, 50, "Setpoint", 1),
      setpoint("asp", "PV", 0, 1, 20, "", 2),
      compute("sub", "E", {0, 1}, {}, 3),  // k omitted: default 1
      compute("add", "I", {2, 4}, {}, 4),  // reads "Y", which runs later
      compute("abs", "Y", {3}, {}, 5),
      output("dao", 4, 0, 0, 0, "MV", 6),
  });
  EXPECT_FALSE(r.diags.has_errors()) << r.diags.items()[0].message;
  EXPECT_EQ(r.diags.warning_count(), 0u);
  const std::vector<FlatBlock>& b = r.program.blocks;
  for (const FlatBlock& f : b) {
    ASSERT_NE(f.spec, nullptr);
    EXPECT_EQ(f.op, block_op(*f.spec, f.n_in));
  }
  EXPECT_EQ(b[2].params, std::vector<double>{1});
  EXPECT_FALSE(b[3].delayed[0]);
  EXPECT_TRUE(b[3].delayed[1]);  // last cycle's Y
  EXPECT_EQ(b[1].label, "asp_d0_c1");
  EXPECT_EQ(b[5].name, "dao@p0.d0.c0");
}

TEST(ProgramChecks, the_result_compiles) {
  Checked r = check({setpoint("asp", "A", 0, 0, 2, "a", 1), compute("abs", "B", {0}, {}, 2),
                     output("dao", 1, 0, 0, 0, "out", 3)});
  ASSERT_FALSE(r.diags.has_errors());
  Result<TaskImage> img = build_image(r.program, CompileOptions{}, 0);
  ASSERT_TRUE(img.ok()) << img.error();
  EXPECT_EQ(img.value().header().n_instr, 3u);
}

TEST(ProgramChecks, reports_an_unknown_block) {
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("filter", "B", {0}, {2}, 2)}, 2,
               "unknown block 'filter'; did you mean 'filt'?");
  expect_error({compute("zzzzzzzz", "B", {}, {}, 1)}, 1, "unknown block 'zzzzzzzz' (rtplc blocks");
}

TEST(ProgramChecks, reports_wrong_arity) {
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("sub", "B", {0}, {}, 2)}, 2,
               "sub takes sub(a, b, [k]), found 1 argument");
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("abs", "B", {0}, {1}, 2)}, 2,
               "abs takes abs(a), found 2 arguments");
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("pid", "B", {0, 0}, {1, 2}, 2)}, 2,
               "pid takes");
  FlatBlock two = output("dao", 0, 0, 0, 0, "x", 2);
  two.n_in = 2;
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), two}, 2,
               "dao takes (value, p, d, c, \"label\")");
}

TEST(ProgramChecks, reports_an_input_of_the_wrong_kind) {
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("not", "B", {0}, {}, 2)}, 2,
               "digital input 'a' of not needs a digital value, but A (asp) is analog");
  expect_error({setpoint("dsp", "A", 0, 0, 1, "a", 1), output("dao", 0, 0, 0, 0, "x", 2)}, 2,
               "analog input 'value' of dao needs an analog value, but A (dsp) is digital");
}

TEST(ProgramChecks, reports_an_input_that_names_no_block_or_an_output_block) {
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("abs", "B", {7}, {}, 2)}, 2,
               "input 'a' of abs reads block #7, which does not exist");
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), output("dao", 0, 0, 0, 0, "x", 2),
                compute("abs", "B", {1}, {}, 3)},
               3, "an output block, which has no result");
}

TEST(ProgramChecks, reports_a_duplicate_or_missing_name) {
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("abs", "A", {0}, {}, 2)}, 2,
               "A is already defined (line 1): every block needs its own id");
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("abs", "", {0}, {}, 2)}, 2,
               "abs needs a name for its result");
}

TEST(ProgramChecks, reports_two_writers_to_one_output_channel) {
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), output("dao", 0, 0, 0, 0, "x", 2),
                output("dao", 0, 0, 0, 0, "y", 3)},
               3, "channel DIO p0.d0.c0 is already written by dao (line 2): each output channel");
}

TEST(ProgramChecks, reports_channel_and_label_rules) {
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), setpoint("asp", "B", 0, 0, 1, "b", 2)}, 2,
               "set-point SETP d0.c0 is already defined (line 1)");
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), setpoint("asp", "B", 0, 1, 1, "a", 2)}, 2,
               "label \"a\" already names channel");
  expect_error({setpoint("asp", "A", 0, 0, 1, "has space", 1)}, 1, "may only use letters");
  expect_error({setpoint("dsp", "A", 0, 0, 2, "a", 1)}, 1, "a digital set-point starts at 0 or 1");
  FlatBlock far = output("dao", 0, 300, 0, 0, "x", 2);
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), far}, 2, "p number 300 is out of range");
}

TEST(ProgramChecks, reports_parameters_out_of_range) {
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("intg", "B", {0}, {0}, 2)}, 2,
               "parameter 'Ti' (integral time (s)) of intg must be greater than 0, found 0");
  expect_error({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("lim", "B", {0}, {3, -3}, 2)}, 2,
               "lim: lower limit 3 is above the upper limit -3");
}

TEST(ProgramChecks, reports_every_bad_block_in_block_order) {
  Checked r = check({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("nope", "B", {0}, {}, 2),
                     compute("sub", "C", {0}, {}, 3), compute("not", "D", {0}, {}, 4)});
  ASSERT_EQ(r.errors().size(), 3u);
  EXPECT_EQ(r.errors()[0]->pos.line, 2u);
  EXPECT_EQ(r.errors()[1]->pos.line, 3u);
  EXPECT_EQ(r.errors()[2]->pos.line, 4u);
}

TEST(ProgramChecks, warns_about_an_unused_result_written_by_the_user_only) {
  Checked r = check({setpoint("asp", "A", 0, 0, 1, "a", 1), compute("abs", "B", {0}, {}, 2)});
  EXPECT_FALSE(r.diags.has_errors());
  ASSERT_EQ(r.diags.warning_count(), 1u);
  EXPECT_EQ(r.diags.items()[0].message, "B (abs) is computed but never used");

  FlatBlock inner = compute("abs", "X.B", {0}, {}, 2);
  inner.call_line = 5;  // part of an expansion: not the user's to remove
  Checked q = check({setpoint("asp", "A", 0, 0, 1, "a", 1), inner});
  EXPECT_EQ(q.diags.warning_count(), 0u);
}

TEST(ProgramChecks, what_the_fbd_front_end_produces_passes_them_unchanged) {
  CompileResult fbd = compile_file(std::string(RTPLC_SOURCE_DIR) + "/examples/seed_pid.fbd");
  ASSERT_TRUE(fbd.ok());
  CheckedProgram again = fbd.program;
  for (FlatBlock& b : again.blocks) {
    b.spec = nullptr;
    for (bool& d : b.delayed) d = false;
  }
  DiagnosticList diags;
  check_flat_program(again, diags);
  EXPECT_FALSE(diags.has_errors()) << diags.items()[0].message;
  ASSERT_EQ(again.blocks.size(), fbd.program.blocks.size());
  for (size_t i = 0; i < again.blocks.size(); ++i) {
    EXPECT_EQ(again.blocks[i].spec, fbd.program.blocks[i].spec);
    EXPECT_EQ(again.blocks[i].op, fbd.program.blocks[i].op);
    EXPECT_EQ(again.blocks[i].params, fbd.program.blocks[i].params);
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(again.blocks[i].delayed[k], fbd.program.blocks[i].delayed[k]);
  }
}

}  // namespace
}  // namespace rtplc::lang
