// The IEC 61131-3 function table (lang/iec/): each standard function or block
// lowered through the Emitter into a flat program, checked by the same
// language-neutral checks as every front end, compiled and run cycle by cycle.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "blocks/executor.h"
#include "lang/compiler.h"
#include "lang/iec/emitter.h"
#include "lang/iec/iec_functions.h"
#include "lang/program_checks.h"

namespace rtplc::lang::iec {
namespace {

// A flat program with set-points the test drives by label, and the lowered calls.
class Lowered {
 public:
  // An analog (or digital) set-point named `label`; returns its producer index.
  uint32_t input(const std::string& label, Kind kind) {
    FlatBlock b;
    b.written = kind == Kind::kAnalog ? "asp" : "dsp";
    b.name = label;
    b.pos = SourcePos{1, 1};
    b.d = 0;
    b.c = next_channel_++;
    b.label = label;
    prog_.blocks.push_back(b);
    return static_cast<uint32_t>(prog_.blocks.size() - 1);
  }

  std::vector<uint32_t> call(const std::string& name, std::vector<uint32_t> inputs,
                             IecType type = IecType::kReal, std::vector<bool> wanted = {}) {
    const IecFunction* f = find_iec(name);
    EXPECT_NE(f, nullptr) << name;
    if (f == nullptr) return {};
    Emitter e(prog_, "main." + name + std::to_string(++calls_), SourcePos{2, 1});
    IecCall c;
    c.inputs = std::move(inputs);
    c.type = type;
    c.wanted = std::move(wanted);
    auto r = f->lower(*f, e, c);
    EXPECT_TRUE(r.ok()) << name << ": " << (r.ok() ? "" : r.error());
    return r.ok() ? *r : std::vector<uint32_t>{};
  }

  bool build() {
    DiagnosticList diags;
    check_flat_program(prog_, diags);
    EXPECT_EQ(diags.error_count(), 0u) << diags.render("lowered", "");
    warnings_ = diags.warning_count();
    if (diags.error_count() != 0) return false;
    auto img = build_image(prog_, CompileOptions{}, 0);
    EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error());
    if (!img.ok()) return false;
    image_ = std::move(*img);
    arena_.resize_for(image_);
    return true;
  }

  void set(const std::string& label, double v) {
    for (const Binding& b : image_.bindings()) {
      if (label == image_.str(b.label)) arena_.io_in[b.io_index] = v;
    }
  }
  void step(int n = 1) {
    for (int k = 0; k < n; ++k) execute_cycle(image_, arena_);
  }
  double value(uint32_t producer) const {
    const std::string& name = prog_.blocks[producer].name;
    for (uint32_t i = 0; i < image_.blocks().size(); ++i) {
      if (name == image_.str(image_.blocks()[i].name)) return arena_.values[image_.code()[i].out];
    }
    ADD_FAILURE() << "no block " << name;
    return 0;
  }
  size_t blocks() const { return prog_.blocks.size(); }
  size_t warnings() const { return warnings_; }

 private:
  CheckedProgram prog_;
  TaskImage image_;
  TaskArena arena_;
  uint32_t next_channel_ = 0;
  int calls_ = 0;
  size_t warnings_ = 0;
};

TEST(IecTable, finds_functions_blocks_and_conversions_by_any_case) {
  for (const char* n :
       {"TON",    "tof",         "Tp",          "CTU",          "CTD",     "CTUD",     "R_TRIG",
        "F_TRIG", "SR",          "RS",          "LIMIT",        "MAX",     "MIN",      "MOVE",
        "SEL",    "MUX",         "ADD",         "SUB",          "MUL",     "DIV",      "MOD",
        "EXPT",   "GT",          "NE",          "AND",          "XOR",     "NOT",      "SHL",
        "ROR",    "INT_TO_REAL", "REAL_TO_INT", "TIME_TO_DINT", "TO_UINT", "CTU_DINT", "TRUNC"}) {
    EXPECT_NE(find_iec(n), nullptr) << n;
  }
  EXPECT_EQ(find_iec("PID"), nullptr);
  EXPECT_EQ(find_iec("INT_TO_INT"), nullptr);
  EXPECT_EQ(find_iec("CONCAT"), nullptr);
  const IecFunction& ton = *find_iec("TON");
  EXPECT_TRUE(ton.function_block);
  EXPECT_EQ(iec_input_index(ton, "pt"), 1);
  EXPECT_EQ(iec_output_index(ton, "ET"), 1);
  EXPECT_EQ(iec_input_index(ton, "IN2"), -1);
  EXPECT_EQ(iec_input_index(*find_iec("ADD"), "IN5"), 4);
  EXPECT_EQ(iec_input_index(*find_iec("MUX"), "IN3"), 4);  // K, IN0, IN1, IN2, IN3
  EXPECT_EQ(iec_output_index(*find_iec("CTUD"), "QD"), 1);
}

TEST(IecLowering, ton_gives_q_and_et_and_leaves_out_an_unwanted_et) {
  Lowered p;
  const uint32_t in = p.input("in", Kind::kDigital), pt = p.input("pt", Kind::kAnalog);
  const auto both = p.call("TON", {in, pt});
  const size_t before = p.blocks();
  const auto q_only = p.call("TON", {in, pt}, IecType::kReal, {true, false});
  EXPECT_EQ(p.blocks() - before, 1u);
  EXPECT_EQ(q_only[1], kUnconnected);
  ASSERT_TRUE(p.build());
  EXPECT_EQ(p.warnings(), 0u);  // lowered helpers are not "unused results"
  p.set("pt", 0.2);
  const std::vector<int> x = {0, 1, 1, 1, 1, 0};
  const std::vector<int> q = {0, 0, 0, 1, 1, 0};
  const std::vector<double> et = {0, 0, 0.1, 0.2, 0.2, 0};
  for (size_t c = 0; c < x.size(); ++c) {
    p.set("in", x[c]);
    p.step();
    EXPECT_EQ(p.value(both[0]), q[c]) << c;
    EXPECT_NEAR(p.value(both[1]), et[c], 1e-12) << c;
    EXPECT_EQ(p.value(q_only[0]), q[c]) << c;
  }
}

TEST(IecLowering, ctud_follows_the_standard_with_reset_over_load) {
  Lowered p;
  const uint32_t cu = p.input("cu", Kind::kDigital), cd = p.input("cd", Kind::kDigital);
  const uint32_t r = p.input("r", Kind::kDigital), ld = p.input("ld", Kind::kDigital);
  const uint32_t pv = p.input("pv", Kind::kAnalog);
  const auto o = p.call("CTUD", {cu, cd, r, ld, pv});
  ASSERT_EQ(o.size(), 3u);
  ASSERT_TRUE(p.build());
  p.set("pv", 2);
  struct Row {
    int cu, cd, r, ld;
    double cv;
    int qu, qd;
  };
  for (Row w : {Row{1, 0, 0, 0, 1, 0, 0}, Row{0, 0, 0, 0, 1, 0, 0}, Row{1, 0, 0, 0, 2, 1, 0},
                Row{0, 1, 0, 0, 1, 0, 0}, Row{0, 0, 0, 1, 2, 1, 0}, Row{0, 0, 1, 1, 0, 0, 1},
                Row{1, 1, 0, 0, 0, 0, 1}, Row{0, 0, 0, 0, 0, 0, 1},
                Row{0, 1, 0, 0, 0, 0, 1},   // at 0: CD counts no further (MatIEC's and CODESYS's CTUD)
                Row{1, 0, 0, 0, 1, 0, 0}, Row{0, 0, 0, 0, 1, 0, 0}, Row{1, 0, 0, 0, 2, 1, 0},
                Row{0, 0, 0, 0, 2, 1, 0}, Row{1, 0, 0, 0, 2, 1, 0}}) {  // at PV: CU counts no further
    p.set("cu", w.cu);
    p.set("cd", w.cd);
    p.set("r", w.r);
    p.set("ld", w.ld);
    p.step();
    EXPECT_EQ(p.value(o[2]), w.cv);
    EXPECT_EQ(p.value(o[0]), w.qu);
    EXPECT_EQ(p.value(o[1]), w.qd);
  }
}

// CTU counts up while CV < PV, CTD down while CV > 0 (MatIEC's counter.txt,
// CODESYS's PV "upper limit for incrementing"); a PV raised later lets CTU go on.
TEST(IecLowering, ctu_stops_at_pv_and_ctd_at_zero) {
  Lowered p;
  const uint32_t cu = p.input("cu", Kind::kDigital), pv = p.input("pv", Kind::kAnalog);
  const uint32_t ld = p.input("ld", Kind::kDigital);
  const auto o = p.call("CTU", {cu, kUnconnected, pv});
  const auto d = p.call("CTD", {cu, ld, pv});
  ASSERT_TRUE(p.build());
  p.set("pv", 3);
  p.set("ld", 1);
  p.step();
  EXPECT_EQ(p.value(d[1]), 3);
  p.set("ld", 0);
  auto pulses = [&](int n) {
    for (int k = 0; k < n; ++k) {
      p.set("cu", 1);
      p.step();
      p.set("cu", 0);
      p.step();
    }
  };
  pulses(5);
  EXPECT_EQ(p.value(o[1]), 3);  // not 5
  EXPECT_EQ(p.value(o[0]), 1);
  EXPECT_EQ(p.value(d[1]), 0);  // not -2
  EXPECT_EQ(p.value(d[0]), 1);
  p.set("pv", 4);
  pulses(2);
  EXPECT_EQ(p.value(o[1]), 4);
  EXPECT_EQ(p.value(d[1]), 0);
  // A CU held high while at PV is no edge once PV rises: the edge memory
  // followed CU all along (as MatIEC's R_TRIG instance does).
  p.set("cu", 1);
  p.step();
  p.set("pv", 9);
  p.step();
  EXPECT_EQ(p.value(o[1]), 4);
}

TEST(IecLowering, integer_arithmetic_wraps_and_divides_toward_zero) {
  Lowered p;
  const uint32_t a = p.input("a", Kind::kAnalog), b = p.input("b", Kind::kAnalog);
  const uint32_t add = p.call("ADD", {a, b}, IecType::kInt)[0];
  const uint32_t div = p.call("DIV", {a, b}, IecType::kInt)[0];
  const uint32_t rdiv = p.call("DIV", {a, b}, IecType::kReal)[0];
  const uint32_t mod = p.call("MOD", {a, b}, IecType::kInt)[0];
  const uint32_t mul = p.call("MUL", {a, b, b}, IecType::kSint)[0];
  ASSERT_TRUE(p.build());
  p.set("a", 32767);
  p.set("b", 1);
  p.step();
  EXPECT_EQ(p.value(add), -32768);
  p.set("a", -7);
  p.set("b", 2);
  p.step();
  EXPECT_EQ(p.value(div), -3);
  EXPECT_EQ(p.value(rdiv), -3.5);
  EXPECT_EQ(p.value(mod), -1);
  EXPECT_EQ(p.value(mul), -28);
  p.set("a", 100);
  p.step();
  EXPECT_EQ(p.value(mul), 400 - 512);  // 400 as a SINT
}

TEST(IecLowering, conversions_round_wrap_and_scale_time_to_milliseconds) {
  Lowered p;
  const uint32_t x = p.input("x", Kind::kAnalog), d = p.input("d", Kind::kDigital);
  const uint32_t r2i = p.call("REAL_TO_INT", {x})[0];
  const uint32_t r2u = p.call("LREAL_TO_USINT", {x})[0];
  const uint32_t i2r = p.call("INT_TO_REAL", {x})[0];
  const uint32_t t2d = p.call("TIME_TO_DINT", {x})[0];
  const uint32_t d2t = p.call("DINT_TO_TIME", {x})[0];
  const uint32_t b2i = p.call("BOOL_TO_INT", {d})[0];
  const uint32_t i2b = p.call("INT_TO_BOOL", {x})[0];
  const uint32_t to = p.call("TO_SINT", {x}, IecType::kDint)[0];
  const uint32_t tr = p.call("TRUNC", {x}, IecType::kInt)[0];
  ASSERT_TRUE(p.build());
  p.set("x", 2.5);
  p.set("d", 1);
  p.step();
  EXPECT_EQ(p.value(r2i), 2);  // an exact half goes to the even neighbour
  EXPECT_EQ(p.value(i2r), 2.5);  // the importer's INT never holds 2.5; the value passes unchanged
  EXPECT_EQ(p.value(t2d), 2500);
  EXPECT_EQ(p.value(d2t), 0.0025);
  EXPECT_EQ(p.value(b2i), 1);
  EXPECT_EQ(p.value(i2b), 1);
  EXPECT_EQ(p.value(tr), 2);
  p.set("x", -2.5);
  p.step();
  EXPECT_EQ(p.value(r2i), -2);
  EXPECT_EQ(p.value(r2u), 254);  // -2 as a USINT (the default conversions wrap; MatIEC's give 0)
  EXPECT_EQ(p.value(tr), -2);
  p.set("x", 40000);
  p.step();
  EXPECT_EQ(p.value(r2i), 40000 - 65536);
  EXPECT_EQ(p.value(to), 40000 % 256 - 256 * ((40000 % 256) >= 128));
}

TEST(IecLowering, selection_mux_limit_and_extensible_comparisons) {
  Lowered p;
  const uint32_t k = p.input("k", Kind::kAnalog), g = p.input("g", Kind::kDigital);
  const uint32_t a = p.input("a", Kind::kAnalog), b = p.input("b", Kind::kAnalog),
                 c = p.input("c", Kind::kAnalog);
  const uint32_t mux = p.call("MUX", {k, a, b, c})[0];
  const uint32_t sel = p.call("SEL", {g, a, b})[0];
  const uint32_t lim = p.call("LIMIT", {a, c, b})[0];  // MN = a, IN = c, MX = b
  const uint32_t gt = p.call("GT", {c, b, a})[0];      // c > b > a
  const uint32_t mx = p.call("MAX", {a, c, b})[0];
  const uint32_t mv = p.call("MOVE", {c})[0];
  EXPECT_EQ(mv, c);
  ASSERT_TRUE(p.build());
  p.set("a", 10);
  p.set("b", 20);
  p.set("c", 30);
  p.set("k", 2);
  p.step();
  EXPECT_EQ(p.value(mux), 30);
  EXPECT_EQ(p.value(sel), 10);
  EXPECT_EQ(p.value(lim), 20);
  EXPECT_EQ(p.value(gt), 1);
  EXPECT_EQ(p.value(mx), 30);
  p.set("k", 7);  // out of range: IN0
  p.set("g", 1);
  p.set("c", 15);
  p.step();
  EXPECT_EQ(p.value(mux), 10);
  EXPECT_EQ(p.value(sel), 20);
  EXPECT_EQ(p.value(lim), 15);
  EXPECT_EQ(p.value(gt), 0);
}

TEST(IecLowering, logic_is_boolean_on_bool_and_bitwise_on_bit_strings) {
  Lowered p;
  const uint32_t x = p.input("x", Kind::kDigital), y = p.input("y", Kind::kDigital);
  const uint32_t w = p.input("w", Kind::kAnalog), v = p.input("v", Kind::kAnalog);
  const uint32_t band = p.call("AND", {x, y, x}, IecType::kBool)[0];
  const uint32_t wand = p.call("AND", {w, v}, IecType::kWord)[0];
  const uint32_t wnot = p.call("NOT", {w}, IecType::kWord)[0];
  const uint32_t shl = p.call("SHL", {w, v}, IecType::kByte)[0];
  ASSERT_TRUE(p.build());
  p.set("x", 1);
  p.set("y", 1);
  p.set("w", 0x0F0F);
  p.set("v", 3);
  p.step();
  EXPECT_EQ(p.value(band), 1);
  EXPECT_EQ(p.value(wand), 3);
  EXPECT_EQ(p.value(wnot), 0xF0F0);
  EXPECT_EQ(p.value(shl), 0x78);  // 0x0F as a BYTE, shifted by 3
}

TEST(IecLowering, refuses_a_bitwise_operation_on_a_real) {
  CheckedProgram prog;
  Emitter e(prog, "x", SourcePos{1, 1});
  IecCall c;
  c.inputs = {kUnconnected, kUnconnected};
  c.type = IecType::kReal;
  const IecFunction& shl = *find_iec("SHL");
  auto r = shl.lower(shl, e, c);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("bit string"), std::string::npos) << r.error();
}

// A front end that names its producers (the PLCopen importer) passes external
// operands: stand-ins of a kind, which the lowering converts like any producer
// and leaves in the inputs for the front end to rewrite.
TEST(IecLowering, takes_external_operands_by_kind) {
  CheckedProgram prog;
  Emitter e(prog, "x", SourcePos{1, 1});
  IecCall c;
  const uint32_t in = e.external(Kind::kDigital), pt = e.external(Kind::kAnalog);
  c.inputs = {in, pt};
  const IecFunction& ton = *find_iec("TON");
  auto r = ton.lower(ton, e, c);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(prog.blocks.size(), 2u);  // ton, ton_et: no d2a/a2d, the kinds already fit
  EXPECT_EQ(prog.blocks[0].name, "x.Q");
  EXPECT_EQ(prog.blocks[0].in[0], in);
  EXPECT_EQ(prog.blocks[0].in[1], pt);
  EXPECT_TRUE(Emitter::is_external(in));
  EXPECT_EQ(Emitter::external_slot(pt), 1u);
  EXPECT_FALSE(Emitter::is_external((*r)[0]));
  // A digital operand where an analog one is read gets a d2a, reading the stand-in.
  const uint32_t a = e.analog(in);
  EXPECT_EQ(prog.blocks[a].written, "d2a");
  EXPECT_EQ(prog.blocks[a].in[0], in);
}

TEST(IecTable, says_output_kinds_operand_inputs_and_result_types) {
  const IecFunction& ton = *find_iec("TON");
  EXPECT_EQ(iec_output_kind(ton, 0), Kind::kDigital);  // Q
  EXPECT_EQ(iec_output_kind(ton, 1), Kind::kAnalog);   // ET
  const IecFunction& ctud = *find_iec("CTUD");
  EXPECT_EQ(iec_output_kind(ctud, 1), Kind::kDigital);  // QD
  EXPECT_EQ(iec_output_kind(ctud, 2), Kind::kAnalog);   // CV
  EXPECT_FALSE(iec_input_sets_type(*find_iec("SEL"), 0));
  EXPECT_TRUE(iec_input_sets_type(*find_iec("SEL"), 1));
  EXPECT_FALSE(iec_input_sets_type(*find_iec("SHL"), 1));
  EXPECT_TRUE(iec_input_sets_type(*find_iec("ADD"), 5));
  EXPECT_EQ(iec_result_type(*find_iec("REAL_TO_INT"), IecType::kReal), IecType::kInt);
  EXPECT_EQ(iec_result_type(*find_iec("TO_DINT"), IecType::kReal), IecType::kDint);
  EXPECT_EQ(iec_result_type(*find_iec("TRUNC"), IecType::kReal), IecType::kLint);
  EXPECT_EQ(iec_result_type(*find_iec("ADD"), IecType::kInt), IecType::kInt);
}

TEST(IecTable, generated_docs_match_the_committed_reference) {
  std::ifstream f(std::string(RTPLC_SOURCE_DIR) + "/docs/iec.md");
  ASSERT_TRUE(f) << "docs/iec.md is missing; run: rtplc blocks --iec > docs/iec.md";
  std::stringstream ss;
  ss << f.rdbuf();
  EXPECT_EQ(ss.str(), iec_functions_markdown())
      << "docs/iec.md is out of date; run: rtplc blocks --iec > docs/iec.md";
}

}  // namespace
}  // namespace rtplc::lang::iec
