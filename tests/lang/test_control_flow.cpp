// Control flow in the executor (blocks/ops.h "Control flow"): variables' homes,
// assignments, forward branches and counted backward loops, built as flat
// programs by hand (what the textual front ends emit), checked, compiled,
// verified and run. Values are worked by hand in each test's comment.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "blocks/executor.h"
#include "blocks/image.h"
#include "blocks/status.h"
#include "lang/compiler.h"
#include "lang/program_checks.h"
#include "tests/support/flow_program.h"

namespace rtplc::lang {
namespace {

using rtplc::testing::Builder;

struct Compiled {
  DiagnosticList diags;
  TaskImage image;
  bool ok = false;
};

Compiled compile(Builder& b, bool batch = true) {
  Compiled c;
  check_flat_program(b.p, c.diags);
  if (c.diags.has_errors()) return c;
  CompileOptions opt;
  opt.batch = batch;
  Result<TaskImage> img = build_image(b.p, opt, 0);
  EXPECT_TRUE(img) << (img ? "" : img.error());
  if (!img) return c;
  c.image = std::move(img).value();
  c.ok = true;
  return c;
}

std::string errors_of(const DiagnosticList& d) {
  std::string s;
  for (const Diagnostic& x : d.items()) s += x.message + "\n";
  return s;
}

// sum := 0; i := 1; WHILE i <= n DO sum := sum + i; i := i + 1; END_WHILE; out0 := sum
// -> n (n + 1) / 2. Returns the program; `loop_block` is the backward branch.
Builder triangle(double n, uint32_t* loop_block = nullptr) {
  Builder b;
  const uint32_t i = b.var("i"), sum = b.var("sum");
  const uint32_t one = b.k("one", 1), limit = b.k("n", n), zero = b.k("zero", 0);
  b.set(sum, zero);
  b.set(i, one);
  const uint32_t head = b.add("le", "cond", {i, limit});
  const uint32_t exit = b.branch("jz", {head}, 0);
  const uint32_t s2 = b.add("add", "s2", {sum, i});
  b.set(sum, s2);
  const uint32_t i2 = b.add("add", "i2", {i, one});
  b.set(i, i2);
  const uint32_t back = b.branch("loop", {}, head);
  if (loop_block) *loop_block = back;
  b.aim(exit, b.next());
  b.out(sum, 0);
  return b;
}

TEST(ControlFlow, a_while_loop_sums_one_to_n_every_cycle) {
  for (bool batch : {true, false}) {
    Builder b = triangle(10);
    Compiled c = compile(b, batch);
    ASSERT_TRUE(c.ok) << errors_of(c.diags);
    TaskArena arena(c.image);
    for (int cycle = 0; cycle < 3; ++cycle) {
      execute_cycle(c.image, arena);
      EXPECT_EQ(arena.loop_fault, 0u);
      ASSERT_EQ(arena.io_out.size(), 1u);
      EXPECT_EQ(arena.io_out[0], 55.0) << "cycle " << cycle << (batch ? " batched" : " in text order");
    }
    EXPECT_EQ(arena.total_errors, 0u);
  }
}

TEST(ControlFlow, both_interpreter_bodies_agree) {
  Builder b = triangle(100);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  for (ExecutorBody body : {ExecutorBody::kBaseline, ExecutorBody::kAvx2}) {
    TaskArena arena(c.image);
    execute_cycle_on(body, make_context(c.image, arena));
    EXPECT_EQ(arena.io_out[0], 5050.0);
  }
}

TEST(ControlFlow, the_budget_counts_backward_branches_exactly) {
  // n = 10 takes the backward branch 10 times (i = 1..10), then leaves.
  uint32_t back = 0;
  Builder b = triangle(10, &back);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  TaskArena arena(c.image);
  arena.loop_budget = 10;
  execute_cycle(c.image, arena);
  EXPECT_EQ(arena.loop_fault, 0u);
  EXPECT_EQ(arena.io_out[0], 55.0);

  arena.loop_budget = 9;
  execute_cycle(c.image, arena);
  ASSERT_NE(arena.loop_fault, 0u);
  // The fault names the loop instruction, which names its block.
  const uint32_t at = arena.loop_fault - 1;
  EXPECT_EQ(c.image.code()[at].op, Op::Loop);
  EXPECT_EQ(c.image.blocks()[at].text_index, back);
  EXPECT_EQ(arena.errors[at], 1u);
  EXPECT_EQ(arena.total_errors, 1u);
  // The cycle stopped inside the loop: the output was not written this time
  // (it still holds the last complete cycle's 55).
  EXPECT_EQ(arena.io_out[0], 55.0);

  // A later cycle within the budget clears the fault.
  arena.loop_budget = 10;
  execute_cycle(c.image, arena);
  EXPECT_EQ(arena.loop_fault, 0u);
}

TEST(ControlFlow, an_endless_loop_ends_the_cycle_at_the_budget) {
  // x := x + 1 forever (a REPEAT ... UNTIL FALSE), output after it.
  Builder b;
  const uint32_t x = b.var("x"), one = b.k("one", 1);
  const uint32_t head = b.add("add", "x1", {x, one});
  b.set(x, head);
  b.branch("loop", {}, head);
  b.out(x, 0);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  TaskArena arena(c.image);
  arena.loop_budget = 1000;
  execute_cycle(c.image, arena);
  ASSERT_NE(arena.loop_fault, 0u);
  // The body ran once before the first backward branch and once after each of
  // the 1,000 allowed: x = 1,001; the store after the loop never ran.
  double xv = -1;
  for (uint32_t s = 0; s < c.image.code().size(); ++s) {
    if (c.image.code()[s].op == Op::Var) xv = arena.values[c.image.code()[s].out];
  }
  EXPECT_EQ(xv, 1001.0);
  EXPECT_EQ(arena.io_out[0], 0.0);
}

TEST(ControlFlow, a_variable_takes_its_initial_value_once_and_keeps_its_value_between_cycles) {
  // count := count + 1 each cycle, count starting at 5.
  Builder b;
  const uint32_t count = b.var("count", 5), one = b.k("one", 1);
  const uint32_t next = b.add("add", "next", {count, one});
  b.set(count, next);
  b.out(count, 0);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  TaskArena arena(c.image);
  for (double want : {6.0, 7.0, 8.0}) {
    execute_cycle(c.image, arena);
    EXPECT_EQ(arena.io_out[0], want);
  }
}

TEST(ControlFlow, a_forward_branch_skips_code_and_a_search_exits_early) {
  // n := 0; REPEAT n := n + 1; IF n * n > 50 THEN EXIT; END_IF; UNTIL FALSE; -> 8
  // (the exit is a jnz past the loop; the loop itself is unconditional).
  Builder b;
  const uint32_t n = b.var("n"), zero = b.k("zero", 0), one = b.k("one", 1), fifty = b.k("fifty", 50);
  b.set(n, zero);
  const uint32_t head = b.add("add", "n1", {n, one});
  b.set(n, head);
  const uint32_t sq = b.add("mult", "sq", {n, n});
  const uint32_t big = b.add("gt", "big", {sq, fifty});
  const uint32_t leave = b.branch("jnz", {big}, 0);
  b.branch("loop", {}, head);
  b.aim(leave, b.next());
  b.out(n, 0);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  TaskArena arena(c.image);
  execute_cycle(c.image, arena);
  EXPECT_EQ(arena.loop_fault, 0u);
  EXPECT_EQ(arena.io_out[0], 8.0);
}

TEST(ControlFlow, the_checks_refuse_a_set_of_a_block_result_and_branches_the_wrong_way) {
  {
    Builder b;
    const uint32_t k = b.k("k", 1);
    b.set(k, k);  // writes a const's result, not a var
    Compiled c = compile(b);
    EXPECT_FALSE(c.ok);
    EXPECT_NE(errors_of(c.diags).find("must write a var block"), std::string::npos) << errors_of(c.diags);
  }
  {
    Builder b;
    const uint32_t k = b.k("k", 1);
    const uint32_t d = b.add("gt", "d", {k, k});
    b.branch("jz", {d}, 0);  // backward jz
    Compiled c = compile(b);
    EXPECT_FALSE(c.ok);
    EXPECT_NE(errors_of(c.diags).find("outside the blocks after it"), std::string::npos) << errors_of(c.diags);
  }
  {
    Builder b;
    b.k("k", 1);
    b.branch("loop", {}, 5);  // forward loop
    b.k("k2", 2);
    Compiled c = compile(b);
    EXPECT_FALSE(c.ok);
    EXPECT_NE(errors_of(c.diags).find("outside the blocks before it"), std::string::npos) << errors_of(c.diags);
  }
  {
    // An FBD source cannot name the control-flow blocks.
    EXPECT_EQ(find_block("loop"), nullptr);
    EXPECT_EQ(find_block("set"), nullptr);
    EXPECT_NE(flow_block("loop"), nullptr);
  }
}

// The image's bytes, editable, 8-byte aligned.
struct Bytes {
  std::vector<uint64_t> words;
  size_t size;
  explicit Bytes(const TaskImage& img) : words((img.bytes().size() + 7) / 8), size(img.bytes().size()) {
    std::memcpy(words.data(), img.bytes().data(), size);
  }
  Instr& instr(uint32_t i) {
    ImageHeader h;
    std::memcpy(&h, words.data(), sizeof h);
    return reinterpret_cast<Instr*>(reinterpret_cast<std::byte*>(words.data()) + h.off_instr)[i];
  }
  Result<void> verify() const {
    return verify_image({reinterpret_cast<const std::byte*>(words.data()), size});
  }
};

TEST(ControlFlow, the_verifier_refuses_branches_out_of_range_and_sets_of_results) {
  Builder b = triangle(10);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  const auto code = c.image.code();
  const uint32_t n_runs = c.image.header().n_runs;
  uint32_t jz = 0, loop = 0, set = 0, add = 0;
  for (uint32_t i = 0; i < code.size(); ++i) {
    if (code[i].op == Op::Jz) jz = i;
    if (code[i].op == Op::Loop) loop = i;
    if (code[i].op == Op::Set) set = i;
    if (code[i].op == Op::Add) add = i;
  }
  ASSERT_TRUE(Bytes(c.image).verify());
  {
    Bytes x(c.image);
    x.instr(jz).out = n_runs + 1;  // past the end
    EXPECT_FALSE(x.verify());
  }
  {
    Bytes x(c.image);
    x.instr(jz).out = 0;  // a conditional branch backward: an uncounted loop
    const Result<void> r = x.verify();
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().find("branch target"), std::string::npos) << r.error();
  }
  {
    Bytes x(c.image);
    x.instr(loop).out = n_runs;  // a loop forward
    EXPECT_FALSE(x.verify());
  }
  {
    Bytes x(c.image);
    x.instr(set).out = code[add].out;  // overwrite a block's result
    const Result<void> r = x.verify();
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().find("not a variable"), std::string::npos) << r.error();
  }
}

TEST(ControlFlow, a_value_summed_in_a_loop_from_a_bad_input_is_not_good) {
  // sum := 0; FOR 3 times: sum := sum + x; out := sum. With x bad, out is bad;
  // once x is good again, out is good again (the variable does not remember).
  Builder b;
  const uint32_t x = b.in(0);
  const uint32_t sum = b.var("sum"), i = b.var("i");
  const uint32_t zero = b.k("zero", 0), one = b.k("one", 1), three = b.k("three", 3);
  b.set(sum, zero);
  b.set(i, zero);
  const uint32_t head = b.add("lt", "more", {i, three});
  const uint32_t exit = b.branch("jz", {head}, 0);
  const uint32_t s2 = b.add("add", "s2", {sum, x});
  b.set(sum, s2);
  const uint32_t i2 = b.add("add", "i2", {i, one});
  b.set(i, i2);
  b.branch("loop", {}, head);
  b.aim(exit, b.next());
  b.out(sum, 0);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  TaskArena arena(c.image);
  StatusLane lane(c.image);
  arena.io_in[0] = 2;

  lane.set_in(0, static_cast<uint8_t>(Lane::kBad));
  execute_cycle(c.image, arena);
  EXPECT_EQ(arena.io_out[0], 6.0);
  EXPECT_TRUE(propagate_status(c.image, arena, lane));
  EXPECT_EQ(lane.out[0], static_cast<uint8_t>(Lane::kBad));

  lane.set_in(0, static_cast<uint8_t>(Lane::kGood));
  execute_cycle(c.image, arena);
  EXPECT_FALSE(propagate_status(c.image, arena, lane));
  EXPECT_EQ(lane.out[0], static_cast<uint8_t>(Lane::kGood));

  lane.set_in(0, static_cast<uint8_t>(Lane::kUncertain));
  execute_cycle(c.image, arena);
  EXPECT_TRUE(propagate_status(c.image, arena, lane));
  EXPECT_EQ(lane.out[0], static_cast<uint8_t>(Lane::kUncertain));
}

TEST(ControlFlow, a_bad_value_carried_backward_by_a_loop_reaches_what_was_read_before_it) {
  // acc := 0 (constant). Loop twice: y := acc (read BEFORE the set in the
  // text), acc := x. Output y. The second iteration's y is x's value, so y
  // must be as bad as x: the pass has to carry the set back to the read.
  Builder b;
  const uint32_t x = b.in(0);
  const uint32_t acc = b.var("acc"), i = b.var("i"), y = b.var("y");
  const uint32_t zero = b.k("zero", 0), one = b.k("one", 1), two = b.k("two", 2);
  b.set(acc, zero);
  b.set(i, zero);
  const uint32_t head = b.add("lt", "more", {i, two});
  const uint32_t exit = b.branch("jz", {head}, 0);
  const uint32_t copy = b.add("add", "copy", {acc, zero});
  b.set(y, copy);
  b.set(acc, x);
  const uint32_t i2 = b.add("add", "i2", {i, one});
  b.set(i, i2);
  b.branch("loop", {}, head);
  b.aim(exit, b.next());
  b.out(y, 0);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  TaskArena arena(c.image);
  StatusLane lane(c.image);
  arena.io_in[0] = 7;
  lane.set_in(0, static_cast<uint8_t>(Lane::kBad));
  execute_cycle(c.image, arena);
  EXPECT_EQ(arena.io_out[0], 7.0);
  propagate_status(c.image, arena, lane);
  EXPECT_EQ(lane.out[0], static_cast<uint8_t>(Lane::kBad));
}

TEST(ControlFlow, pick_and_put_reach_an_element_by_an_index_known_at_run_time) {
  // a[1..3] := [10, 20, 30]; a[k] := a[k] + 5 for k = 0..4 (0 and 4 outside:
  // read 0, write nothing); out0 := a[k] after the write, out1..3 := a[1..3].
  Builder b;
  const uint32_t k = b.var("k");
  const uint32_t a1 = b.var("a1", 10), a2 = b.var("a2", 20), a3 = b.var("a3", 30);
  const uint32_t one = b.k("one", 1), five = b.k("five", 5), limit = b.k("limit", 4);
  const uint32_t zero = b.k("zero", 0);
  b.set(k, zero);
  const uint32_t head = b.add("le", "more", {k, limit});
  const uint32_t exit = b.branch("jz", {head}, 0);
  const uint32_t old = b.pick({a1, a2, a3}, k, 1);
  const uint32_t sum = b.add("add", "sum", {old, five});
  b.put({a1, a2, a3}, k, sum, 1);
  const uint32_t k1 = b.add("add", "k1", {k, one});
  b.set(k, k1);
  b.branch("loop", {}, head);
  b.aim(exit, b.next());
  const uint32_t last = b.pick({a1, a2, a3}, k, 1);  // k = 5 after the loop: outside
  b.out(last, 0);
  b.out(a1, 1);
  b.out(a2, 2);
  b.out(a3, 3);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  TaskArena arena(c.image);
  execute_cycle(c.image, arena);
  EXPECT_EQ(arena.loop_fault, 0u);
  EXPECT_EQ(arena.io_out[0], 0.0);
  EXPECT_EQ(arena.io_out[1], 15.0);
  EXPECT_EQ(arena.io_out[2], 25.0);
  EXPECT_EQ(arena.io_out[3], 35.0);
  execute_cycle(c.image, arena);  // the variables keep their values: +5 again
  EXPECT_EQ(arena.io_out[3], 40.0);
}

TEST(ControlFlow, the_verifier_and_the_checks_refuse_tables_that_reach_outside) {
  {
    Builder b;
    const uint32_t k = b.k("k", 1), v = b.var("v");
    b.put({k}, k, k);  // a put into a constant's result
    b.out(v, 0);
    Compiled c = compile(b);
    EXPECT_FALSE(c.ok);
    EXPECT_NE(errors_of(c.diags).find("needs a table"), std::string::npos) << errors_of(c.diags);
  }
  Builder b;
  const uint32_t i = b.k("i", 0), v = b.var("v"), w = b.var("w");
  b.put({v, w}, i, i);
  const uint32_t got = b.pick({v, w}, i);
  b.out(got, 0);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  const auto code = c.image.code();
  uint32_t put = 0, pick = 0;
  for (uint32_t s = 0; s < code.size(); ++s) {
    if (code[s].op == Op::Put) put = s;
    if (code[s].op == Op::Pick) pick = s;
  }
  ASSERT_TRUE(Bytes(c.image).verify());
  auto table_of = [](Bytes& x, uint32_t s) {
    ImageHeader h;
    std::memcpy(&h, x.words.data(), sizeof h);
    return reinterpret_cast<double*>(reinterpret_cast<std::byte*>(x.words.data()) + h.off_params) + x.instr(s).param;
  };
  {
    Bytes x(c.image);
    table_of(x, pick)[2] = 1e6;  // a slot past the arena
    EXPECT_FALSE(x.verify());
  }
  {
    Bytes x(c.image);
    table_of(x, pick)[0] = 1e9;  // a table longer than the pool
    EXPECT_FALSE(x.verify());
  }
  {
    Bytes x(c.image);
    table_of(x, put)[3] = code[pick].out;  // write into the pick's own result
    const Result<void> r = x.verify();
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().find("not a variable"), std::string::npos) << r.error();
  }
}

TEST(ControlFlow, a_picked_element_is_as_good_as_the_elements_it_may_pick) {
  Builder b;
  const uint32_t x = b.in(0);
  const uint32_t v = b.var("v"), w = b.var("w");
  const uint32_t i = b.k("i", 1);
  b.set(v, x);
  const uint32_t got = b.pick({v, w}, i);  // picks w, but v may be picked with another i
  b.out(got, 0);
  Compiled c = compile(b);
  ASSERT_TRUE(c.ok) << errors_of(c.diags);
  TaskArena arena(c.image);
  StatusLane lane(c.image);
  lane.set_in(0, static_cast<uint8_t>(Lane::kBad));
  execute_cycle(c.image, arena);
  propagate_status(c.image, arena, lane);
  EXPECT_EQ(lane.out[0], static_cast<uint8_t>(Lane::kBad));
  lane.set_in(0, static_cast<uint8_t>(Lane::kGood));
  execute_cycle(c.image, arena);
  propagate_status(c.image, arena, lane);
  EXPECT_EQ(lane.out[0], static_cast<uint8_t>(Lane::kGood));
}

}  // namespace
}  // namespace rtplc::lang
