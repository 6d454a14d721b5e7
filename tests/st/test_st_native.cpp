// Native code (blocks/native.h) against the interpreter: every program of the ST
// corpus and the examples, in every language, run cycle by cycle on the same
// changing inputs, must leave the same arena bit for bit (values, state, error
// counters, outputs); a runaway loop faults at the same Loop; what cannot be
// compiled is a clear error.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "blocks/executor.h"
#include "blocks/native.h"
#include "lang/compiler.h"

namespace rtplc {
namespace {

namespace fs = std::filesystem;

const std::string kSource = RTPLC_SOURCE_DIR;

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

// The first place two arenas differ, or empty.
std::string difference(const TaskArena& x, const TaskArena& y) {
  if (!same_bits(x.values, y.values)) {
    for (size_t i = 0; i < x.values.size(); ++i) {
      if (std::memcmp(&x.values[i], &y.values[i], sizeof(double)) != 0) {
        return "value slot " + std::to_string(i) + ": " + std::to_string(x.values[i]) + " vs " +
               std::to_string(y.values[i]);
      }
    }
  }
  if (!same_bits(x.state, y.state)) return "state";
  if (!same_bits(x.io_out, y.io_out)) return "outputs";
  if (x.errors != y.errors) return "error counters";
  if (x.total_errors != y.total_errors) return "total errors";
  if (x.loop_fault != y.loop_fault) return "loop fault";
  if (x.cycles != y.cycles) return "cycles";
  return {};
}

// Inputs that change every cycle: whole numbers, fractions, signs, 0/1, large.
double input_value(uint64_t cycle, uint32_t k) {
  static const double kValues[] = {0, 1, -1, 2.5, 100, -37, 1e6, 0.001, 7, 3, 65535, -0.5, 12, 1, 0, 42};
  const uint64_t h = (cycle * 2654435761u + k * 40503u) >> 3;
  return kValues[h % (sizeof kValues / sizeof kValues[0])];
}

// Inputs that are any double: what shows a libm call that differs in its last bit.
double any_value(uint64_t cycle, uint32_t k) {
  uint64_t x = (cycle + 1) * 6364136223846793005ull + (k + 1) * 1442695040888963407ull;
  x ^= x >> 29;
  return 0.001 + static_cast<double>(x >> 11) * 0x1p-53 * 1000.0;
}

// The interpreter and the image's native code side by side, each on its own
// arena, given the same inputs. `ok` is false (with the failure reported) when
// the native code could not be made.
struct SideBySide {
  SideBySide(const TaskImage& img, uint64_t loop_budget = kDefaultLoopBudget) : interp(img), nat(img) {
    auto n = compile_native(img);
    ok = n.ok();
    if (!ok) {
      ADD_FAILURE() << n.error();
      return;
    }
    code = *n;
    EXPECT_TRUE(code->compiled_from(img));
    interp.loop_budget = nat.loop_budget = loop_budget;
    ci = make_context(img, interp);
    cn = make_context(img, nat);
    cn.native = code->entry();
  }
  SideBySide(const SideBySide&) = delete;
  SideBySide& operator=(const SideBySide&) = delete;
  void input(uint32_t k, double v) { interp.io_in[k] = nat.io_in[k] = v; }
  void inputs(uint64_t cycle, double (*value)(uint64_t, uint32_t)) {
    for (uint32_t k = 0; k < interp.io_in.size(); ++k) input(k, value(cycle, k));
  }
  // One cycle of each; where their arenas then differ, or empty.
  std::string cycle() {
    execute_cycle(ci);
    execute_cycle(cn);
    return difference(interp, nat);
  }

  bool ok = false;
  std::shared_ptr<const NativeCode> code;
  TaskArena interp, nat;
  ExecContext ci, cn;
};

void expect_same(const TaskImage& img, uint32_t cycles, double (*input)(uint64_t, uint32_t) = input_value) {
  SideBySide two(img);
  ASSERT_TRUE(two.ok);
  for (uint64_t c = 0; c < cycles; ++c) {
    two.inputs(c, input);
    const std::string d = two.cycle();
    ASSERT_TRUE(d.empty()) << "cycle " << c << ": " << d;
  }
}

void expect_same_as_interpreter(const std::string& file, uint32_t cycles) {
  SCOPED_TRACE(file);
  lang::CompileResult r = lang::compile_file(file, {});
  ASSERT_TRUE(r.ok()) << "does not compile";
  expect_same(*r.image, cycles);
}

std::vector<std::string> files_in(const std::string& dir, std::initializer_list<const char*> extensions) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    for (const char* x : extensions) {
      if (e.path().extension() == x) out.push_back(e.path().string());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Native, every_st_corpus_program_runs_as_the_interpreter_runs_it) {
  int ran = 0;
  for (const std::string& f : files_in(kSource + "/tests/st/corpus", {".st"})) {
    if (!lang::compile_file(f, {}).ok()) continue;  // the corpus also seeds the fuzzer with refusals
    expect_same_as_interpreter(f, 60);
    ++ran;
  }
  EXPECT_GE(ran, 10);
}

TEST(Native, the_examples_in_every_language_run_as_the_interpreter_runs_them) {
  for (const char* f : {"/examples/seed_pid.fbd", "/examples/flow_pidc.fbd", "/examples/tank.sfc",
                        "/examples/plcopen_tank.xml", "/examples/filler_sfc.st", "/examples/median.st",
                        "/examples/messages.st", "/examples/seed_loop.fbd"}) {
    expect_same_as_interpreter(kSource + f, 200);
  }
}

// The C library's sin, log, pow... are not always correctly rounded; the C++
// compiler's own evaluation of them at compile time is, and it rewrites
// pow(x, 2) as x*x. Native code must call the library as the interpreter does.
TEST(Native, the_maths_functions_give_the_interpreters_bits) {
  lang::CompileResult r = lang::compile_source(
      "PROGRAM M\nVAR x AT %ID0 : LREAL; q AT %QD0 : LREAL; k : LREAL := 748265.3704754404;\n"
      "a, b, c, d, e, f, g, h, i : LREAL; END_VAR\n"
      "a := EXPT(x, 2.0); b := EXPT(x, -1.0); c := LN(x); d := LOG(x); e := SIN(x); f := COS(x);\n"
      "g := TAN(x) + ATAN(x) + ASIN(x / 1000.0) + ACOS(x / 1000.0); h := EXP(x / 100.0);\n"
      "i := LN(k) + SIN(k) + EXPT(k, 0.5) + EXP(k / 100000.0);\n"
      "q := a + b + c + d + e + f + g + h + i;\nEND_PROGRAM\n",
      {});
  ASSERT_TRUE(r.ok());
  expect_same(*r.image, 3000, any_value);
}

// A block reading a constant that comes later in the schedule reads last
// cycle's value (0 in the first cycle): not the constant.
TEST(Native, a_constant_read_before_it_runs_is_not_taken_for_the_constant) {
  lang::CompileResult fbd = lang::compile_source(
      "%%\nstime(0.1)\nF1 = intg(F2, 1)\nF2 = const(1)\nF3 = add(F1, F2, 1)\ndao(F3, p0, d0, c0, \"OUT\")\nEND\n%%\n",
      {});
  ASSERT_TRUE(fbd.ok());
  expect_same(*fbd.image, 20);
  // A constant under an IF that is not taken has not run either.
  lang::CompileResult st = lang::compile_source(
      "PROGRAM C\nVAR go AT %IX0.0 : BOOL; n AT %QD0 : DINT; k : DINT; i : INT; END_VAR\n"
      "FOR i := 1 TO 3 DO IF go THEN k := 7; END_IF; n := n + k MOD 5; END_FOR;\nEND_PROGRAM\n",
      {});
  ASSERT_TRUE(st.ok());
  expect_same(*st.image, 40);
}

// Nothing of the image's text becomes code: a name with a newline in it stays
// in its comment.
TEST(Native, an_image_name_is_never_compiled_as_code) {
  lang::CompileOptions opt;
  opt.name = "x\n#error this line must not be compiled\n";
  lang::CompileResult r = lang::compile_source("PROGRAM P\nVAR n AT %QW0 : INT; END_VAR\nn := n + 1;\nEND_PROGRAM\n", opt);
  ASSERT_TRUE(r.ok());
  ASSERT_NE(std::string(r.image->name()).find('\n'), std::string::npos) << "the name lost its newline";
  auto n = compile_native(*r.image);
  EXPECT_TRUE(n.ok()) << n.error();
  EXPECT_EQ(native_source(*r.image).find("#error"), std::string::npos);
}

TEST(Native, a_compiler_that_does_not_finish_is_stopped_and_the_caller_goes_on_meanwhile) {
  const fs::path dir = fs::temp_directory_path() / ("rtplc-native-slow-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string slow = (dir / "slow-c++").string();
  std::ofstream(slow) << "#!/bin/sh\nsleep 30\n";
  fs::permissions(slow, fs::perms::owner_all);
  lang::CompileResult r = lang::compile_file(kSource + "/examples/median.st", {});
  ASSERT_TRUE(r.ok());
  NativeOptions opt;
  opt.compiler = slow;
  opt.timeout_s = 0.5;
  int ticks = 0;  // the runtime's housekeeping goes on meanwhile
  opt.while_waiting = [&ticks] {
    ++ticks;
    return true;
  };
  auto n = compile_native(*r.image, opt);
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.error().find("was stopped"), std::string::npos) << n.error();
  EXPECT_GE(ticks, 2);
  // A runtime that stops stops the compile at once, whatever the time limit.
  opt.timeout_s = 60;
  const auto t0 = std::chrono::steady_clock::now();
  opt.while_waiting = [] { return false; };
  auto m = compile_native(*r.image, opt);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().find("the runtime is stopping"), std::string::npos) << m.error();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(25)) << "the compiler was waited for";
  fs::remove_all(dir);
}

TEST(Native, a_runaway_loop_stops_at_the_same_loop_with_the_same_count) {
  lang::CompileResult r = lang::compile_source(
      "PROGRAM P\nVAR x : DINT; go AT %IX0.0 : BOOL; n AT %QD0 : DINT; END_VAR\n"
      "x := 0;\nWHILE go OR x < 3 DO\n  x := x + 1;\nEND_WHILE;\nn := x;\nEND_PROGRAM\n",
      {});
  ASSERT_TRUE(r.ok());
  SideBySide two(*r.image, 777);
  ASSERT_TRUE(two.ok);
  EXPECT_EQ(two.cycle(), "");
  EXPECT_EQ(two.interp.loop_fault, 0u);
  EXPECT_EQ(two.nat.io_out[0], 3.0);
  two.input(0, 1);  // go: the loop never ends
  EXPECT_EQ(two.cycle(), "");
  EXPECT_NE(two.nat.loop_fault, 0u);
  EXPECT_EQ(two.nat.total_errors, 1u);
}

// A program long enough to be cut into several functions, with a loop longer
// than one part (it must stay whole) and a runaway loop in a later part.
TEST(Native, a_long_program_cut_into_parts_runs_and_faults_as_the_interpreter) {
  std::string src = "PROGRAM Long\nVAR a AT %IW0 : INT; go AT %IX0.0 : BOOL; y AT %QD0 : DINT;\n"
                    "x : DINT; r : REAL; i : INT; END_VAR\n";
  for (int k = 0; k < 100; ++k) src += "IF a > " + std::to_string(k % 7) + " THEN x := x + 1; ELSE r := r * 0.5 + 1.0; END_IF;\n";
  src += "i := 0;\nWHILE i < 3 OR go DO\n  i := i + 1;\n";
  for (int k = 0; k < 100; ++k) src += "  x := (x * 3 + " + std::to_string(k) + ") MOD 10007;\n";
  src += "END_WHILE;\n";
  for (int k = 0; k < 100; ++k) src += "r := r + " + std::to_string(k) + ".5;\n";
  src += "y := x;\nEND_PROGRAM\n";
  lang::CompileResult r = lang::compile_source(src, {});
  ASSERT_TRUE(r.ok());
  const std::string code = native_source(*r.image);
  size_t parts = 0;
  for (size_t at = code.find("uint64_t part"); at != std::string::npos; at = code.find("uint64_t part", at + 1)) ++parts;
  EXPECT_GE(parts, 3u) << "the program was not cut";
  SideBySide two(*r.image, 50);
  ASSERT_TRUE(two.ok);
  for (uint64_t c = 0; c < 30; ++c) {
    two.inputs(c, input_value);
    if (c >= 20) two.input(1, 1);  // go: the loop runs away
    ASSERT_EQ(two.cycle(), "") << "cycle " << c;
  }
  EXPECT_NE(two.nat.loop_fault, 0u);
}

TEST(Native, a_missing_or_failing_compiler_is_a_clear_error) {
  lang::CompileResult r = lang::compile_file(kSource + "/examples/median.st", {});
  ASSERT_TRUE(r.ok());
  NativeOptions none;
  none.compiler = "/nonexistent/c++";
  auto a = compile_native(*r.image, none);
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().find("needs a C++ compiler"), std::string::npos) << a.error();
  EXPECT_NE(a.error().find("RTPLC_CXX"), std::string::npos) << a.error();
  NativeOptions failing;
  failing.compiler = "false";
  auto b = compile_native(*r.image, failing);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("exited with 1"), std::string::npos) << b.error();
  NativeOptions nowhere;
  nowhere.work_dir = "/nonexistent/dir";
  auto c = compile_native(*r.image, nowhere);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find("cannot make a build folder in /nonexistent/dir"), std::string::npos) << c.error();
}

// Several libraries live at once (tasks, a swap's new program beside the
// running one), each its own.
TEST(Native, two_libraries_loaded_at_once_are_each_their_own) {
  lang::CompileResult a = lang::compile_file(kSource + "/examples/median.st", {});
  lang::CompileResult b = lang::compile_file(kSource + "/examples/seed_pid.fbd", {});
  ASSERT_TRUE(a.ok() && b.ok());
  auto na = compile_native(*a.image);
  auto nb = compile_native(*b.image);
  auto na2 = compile_native(*a.image);
  ASSERT_TRUE(na.ok() && nb.ok() && na2.ok()) << (na.ok() ? "" : na.error()) << (nb.ok() ? "" : nb.error())
                                              << (na2.ok() ? "" : na2.error());
  EXPECT_NE((*na)->entry(), (*nb)->entry());
  EXPECT_TRUE((*nb)->compiled_from(*b.image));
  expect_same(*b.image, 20);
}

TEST(Native, leaves_nothing_behind_and_knows_its_image) {
  const fs::path dir = fs::temp_directory_path() / ("rtplc-native-test-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  lang::CompileResult a = lang::compile_file(kSource + "/examples/median.st", {});
  lang::CompileResult b = lang::compile_file(kSource + "/examples/seed_pid.fbd", {});
  ASSERT_TRUE(a.ok() && b.ok());
  NativeOptions opt;
  opt.work_dir = dir.string();
  auto n = compile_native(*a.image, opt);
  ASSERT_TRUE(n.ok()) << n.error();
  EXPECT_TRUE(fs::is_empty(dir)) << "the build folder was not removed";
  EXPECT_TRUE((*n)->compiled_from(*a.image));
  EXPECT_FALSE((*n)->compiled_from(*b.image));
  EXPECT_GT((*n)->stats().native_runs, 0u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rtplc
