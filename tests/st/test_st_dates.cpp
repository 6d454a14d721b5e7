// DATE, TIME_OF_DAY and DATE_AND_TIME in ST (docs/st.md, "Dates and times of
// day"): literals, variables, the standard's date arithmetic functions, and
// the refusal of a date that does not exist, at its line:col. The expected
// values are worked by hand: 2024-01-15 is 54 years after 1970 with 13 leap
// days between (1972..2020), 54 * 365 + 13 + 14 = 19737 days, 1,705,276,800 s;
// 2024-02-29 is 19723 + 31 + 28 = 19782 days, 1,709,164,800 s.
#include <gtest/gtest.h>

#include <tuple>

#include <string>

#include "lang/compiler.h"
#include "tests/support/block_value.h"
#include "lang/front_end.h"
#include "tests/st/first_error.h"
#include "tests/support/fbd_harness.h"

namespace rtplc::lang {
namespace {

using testing::FbdHarness;

constexpr double kJan15 = 1705276800;  // D#2024-01-15
constexpr double kLeapDay = 1709164800;  // D#2024-02-29

using testing::first_error;

TEST(StDates, literals_are_seconds_since_1970_or_since_midnight) {
  const char* src = R"(PROGRAM Main
VAR
  d : DATE;
  d2 : DATE;
  t : TOD;
  t2 : TIME_OF_DAY;
  x : DT;
  x2 : DATE_AND_TIME;
END_VAR
  d := D#2024-01-15;
  d2 := DATE#2024-02-29;
  t := TOD#12:30:15.5;
  t2 := TIME_OF_DAY#07:05;
  x := DT#2024-02-29-23:59:59.25;
  x2 := DATE_AND_TIME#1970-01-01-00:00:01;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("d.st", src);
  h.step();
  EXPECT_EQ(h.value("Main.d"), kJan15);
  EXPECT_EQ(h.value("Main.d2"), kLeapDay);
  EXPECT_EQ(h.value("Main.t"), 45015.5);  // 12 * 3600 + 30 * 60 + 15.5
  EXPECT_EQ(h.value("Main.t2"), 25500);   // 7 * 3600 + 5 * 60
  EXPECT_EQ(h.value("Main.x"), kLeapDay + 86399.25);
  EXPECT_EQ(h.value("Main.x2"), 1);
}

TEST(StDates, the_standard_functions_give_exact_microseconds) {
  const char* src = R"(PROGRAM Main
VAR
  a : DT := DT#2024-02-29-23:59:59.25;
  b : DT := DT#2024-03-01-00:00:00.000001;
  gap, days, tods : TIME;
  later, earlier, joined : DT;
  tod, tod2, tod3 : TOD;
  day : DATE;
  after : BOOL;
END_VAR
  gap := SUB_DT_DT(b, a);
  days := SUB_DATE_DATE(D#2024-03-01, D#2024-01-15);
  tods := SUB_TOD_TOD(TOD#12:00:00, TOD#11:59:59.999999999);
  later := ADD_DT_TIME(a, T#750ms);
  earlier := SUB_DT_TIME(a, T#1d);
  tod := DT_TO_TOD(a);
  day := DT_TO_DATE(a);
  joined := CONCAT_DATE_TOD(D#2024-02-29, TOD#23:59:59.25);
  tod2 := ADD_TOD_TIME(TOD#23:00:00, T#30m);
  tod3 := SUB_TOD_TIME(TOD#00:30:00, T#15m);
  after := b > a;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("d.st", src);
  h.step();
  // A double near 1.7e9 s is 0.24 us coarse: the plain difference would be off
  // by up to that much; SUB_DT_DT puts it on the microsecond grid.
  EXPECT_EQ(h.value("Main.gap"), 0.750001);
  EXPECT_EQ(h.value("Main.days"), 46.0 * 86400);  // 17 days to February 1, then 29 of February
  EXPECT_EQ(h.value("Main.tods"), 1e-9);
  EXPECT_EQ(h.value("Main.later"), kLeapDay + 86400);  // 2024-03-01-00:00:00
  EXPECT_EQ(h.value("Main.earlier"), kLeapDay + 86399.25 - 86400);
  EXPECT_EQ(h.value("Main.tod"), 86399.25);
  EXPECT_EQ(h.value("Main.day"), kLeapDay);
  EXPECT_EQ(h.value("Main.joined"), h.value("Main.a"));
  EXPECT_EQ(h.value("Main.tod2"), 84600);  // 23:30
  EXPECT_EQ(h.value("Main.tod3"), 900);    // 00:15
  EXPECT_EQ(h.value("Main.after"), 1);
}

TEST(StDates, a_dt_stepped_every_cycle_does_not_drift) {
  // 1,000 steps of 1 ms from a date in 2024: a DT variable lands on the
  // microsecond grid at each assignment, so it reaches the next second exactly
  // (a bare double sum near 1.7e9 would not).
  const char* src = R"(PROGRAM Main
VAR
  x : DT := DT#2024-01-15-08:00:00;
  n : INT;
  at_second : BOOL;
END_VAR
  x := x + T#1ms;
  n := n + 1;
  at_second := x = DT#2024-01-15-08:00:01;
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("d.st", src);
  for (int k = 0; k < 1000; ++k) h.step();
  EXPECT_EQ(h.value("Main.n"), 1000);
  EXPECT_EQ(h.value("Main.x"), kJan15 + 8 * 3600 + 1);
  EXPECT_EQ(h.value("Main.at_second"), 1);
}

TEST(StDates, a_date_that_does_not_exist_is_refused_at_its_place) {
  const std::string head = "PROGRAM Main\nVAR\n  d : DATE;\n  t : TOD;\nEND_VAR\n";
  EXPECT_NE(first_error(head + "  d := D#2023-02-29;\nEND_PROGRAM\n").find("6:8: 'D#2023-02-29' is not a literal"),
            std::string::npos);
  EXPECT_NE(first_error(head + "  t := TOD#24:00:00;\nEND_PROGRAM\n").find("6:8: 'TOD#24:00:00' is not a literal"),
            std::string::npos);
  EXPECT_NE(first_error(head + "  d := D#1969-12-31;\nEND_PROGRAM\n").find("from 1970 to 2255"), std::string::npos);
  EXPECT_NE(first_error(head + "  t := TOD#12:3x;\nEND_PROGRAM\n").find("6:8:"), std::string::npos);
}

// Dates meeting numbers, as each editor's runtime converts: MatIEC in seconds
// for every time type (the fraction dropped into an integer: tv_sec), CODESYS
// in seconds for DATE and DT, milliseconds for TOD (and TIME).
TEST(StDates, conversions_to_and_from_numbers_follow_the_chosen_editor) {
  const char* src = R"(PROGRAM Main
VAR
  x : DT := DT#2024-01-15-12:00:00.75;
  d : DATE := D#2024-01-15;
  t : TOD := TOD#12:30:15.5;
  xs, ds, ts : UDINT;
  xr : LREAL;
  back : DT;
  tb : TOD;
  dd : DATE;
  on : BOOL;
  g : TOD;
  dur : TIME := T#1.5s;
  dn : DINT;
END_VAR
  xs := DT_TO_UDINT(x); ds := DATE_TO_UDINT(d); ts := TOD_TO_UDINT(t);
  xr := DT_TO_LREAL(x);
  back := UDINT_TO_DT(xs);
  tb := UDINT_TO_TOD(ts);
  dd := TO_DATE(x);
  g := TO_TOD(x);
  on := DT_TO_BOOL(x);
  dn := TO_DINT(dur);
END_PROGRAM
)";
  struct Want {
    EditorSemantics sem;
    double xs, ts, tb, dn;
  };
  // DT_TO_UDINT: MatIEC drops the .75 s (tv_sec); CODESYS rounds it, as it rounds a REAL.
  for (const Want& w : {Want{EditorSemantics::kMatiec, kJan15 + 12 * 3600, 45015, 45015, 1},
                        Want{EditorSemantics::kCodesys, kJan15 + 12 * 3600 + 1, 45015500, 45015.5, 1500}}) {
    CompileOptions o;
    o.semantics = w.sem;
    o.period_override = 0.01;
    CompileResult r = compile_source(src, o);
    ASSERT_TRUE(r.ok()) << r.diags.render("d.st", src);
    TaskArena arena(*r.image);
    execute_cycle(*r.image, arena);
    auto value = [&](std::string_view name) { return testing::block_value(r, arena, name); };
    const int k = static_cast<int>(w.sem);
    EXPECT_EQ(value("Main.xs"), w.xs) << k;
    EXPECT_EQ(value("Main.ds"), kJan15) << k;
    EXPECT_EQ(value("Main.ts"), w.ts) << k;
    EXPECT_EQ(value("Main.xr"), kJan15 + 12 * 3600 + 0.75) << k;
    EXPECT_EQ(value("Main.back"), value("Main.xs")) << k;
    EXPECT_EQ(value("Main.tb"), w.tb) << k;
    EXPECT_EQ(value("Main.dd"), kJan15) << k;
    EXPECT_EQ(value("Main.g"), 12 * 3600 + 0.75) << k;
    EXPECT_EQ(value("Main.on"), 1) << k;
    EXPECT_EQ(value("Main.dn"), w.dn) << k;  // TO_DINT of a TIME variable counts as TIME_TO_DINT does
  }
}

TEST(StDates, a_conversion_between_time_types_the_standard_lacks_is_refused_by_name) {
  const std::string head = "PROGRAM Main\nVAR\n  d : DATE;\n  t : TOD;\n  x : DT;\n  s : TIME;\nEND_VAR\n";
  EXPECT_NE(first_error(head + "  s := TOD_TO_TIME(t);\nEND_PROGRAM\n").find("8:8: TOD_TO_TIME is no conversion of the standard"),
            std::string::npos);
  EXPECT_NE(first_error(head + "  x := DATE_TO_DT(d);\nEND_PROGRAM\n").find("CONCAT_DATE_TOD"), std::string::npos);
  EXPECT_NE(first_error(head + "  s := TO_TIME(x);\nEND_PROGRAM\n").find("TO_TIME of a DT"), std::string::npos);
}

// The standard's TIME functions (IEC 61131-3 ed. 2, table 30) on the
// nanosecond grid: ADD_TIME, SUB_TIME, MULTIME and DIVTIME (and MUL_TIME,
// DIV_TIME), as OSCAT and MatIEC programs call them.
TEST(StDates, add_sub_mul_and_div_of_time_land_on_the_nanosecond_grid) {
  const char* src = R"(PROGRAM Main
VAR
  a, b, m, d, m2, d2 : TIME;
  n : INT := 3;
END_VAR
  a := ADD_TIME(T#1s, T#250ms);
  b := SUB_TIME(T#1s, T#250ms);
  m := MULTIME(T#100ms, n);
  d := DIVTIME(T#1s, n);
  m2 := MUL_TIME(T#1ms, 1000);
  d2 := DIV_TIME(T#1s, 8);
END_PROGRAM
)";
  FbdHarness h(src, 0.01, true, true);
  ASSERT_TRUE(h.ok()) << h.result().diags.render("t.st", src);
  h.step();
  EXPECT_EQ(h.value("Main.a"), 1.25);
  EXPECT_EQ(h.value("Main.b"), 0.75);
  EXPECT_EQ(h.value("Main.m"), 0.3);  // 0.1 * 3 is 0.30000000000000004 as a bare double
  EXPECT_EQ(h.value("Main.d"), 0.333333333);
  EXPECT_EQ(h.value("Main.m2"), 1);
  EXPECT_EQ(h.value("Main.d2"), 0.125);
}


// TO_DINT of a TIME literal, a timer's ET and a sum of TIMEs converts from the
// TIME, as TIME_TO_DINT does (ms under CODESYS, whole seconds under MatIEC).
TEST(StDates, to_dint_of_a_time_literal_an_et_and_a_sum_is_time_to_dint) {
  const char* src = R"(PROGRAM Main
VAR
  t : TON;
  a : TIME := T#1s;
  lit, et, sum, day : DINT;
END_VAR
  t(IN := TRUE, PT := T#10s);
  lit := TO_DINT(T#1500ms);
  et := TO_DINT(t.ET);
  sum := TO_DINT(a + T#2s500ms);
  day := TO_DINT(D#1970-01-02);
END_PROGRAM
)";
  for (const auto& [sem, lit, et, sum] : {std::tuple{EditorSemantics::kMatiec, 1.0, 2.0, 3.0},
                                          std::tuple{EditorSemantics::kCodesys, 1500.0, 2500.0, 3500.0}}) {
    CompileOptions o;
    o.semantics = sem;
    o.period_override = 0.5;
    CompileResult r = compile_source(src, o);
    ASSERT_TRUE(r.ok()) << r.diags.render("d.st", src);
    TaskArena arena(*r.image);
    for (int k = 0; k < 6; ++k) execute_cycle(*r.image, arena);  // ET = 2.5 s after six cycles of 0.5 s
    auto value = [&](std::string_view name) { return testing::block_value(r, arena, name); };
    const int k = static_cast<int>(sem);
    EXPECT_EQ(value("Main.lit"), lit) << k;
    EXPECT_EQ(value("Main.et"), et) << k;
    EXPECT_EQ(value("Main.sum"), sum) << k;
    EXPECT_EQ(value("Main.day"), 86400) << k;  // a DATE counts seconds for both
  }
}

}  // namespace
}  // namespace rtplc::lang
