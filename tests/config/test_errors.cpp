// Bad configs (config/config.h): every kind of error the loader reports, each
// at the exact line:col of the offending node, several per load, and YAML
// syntax errors turned into diagnostics rather than exceptions.
#include <gtest/gtest.h>

#include <string>

#include "common/capacities.h"
#include "config/config.h"
#include "config/driver_kinds.h"
#include "tests/config/config_test_util.h"

namespace rtplc::config {
namespace {

using testing::has_diag;
using testing::parse;

TEST(ConfigErrors, unknown_key_suggests_the_nearest_one) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    perod: 10ms\n");
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(has_diag(r, 3, 5, "unknown key 'perod' in a task; did you mean 'period'?"));
  EXPECT_EQ(r.diags.items()[0].length, 5u);
  EXPECT_EQ(r.diags.error_count(), 1u);
}

TEST(ConfigErrors, setpoint_limits_are_parsed_and_bad_ones_pointed_at) {
  LoadResult ok = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    setpoints: {SP: {min: -1.5, max: 100}, Low: {min: 0}, High: {max: 9}}\n");
  ASSERT_TRUE(ok.ok()) << ok.render();
  const std::vector<SetpointLimits>& l = ok.config->tasks[0].setpoint_limits;
  ASSERT_EQ(l.size(), 3u);
  EXPECT_EQ(l[0].label, "SP");
  EXPECT_EQ(*l[0].min, -1.5);
  EXPECT_EQ(*l[0].max, 100.0);
  EXPECT_FALSE(l[1].max.has_value());
  EXPECT_FALSE(l[2].min.has_value());
  EXPECT_EQ(l[0].pos.line, 3u);
  EXPECT_EQ(l[0].pos.col, 17u);

  LoadResult bad = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    setpoints:\n"
      "      SP: {min: 10, max: 5}\n"
      "      A: {mn: 0}\n"
      "      B: {max: .inf}\n"
      "      C: 7\n"
      "      SP: {min: 0}\n");
  EXPECT_FALSE(bad.ok());
  EXPECT_TRUE(has_diag(bad, 4, 26, "set-point 'SP': max 5 is below min 10"));
  EXPECT_TRUE(has_diag(bad, 5, 11, "set-point 'A' takes 'min' and 'max'"));
  EXPECT_TRUE(has_diag(bad, 6, 16, "'max' of set-point 'B' expects a finite number"));
  EXPECT_TRUE(has_diag(bad, 7, 10, "set-point 'C' expects {min: number, max: number}"));
  EXPECT_TRUE(has_diag(bad, 8, 7, "set-point 'SP' is given twice"));
}

TEST(ConfigErrors, unknown_key_far_from_any_lists_the_known_ones) {
  LoadResult r = parse("runtime:\n  colour: blue\ntasks: [{program: a.fbd}]\n");
  EXPECT_TRUE(has_diag(r, 2, 3,
                       "unknown key 'colour' in the runtime section; expected one of: name, "
                       "socket, retain_file, programs, monitor_group, operators, priority_band, cpu_dma_latency, lock_memory"));
}

TEST(ConfigErrors, unknown_top_level_and_plant_keys) {
  LoadResult r = parse(
      "task:\n"
      "  - program: a.fbd\n"
      "drivers:\n"
      "  - kind: sim\n"
      "    plants: [{model: second-order, inptu: p0.d0.c0, output: p0.d0.c0}]\n");
  EXPECT_TRUE(has_diag(r, 1, 1, "unknown key 'task' in the config; did you mean 'tasks'?"));
  EXPECT_TRUE(has_diag(r, 1, 1, "the config needs 'tasks'"));
  EXPECT_TRUE(has_diag(r, 5, 36, "unknown key 'inptu' in a plant; did you mean 'input'?"));
  EXPECT_TRUE(has_diag(r, 5, 14, "a plant needs 'input'"));
}

TEST(ConfigErrors, duplicate_key_points_at_the_second_and_notes_the_first) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    period: 10ms\n"
      "    period: 20ms\n");
  EXPECT_TRUE(has_diag(r, 4, 5, "duplicate key 'period' in a task"));
  EXPECT_TRUE(has_diag(r, 3, 5, "first given here", Severity::kNote));
}

TEST(ConfigErrors, a_string_where_a_number_is_needed) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    priority: high\n"
      "    cpu: \"1\"\n"
      "    watchdog: 2.5\n");
  EXPECT_TRUE(has_diag(r, 3, 15, "'priority' expects a whole number, got 'high'"));
  EXPECT_TRUE(has_diag(r, 4, 10,
                       "'cpu' expects a whole number, got the string '1' (leave out the quotes)"));
  EXPECT_TRUE(
      has_diag(r, 5, 15, "'watchdog' expects a whole number, got '2.5' (no fraction allowed)"));
  EXPECT_EQ(r.diags.error_count(), 3u) << r.render();
}

TEST(ConfigErrors, values_out_of_range) {
  LoadResult r = parse(
      "runtime:\n"
      "  priority_band: [0, 50]\n"
      "tasks:\n"
      "  - program: a.fbd\n"
      "    period: 5us\n"
      "    priority: 99\n"
      "    cpu: -1\n"
      "    watchdog: 1000001\n"
      "  - program: b.fbd\n"
      "    period: 2h\n"
      "    overrun: halt\n"
      "  - program: c.fbd\n"
      "    period: 3601\n");
  EXPECT_TRUE(has_diag(r, 2, 19, "'priority_band' must be from 1 to 98, got 0"));
  EXPECT_TRUE(has_diag(r, 5, 13, "'period' must be between 10us and 3600s, got 5us"));
  EXPECT_TRUE(has_diag(r, 6, 15, "'priority' must be from 1 to 98, got 99"));
  EXPECT_TRUE(has_diag(r, 7, 10, "'cpu' must be from 0 to 1023, got -1"));
  EXPECT_TRUE(has_diag(r, 8, 15, "'watchdog' must be from 0 to 1000000, got 1000001"));
  EXPECT_TRUE(has_diag(
      r, 10, 13, "'period' expects a duration such as 10ms, 250us, 0.5s or 2 (seconds), got '2h'"));
  EXPECT_TRUE(has_diag(r, 11, 14, "'overrun' expects one of skip, stop, got 'halt'"));
  EXPECT_TRUE(has_diag(r, 13, 13, "'period' must be between 10us and 3600s, got 3601s"));
}

TEST(ConfigErrors, priority_band_must_be_an_ordered_pair) {
  LoadResult a = parse("runtime: {priority_band: [40, 20]}\ntasks: [{program: a.fbd}]\n");
  EXPECT_TRUE(has_diag(a, 1, 26, "'priority_band' must have lo <= hi, got [40, 20]"));
  LoadResult b = parse("runtime: {priority_band: 40}\ntasks: [{program: a.fbd}]\n");
  EXPECT_TRUE(
      has_diag(b, 1, 26, "'priority_band' expects a pair [lo, hi] of whole numbers, got '40'"));
  LoadResult c = parse("runtime: {priority_band: [1, 2, 3]}\ntasks: [{program: a.fbd}]\n");
  EXPECT_TRUE(has_diag(c, 1, 26, "got a list of 3"));
}

TEST(ConfigErrors, task_priority_outside_the_band) {
  LoadResult r = parse(
      "runtime:\n"
      "  priority_band: [20, 30]\n"
      "tasks:\n"
      "  - program: a.fbd\n"
      "    priority: 40\n");
  EXPECT_TRUE(has_diag(r, 5, 15, "priority 40 is outside the task band [20, 30]"));
  EXPECT_TRUE(has_diag(r, 2, 18, "the band is set here", Severity::kNote));
  // With the default band there is no band line to point at.
  LoadResult d = parse("tasks:\n  - {program: a.fbd, priority: 60}\n");
  EXPECT_TRUE(has_diag(d, 2, 32, "priority 60 is outside the task band [10, 49]"));
  EXPECT_EQ(d.diags.items().size(), 1u);
}

TEST(ConfigErrors, duplicate_task_names) {
  LoadResult r = parse(
      "tasks:\n"
      "  - {name: loop, program: a.fbd}\n"
      "  - {name: loop, program: b.fbd}\n"
      "  - program: x/same.fbd\n"
      "  - program: y/same.fbd\n");
  EXPECT_TRUE(has_diag(r, 3, 12, "task name 'loop' is already used by the task at line 2"));
  EXPECT_TRUE(has_diag(r, 2, 12, "first used here", Severity::kNote));
  EXPECT_TRUE(has_diag(
      r, 5, 14,
      "task name 'same' is already used by the task at line 4; give this task its own 'name'"));
}

TEST(ConfigErrors, duplicate_driver_names) {
  LoadResult r = parse(
      "tasks: [{program: a.fbd}]\n"
      "drivers:\n"
      "  - kind: sim\n"
      "  - kind: sim\n");
  EXPECT_TRUE(has_diag(r, 4, 11,
                       "driver name 'sim' is already used by the driver at line 3; give this "
                       "driver its own 'name'"));
}

TEST(ConfigErrors, more_tasks_than_the_runtime_holds) {
  std::string y = "tasks:\n";
  for (size_t i = 0; i <= kMaxTasks; ++i) y += "  - program: t" + std::to_string(i) + ".fbd\n";
  LoadResult r = parse(y);
  EXPECT_TRUE(has_diag(r, static_cast<uint32_t>(kMaxTasks) + 2, 5,
                       "'tasks' holds 17 entries; at most 16 are allowed"));
}

TEST(ConfigErrors, empty_or_missing_task_list) {
  EXPECT_TRUE(has_diag(parse("tasks: []\n"), 1, 8, "'tasks' needs at least 1 entry"));
  EXPECT_TRUE(has_diag(parse("tasks:\n"), 1, 1, "'tasks' needs at least 1 entry"));
  EXPECT_TRUE(has_diag(parse("drivers: [{kind: sim}]\n"), 1, 1, "the config needs 'tasks'"));
  EXPECT_TRUE(has_diag(parse("tasks: a.fbd\n"), 1, 8, "'tasks' expects a list of task entries"));
}

TEST(ConfigErrors, task_without_program_or_as_a_bare_word) {
  LoadResult r = parse(
      "tasks:\n"
      "  - name: a\n"
      "    period: 10ms\n"
      "  - b.fbd\n");
  EXPECT_TRUE(has_diag(r, 2, 5, "a task needs 'program' (a file path)"));
  EXPECT_TRUE(has_diag(r, 4, 5, "a task must be a map such as '- program: b.fbd', got 'b.fbd'"));
}

TEST(ConfigErrors, bad_names) {
  LoadResult r = parse(
      "runtime: {name: \"my plc\"}\n"
      "tasks:\n"
      "  - {name: a.b, program: a.fbd}\n"
      "  - program: my.loop.fbd\n");
  EXPECT_TRUE(
      has_diag(r, 1, 17, "'name' must be 1 to 31 letters, digits, '_' or '-', got 'my plc'"));
  EXPECT_TRUE(has_diag(r, 3, 12, "'name' must be 1 to 31"));
  EXPECT_TRUE(has_diag(
      r, 4, 14,
      "this task needs a 'name': the program's file name 'my.loop' is not a valid task name"));
}

TEST(ConfigErrors, empty_value_points_at_its_key) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    period:\n"
      "    cpu: 1\n");
  EXPECT_TRUE(has_diag(r, 3, 5, "'period' has no value; expected a duration"));
  EXPECT_EQ(r.diags.items()[0].length, 6u);
}

TEST(ConfigErrors, booleans_are_true_or_false) {
  LoadResult r =
      parse("runtime:\n  lock_memory: yes\n  cpu_dma_latency: [true]\ntasks: [{program: a.fbd}]\n");
  EXPECT_TRUE(has_diag(r, 2, 16, "'lock_memory' expects true or false, got 'yes'"));
  EXPECT_TRUE(has_diag(r, 3, 20, "'cpu_dma_latency' expects true or false, got a list"));
}

TEST(ConfigErrors, stop_with_watchdog_zero_would_never_stop) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    overrun: stop\n"
      "    watchdog: 0\n");
  EXPECT_TRUE(has_diag(r, 4, 15, "'overrun: stop' with 'watchdog: 0' would never stop the task"));
  EXPECT_TRUE(has_diag(r, 3, 14, "the policy is set here", Severity::kNote));
}

TEST(ConfigErrors, safe_outputs_labels_and_values) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    watchdog: 2\n"
      "    safe_outputs:\n"
      "      MV 1: 0\n"
      "      MV2: off\n"
      "      MV3: 1\n"
      "      MV3: 2\n"
      "      MV4: \"5\"\n"
      "      MV5:\n"
      "  - program: b.fbd\n"
      "    safe_outputs: [MV]\n");
  EXPECT_TRUE(has_diag(r, 5, 7, "a safe output is named by its channel label"));
  EXPECT_TRUE(has_diag(r, 6, 12, "safe output 'MV2' expects a finite number, got 'off'"));
  EXPECT_TRUE(has_diag(r, 8, 7, "safe output 'MV3' is given twice"));
  EXPECT_TRUE(has_diag(r, 9, 12, "safe output 'MV4' expects a finite number, got the string '5'"));
  EXPECT_TRUE(has_diag(r, 10, 7, "safe output 'MV5' has no value"));
  EXPECT_TRUE(has_diag(r, 12, 19, "'safe_outputs' expects a map of LABEL: number, got a list"));
}

TEST(ConfigErrors, safe_outputs_without_a_watchdog_are_a_warning) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    safe_outputs: {MV: 0}\n");
  EXPECT_TRUE(r.ok()) << r.render();
  EXPECT_TRUE(has_diag(r, 3, 5, "these safe outputs apply only if a loop of the program runs past its loop_budget", Severity::kWarning));
}

TEST(ConfigErrors, unknown_driver_kind_lists_the_known_ones_and_nothing_else) {
  LoadResult r = parse(
      "tasks: [{program: a.fbd}]\n"
      "drivers:\n"
      "  - kind: profinet\n"
      "    host: 10.0.0.2\n"
      "  - name: x\n");
  EXPECT_TRUE(
      has_diag(r, 3, 11, "unknown driver kind 'profinet'; known kinds: " + known_driver_kinds()));
  EXPECT_TRUE(
      has_diag(r, 5, 5, "a driver needs 'kind' (a driver kind (" + known_driver_kinds() + "))"));
  // Keys of the unknown kind are not blamed: the kind is the mistake.
  EXPECT_EQ(r.diags.error_count(), 2u) << r.render();
}

TEST(ConfigErrors, sim_plants) {
  LoadResult r = parse(
      "tasks: [{program: a.fbd}]\n"
      "drivers:\n"
      "  - kind: sim\n"
      "    plants:\n"
      "      - {model: third-order, input: p0.d0.c0, output: p0.d0.c0}\n"
      "      - {model: 'fopdt:T=-1', input: p0.d0.c0, output: p0.d1.c0}\n"
      "      - {input: p0.d0.c0, output: x0.d0.c0, model: 'secnd-order:wn=2'}\n"
      "      - {input: p0.d0.c70000, output: p0.d2.c0, model: second-order:wn=2}\n"
      "  - kind: sim\n"
      "    name: empty\n"
      "    plants: []\n"
      "  - kind: sim\n"
      "    name: scalar\n"
      "    plants: second-order\n");
  EXPECT_TRUE(has_diag(r, 5, 17,
                       "bad plant model: unknown plant 'third-order'; choose one of "
                       "second-order, tf, fopdt, tank"));
  EXPECT_TRUE(has_diag(r, 6, 17, "bad plant model: fopdt needs T > 0"));
  EXPECT_TRUE(has_diag(r, 7, 52,
                       "choose one of second-order, tf, fopdt, tank, measuring-tank; did you mean "
                       "'second-order'?"));
  EXPECT_TRUE(has_diag(
      r, 7, 35,
      "'output' expects a channel address pN.dN.cN (p and d 0..255, c 0..65535), got 'x0.d0.c0'"));
  EXPECT_TRUE(has_diag(r, 8, 17, "'input' expects a channel address"));
  EXPECT_TRUE(has_diag(r, 11, 13, "'plants' needs at least 1 entry"));
  EXPECT_TRUE(has_diag(r, 14, 13, "'plants' expects a list of plant entries"));
}

TEST(ConfigErrors, one_dai_channel_has_one_plant) {
  LoadResult r = parse(
      "tasks: [{program: a.fbd}]\n"
      "drivers:\n"
      "  - kind: sim\n"
      "    plants: [{input: p0.d0.c0, output: p0.d0.c0}]\n"
      "  - kind: sim\n"
      "    name: two\n"
      "    plants: [{input: p0.d0.c0, output: p0.d00.c0}]\n");
  EXPECT_TRUE(has_diag(r, 7, 40, "input channel in/DIO/p0.d0.c0 is already provided at line 4; each input channel has one source"));
  EXPECT_TRUE(has_diag(r, 4, 40, "first provided here", Severity::kNote));
  EXPECT_EQ(r.diags.error_count(), 1u) << r.render();  // sharing an input is fine
}

// The maps' shared checks (config/map_entries.h) say the same in every kind:
// a name used twice, a channel mapped twice in one direction, a bad channel.
TEST(ConfigErrors, driver_maps_refuse_a_name_used_twice_and_a_channel_mapped_twice) {
  LoadResult r = parse(
      "tasks: [{program: a.fbd}]\n"
      "drivers:\n"
      "  - kind: s7\n"
      "    plcs:\n"
      "      - {name: a, address: 10.0.0.1}\n"
      "      - {name: a, address: 10.0.0.2}\n"
      "    read:\n"
      "      - {channel: p1.d0.c0, plc: a, item: DB1.DBW0}\n"
      "      - {channel: p1.d0.c0, plc: a, item: DB1.DBW2}\n"
      "      - {channel: p1.d0.x, plc: a, item: DB1.DBW4}\n"
      "  - kind: modbus\n"
      "    slaves:\n"
      "      - {name: x, address: 10.0.0.3}\n"
      "      - {name: x, address: 10.0.0.4}\n"
      "    read:\n"
      "      - {device: R, channel: p1.d0.c0, slave: x, address: 1}\n"
      "      - {device: R, channel: p1.d0.c0, slave: x, address: 2}\n"
      "      - {device: X, channel: p1.d0.c0, slave: x, address: 2}\n");
  EXPECT_TRUE(has_diag(r, 6, 16, "PLC name 'a' is used twice (first at line 5)"));
  EXPECT_TRUE(has_diag(r, 9, 19, "channel p1.d0.c0 is mapped twice (first at line 8)"));
  EXPECT_TRUE(has_diag(
      r, 10, 19, "'channel' expects a channel address pN.dN.cN (p and d 0..255, c 0..65535), got 'p1.d0.x'"));
  EXPECT_TRUE(has_diag(r, 14, 16, "slave name 'x' is used twice (first at line 13)"));
  EXPECT_TRUE(has_diag(r, 17, 30, "channel R p1.d0.c0 is mapped twice (first at line 16)"));
  for (const Diagnostic& d : r.diags.items()) {
    EXPECT_EQ(d.message.find("channel X p1.d0.c0 is mapped twice"), std::string::npos) << d.message;
  }
}

TEST(ConfigErrors, driver_priority_inside_the_task_band_is_a_warning) {
  LoadResult r = parse("tasks: [{program: a.fbd}]\ndrivers: [{kind: sim, priority: 30}]\n");
  EXPECT_TRUE(r.ok()) << r.render();
  EXPECT_TRUE(has_diag(r, 2, 33, "driver 'sim' at priority 30 is not above the task band [10, 49]",
                       Severity::kWarning));
}

TEST(ConfigErrors, yaml_syntax_errors_are_diagnostics) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a\n"
      "   period: 3\n");
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(has_diag(r, 3, 4, "YAML syntax error: end of sequence not found"));
  LoadResult f = parse("tasks: [{program: a.fbd}\n");
  EXPECT_TRUE(has_diag(f, 2, 1, "YAML syntax error: end of sequence flow not found"));
  LoadResult a = parse("tasks: [*nothing]\n");
  EXPECT_TRUE(has_diag(a, 1, 9, "YAML syntax error: the referenced anchor is not defined"));
}

TEST(ConfigErrors, text_that_stalls_the_yaml_parser_is_a_syntax_error) {
  // yaml-cpp 0.7 reports endless empty documents at ",'" instead of an error.
  LoadResult r = parse(",'\n");
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(has_diag(r, 1, 1, "YAML syntax error: the text here cannot be parsed"));
  LoadResult after = parse("# a comment\n    ,L=0', x  - {m: 'f}\n");
  EXPECT_FALSE(after.ok());
  EXPECT_TRUE(has_diag(after, 2, 5, "YAML syntax error")) << after.render();
}

TEST(ConfigErrors, empty_documents_and_odd_shapes) {
  EXPECT_TRUE(has_diag(parse(""), 1, 1, "the config is empty"));
  EXPECT_TRUE(has_diag(parse("# nothing\n"), 1, 1, "the config is empty"));
  EXPECT_TRUE(has_diag(parse("- program: a.fbd\n"), 1, 1,
                       "the config must be a map with a 'tasks:' list, got a list"));
  EXPECT_TRUE(has_diag(parse("hello\n"), 1, 1, "got 'hello'"));
  LoadResult two = parse("tasks: [{program: a.fbd}]\n---\ntasks: [{program: b.fbd}]\n");
  EXPECT_TRUE(has_diag(two, 2, 1, "a config file holds one YAML document"));
  LoadResult key = parse("tasks: [{program: a.fbd}]\n[a]: 1\n");
  EXPECT_TRUE(has_diag(key, 2, 1, "a key in the config must be a plain word, got a list"));
}

TEST(ConfigErrors, collects_every_error_of_a_file_in_one_load) {
  LoadResult r = parse(
      "runtime:\n"
      "  name: a b\n"
      "  priority_band: [30, 20]\n"
      "tasks:\n"
      "  - program: a.fbd\n"
      "    perod: 1ms\n"
      "    priority: x\n"
      "  - nme: b\n"
      "drivers:\n"
      "  - kind: sim\n"
      "    period: 0\n");
  EXPECT_FALSE(r.config.has_value());
  EXPECT_EQ(r.diags.error_count(), 7u) << r.render();
}

TEST(ConfigErrors, render_reads_like_a_compiler) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: a.fbd\n"
      "    perod: 10ms\n");
  EXPECT_EQ(r.render(),
            "t.yaml:3:5: error: unknown key 'perod' in a task; did you mean 'period'?\n"
            " 3 |     perod: 10ms\n"
            "   |     ^~~~~\n");
}

TEST(ConfigErrors, odd_bytes_never_throw) {
  const std::string inputs[] = {
      std::string("tasks:\0\n", 8),
      "\xef\xbb\xbftasks: [{program: a.fbd}]\n",
      "tasks: [{program: \"\\u0000\"}]\n",
      "tasks: !!map {program: a}\n",
      "tasks: [{program: a.fbd, safe_outputs: {? [x] : 1}}]\n",
      "tasks: [{program: a.fbd, period: !!float 0.1}]\n",
      std::string(5000, '[') + std::string(5000, ']'),
      "a: &a [*a]\n",
      "tasks:\n\t- program: a.fbd\n",
  };
  for (const std::string& in : inputs) {
    LoadResult r = parse(in);
    EXPECT_TRUE(r.ok() || r.diags.has_errors()) << in;
    (void)r.render();
  }
}

}  // namespace
}  // namespace rtplc::config
