// The compiler's schedule: grouping blocks into runs must give exactly the
// results of textual order. Checked on random programs full of forward and self
// references, cycle by cycle, bit for bit.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "blocks/executor.h"
#include "lang/compiler.h"

namespace rtplc::lang {
namespace {

struct Generated {
  std::string source;
  std::vector<std::string> names;
};

// A random but valid program: 3 analog and 3 digital set-points, then `n`
// compute blocks whose inputs may point anywhere (earlier, later, itself).
Generated random_program(std::mt19937& rng, int n) {
  std::vector<const BlockSpec*> compute;
  for (const BlockSpec& b : all_blocks()) {
    if (b.signature == Signature::kCompute && !b.reads_quality) compute.push_back(&b);
  }
  std::vector<const BlockSpec*> chosen;
  std::vector<uint32_t> analog_ids, digital_ids;
  for (int i = 0; i < 3; ++i) analog_ids.push_back(static_cast<uint32_t>(i));
  for (int i = 3; i < 6; ++i) digital_ids.push_back(static_cast<uint32_t>(i));
  for (int i = 0; i < n; ++i) {
    const BlockSpec* b = compute[rng() % compute.size()];
    chosen.push_back(b);
    (b->out_kind == Kind::kAnalog ? analog_ids : digital_ids).push_back(static_cast<uint32_t>(6 + i));
  }
  Generated g;
  std::string& s = g.source;
  s = "%%\n";
  for (int i = 0; i < 3; ++i) {
    s += "F" + std::to_string(i) + " = asp(d0, c" + std::to_string(i) + ", 0, \"a" + std::to_string(i) + "\")\n";
    s += "D" + std::to_string(i + 3) + " = dsp(d1, c" + std::to_string(i) + ", 0, \"x" + std::to_string(i) + "\")\n";
  }
  for (int i = 0; i < n; ++i) {
    const BlockSpec& b = *chosen[static_cast<size_t>(i)];
    const std::string id = std::string(b.out_kind == Kind::kAnalog ? "F" : "D") + std::to_string(6 + i);
    g.names.push_back(id);
    s += id + " = " + b.name + "(";
    const uint32_t n_in = b.min_inputs + (b.max_inputs > b.min_inputs ? static_cast<uint32_t>(rng() % 2) : 0u);
    for (uint32_t k = 0; k < n_in; ++k) {
      const auto& pool = b.input_kind[k] == Kind::kAnalog ? analog_ids : digital_ids;
      const uint32_t ref = pool[rng() % pool.size()];
      s += std::string(k ? ", " : "") + (b.input_kind[k] == Kind::kAnalog ? "F" : "D") + std::to_string(ref);
    }
    std::vector<double> params;
    for (uint8_t k = 0; k < b.param_count; ++k) {
      const ParamSpec& p = b.params[k];
      double lo = std::max(p.min, -5.0), hi = std::min(p.max, 5.0);
      double v = lo + (hi - lo) * static_cast<double>(rng() % 1000) / 1000.0;
      if (p.min_exclusive && v <= p.min) v = p.min + 0.5;
      if (p.integer) v = std::floor(v);
      params.push_back(v);
    }
    if (std::string_view(b.name) == "lim" && params[0] > params[1]) std::swap(params[0], params[1]);
    if (std::string_view(b.name) == "pidc" && params[3] > params[4])
      std::swap(params[3], params[4]);
    bool first = n_in == 0;  // `const` and `dconst` have parameters only
    for (double v : params) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.17g", v);
      s += std::string(first ? "" : ", ") + buf;
      first = false;
    }
    s += ")\n";
  }
  s += "END\n";
  return g;
}

uint32_t index_of(const TaskImage& img, const std::string& name) {
  for (uint32_t i = 0; i < img.blocks().size(); ++i) {
    if (name == img.str(img.blocks()[i].name)) return i;
  }
  ADD_FAILURE() << name;
  return 0;
}

TEST(Compiler, batched_schedule_gives_the_results_of_textual_order) {
  std::mt19937 rng(2024);
  int runs_shorter = 0;
  for (int trial = 0; trial < 60; ++trial) {
    Generated g = random_program(rng, 20 + trial * 3);
    CompileOptions text_order;
    text_order.batch = false;
    CompileOptions batched;
    CompileResult a = compile_source(g.source, text_order);
    CompileResult b = compile_source(g.source, batched);
    ASSERT_TRUE(a.ok()) << a.diags.render("gen", g.source) << g.source;
    ASSERT_TRUE(b.ok());
    if (b.image->runs().size() < a.image->runs().size()) ++runs_shorter;
    TaskArena aa(*a.image), ab(*b.image);
    std::mt19937 inputs(static_cast<unsigned>(trial));
    for (int cycle = 0; cycle < 25; ++cycle) {
      for (const Binding& bd : a.image->bindings()) {
        const double v = bd.kind == Kind::kAnalog ? static_cast<double>(inputs() % 2001) / 100.0 - 10.0
                                                   : static_cast<double>(inputs() % 2);
        aa.io_in[bd.io_index] = v;
        for (const Binding& bb : b.image->bindings()) {
          if (std::strcmp(a.image->str(bd.label), b.image->str(bb.label)) == 0) ab.io_in[bb.io_index] = v;
        }
      }
      execute_cycle(*a.image, aa);
      execute_cycle(*b.image, ab);
      for (const std::string& n : g.names) {
        const uint32_t ia = index_of(*a.image, n), ib = index_of(*b.image, n);
        const double va = aa.values[a.image->code()[ia].out], vb = ab.values[b.image->code()[ib].out];
        ASSERT_EQ(std::memcmp(&va, &vb, sizeof va), 0)
            << "trial " << trial << " cycle " << cycle << " block " << n << ": " << va << " vs " << vb
            << "\n" << g.source;
        ASSERT_EQ(aa.errors[ia], ab.errors[ib]) << n;
      }
    }
  }
  EXPECT_GT(runs_shorter, 50);  // batching actually grouped blocks in almost every program
}

TEST(Compiler, both_interpreter_bodies_give_bit_identical_results) {
  if (!executor_body_available(ExecutorBody::kAvx2)) GTEST_SKIP() << "this CPU has no AVX2 body";
  std::mt19937 rng(77);
  for (int trial = 0; trial < 30; ++trial) {
    Generated g = random_program(rng, 200 + trial * 20);
    CompileResult r = compile_source(g.source);
    ASSERT_TRUE(r.ok());
    TaskArena a(*r.image), b(*r.image);
    const ExecContext ca = make_context(*r.image, a), cb = make_context(*r.image, b);
    std::mt19937 inputs(static_cast<unsigned>(trial));
    for (int cycle = 0; cycle < 25; ++cycle) {
      for (size_t i = 0; i < a.io_in.size(); ++i) {
        a.io_in[i] = b.io_in[i] = static_cast<double>(inputs() % 2001) / 100.0 - 10.0;
      }
      execute_cycle_on(ExecutorBody::kBaseline, ca);
      execute_cycle_on(ExecutorBody::kAvx2, cb);
      ASSERT_EQ(std::memcmp(a.values.data(), b.values.data(), a.values.size() * sizeof(double)), 0)
          << "trial " << trial << " cycle " << cycle;
      ASSERT_EQ(a.state, b.state);
      ASSERT_EQ(a.errors, b.errors);
    }
  }
}

TEST(Compiler, replicated_loops_become_long_runs) {
  std::string s = "%%\n";
  for (int i = 0; i < 100; ++i) {
    const int b = i * 10;
    auto F = [&](int k) { return "F" + std::to_string(b + k); };
    s += F(0) + " = asp(d0, c" + std::to_string(i) + ", 1, \"sp" + std::to_string(i) + "\")\n";
    s += F(1) + " = filt(" + F(4) + ", 2)\n";
    s += F(2) + " = sub(" + F(0) + ", " + F(1) + ")\n";
    s += F(3) + " = epi(" + F(2) + ", 1, 3)\n";
    s += F(4) + " = lim(" + F(3) + ", 0, 100)\n";
  }
  s += "END\n";
  CompileResult r = compile_source(s);
  ASSERT_TRUE(r.ok()) << r.diags.render("t", s);
  EXPECT_EQ(r.image->header().n_instr, 500u);
  EXPECT_EQ(r.image->runs().size(), 5u);  // LoadA, Filt, Sub, Epi, Lim: one run each
  for (const rtplc::Run& run : r.image->runs()) EXPECT_EQ(run.end - run.begin, 100u);
}

TEST(Compiler, explain_lists_order_delays_bindings_and_sizes) {
  CompileResult r = compile_source(
      "%%\nF0 = dai(p0, d0, c0, \"PV_Msp\")\nF1 = asp(d0, c0, 2, \"SV_Msp\")\nF20 = derv(F0, 1)\n"
      "F21 = sub(F41, F20, 1)\nF41 = epi(F21, 3, 3)\nF61 = sub(F41, F20, 1)\n"
      "dao(F61, p0, d0, c0, \"MV_Msp\")\nEND\n%%\n");
  ASSERT_TRUE(r.ok());
  std::string e = explain(r);
  EXPECT_NE(e.find("Delayed references: 1"), std::string::npos) << e;
  EXPECT_NE(e.find("line 5:11  F21 reads F41, which runs later (#4): one-cycle delay"), std::string::npos) << e;
  EXPECT_NE(e.find("in       DIO    p0.d0.c0       analog   PV_Msp"), std::string::npos) << e;
  EXPECT_NE(e.find("setpoint SETP   d0.c0          analog   SV_Msp =2"), std::string::npos) << e;
  EXPECT_NE(e.find("out      DIO    p0.d0.c0       analog   MV_Msp"), std::string::npos) << e;
  EXPECT_NE(e.find("state         3 doubles in 2 blocks"), std::string::npos) << e;
}

TEST(Compiler, never_crashes_on_garbage) {
  std::mt19937 rng(99);
  const std::string alphabet = "FDMNPpdc0123456789=(),%|:{}\" \n-+.eEabsdiunMACROENDRETURN/*";
  for (int i = 0; i < 3000; ++i) {
    std::string s;
    const size_t len = rng() % 200;
    for (size_t k = 0; k < len; ++k) s += alphabet[rng() % alphabet.size()];
    CompileResult r = compile_source(s);
    if (!r.ok()) {
      EXPECT_TRUE(r.diags.has_errors());
    }
  }
}

}  // namespace
}  // namespace rtplc::lang
