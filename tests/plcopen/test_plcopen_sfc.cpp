// The PLCopen importer's SFC bodies (docs/plcopen.md, "SFC"): the action
// qualifiers beyond N S R P L D, and transition conditions drawn in FBD or LD,
// run cycle by cycle on projects written for these tests (tests/plcopen/data).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "lang/compiler.h"
#include "tests/plcopen/plcopen_harness.h"

namespace rtplc::lang {
namespace {

std::string read_data(const char* f) {
  std::ifstream in(data(f));
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// `text` with its first `from` replaced by `to` (the test fails if absent).
std::string edited(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The first error's message and line, or "" when it compiled.
std::string first_error(const CompileResult& r, uint32_t* line = nullptr) {
  for (const Diagnostic& d : r.diags.items()) {
    if (d.severity != Severity::kError) continue;
    if (line) *line = d.pos.line;
    return d.message;
  }
  return "";
}

// sfc_qualifiers.xml at 100 ms, cycle by cycle: go, stop and rst as "100"...;
// per cycle the active step's initial and p1_out p0_out sd_out ds_out sl_out.
TEST(PlcopenSfcQualifiers, p1_p0_sd_ds_and_sl_follow_the_hand_worked_trace) {
  CompileResult r = compile_file(data("sfc_qualifiers.xml"));
  ASSERT_TRUE(r.ok()) << r.diags.render("sfc_qualifiers.xml", read_data("sfc_qualifiers.xml"));
  Machine run(std::move(*r.image));
  const std::vector<std::string> inputs = {"000", "100", "010", "000", "000", "000", "100", "010",
                                           "001", "000", "100", "000", "000", "000", "010", "001"};
  std::string got;
  for (const std::string& in : inputs) {
    run.set("go", in[0] == '1');
    run.set("stop", in[1] == '1');
    run.set("rst", in[2] == '1');
    run.cycles(1);
    for (const char* st : {"Idle", "Run", "Clear"}) {
      if (run.value(std::string("q0.step.") + st + ".X") != 0) got += st[0];
    }
    for (const char* v : {"p1_out", "p0_out", "sd_out", "ds_out", "sl_out"})
      got += std::to_string(static_cast<int>(run.value(std::string("q0.") + v)));
    got += ' ';
  }
  // Run is active in cycles 2, 7 and 11-14 (T = 0.3 s is three cycles):
  // P1 pulses as Run starts, P0 as it ends; SD comes on 3 cycles after cycle 2
  // though Run ended, stays on until Clear's R, and again 3 cycles after 11;
  // DS only once Run lasts 3 cycles (cycle 14), stored past Run's end; SL is
  // on for 3 cycles from 2, not again in 7 (not reset yet), again from 11.
  EXPECT_EQ(got,
            "I00000 R10001 I01001 I00001 I00100 I00100 R10100 I01100 "
            "C00000 I00000 R10001 R00001 R00001 R00110 I01110 C00000 ");
  EXPECT_EQ(run.value("q0.ends"), 3) << "the P0 action body ran once per end of Run";
}

TEST(PlcopenSfcQualifiers, a_timed_qualifier_needs_a_duration_and_dl_is_refused) {
  const std::string xml = read_data("sfc_qualifiers.xml");
  const std::pair<const char*, uint32_t> timed[] = {{"SD", 51}, {"DS", 52}, {"SL", 53}};
  for (const auto& [q, at] : timed) {
    const std::string with = std::string("qualifier=\"") + q + "\" duration=\"T#300ms\"";
    CompileResult r = compile_source(edited(xml, with, std::string("qualifier=\"") + q + "\""));
    uint32_t line = 0;
    EXPECT_EQ(first_error(r, &line), std::string("qualifier ") + q + " needs a duration");
    EXPECT_EQ(line, at) << "the <action>'s line";
  }
  CompileResult dl = compile_source(edited(xml, "qualifier=\"SD\"", "qualifier=\"DL\""));
  EXPECT_NE(first_error(dl).find("action qualifier DL is not supported"), std::string::npos)
      << first_error(dl);
}

}  // namespace
}  // namespace rtplc::lang
