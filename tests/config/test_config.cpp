// Loading good configs (config/config.h): the defaults of the smallest config,
// every key of the schema read into its field with its position, path
// resolution, and the shipped examples.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "common/capacities.h"
#include "config/config.h"
#include "config/driver_kinds.h"
#include "io/drivers/sim/config.h"
#include "tests/config/config_test_util.h"

namespace rtplc::config {
namespace {

using testing::has_diag;
using testing::parse;

const std::string kSrc = RTPLC_SOURCE_DIR;

TEST(Config, smallest_config_takes_every_default) {
  LoadResult r = parse(
      "tasks:\n"
      "  - program: seed_pid.fbd\n"
      "drivers:\n"
      "  - kind: sim\n");
  ASSERT_TRUE(r.ok()) << r.render();
  const RuntimeConfig& c = *r.config;
  EXPECT_EQ(c.name, "rtplc");
  EXPECT_EQ(c.socket_path, "");
  EXPECT_EQ(c.retain_path, "");
  EXPECT_EQ(c.band_lo, 10);
  EXPECT_EQ(c.band_hi, 49);
  EXPECT_EQ(c.band_pos.line, 0u);
  EXPECT_TRUE(c.cpu_dma_latency);
  EXPECT_TRUE(c.lock_memory);
  EXPECT_EQ(c.base_dir, "/plant");
  ASSERT_EQ(c.tasks.size(), 1u);
  const TaskConfig& t = c.tasks[0];
  EXPECT_EQ(t.name, "seed_pid");
  EXPECT_EQ(t.program, "/plant/seed_pid.fbd");
  EXPECT_EQ(t.pos.line, 2u);
  EXPECT_EQ(t.pos.col, 5u);
  EXPECT_EQ(t.program_pos.line, 2u);
  EXPECT_EQ(t.program_pos.col, 14u);
  EXPECT_EQ(t.name_pos.line, t.program_pos.line);  // the name comes from the program
  EXPECT_FALSE(t.period_s);
  EXPECT_FALSE(t.priority);
  EXPECT_FALSE(t.cpu);
  EXPECT_EQ(t.overrun, OverrunPolicy::kSkip);
  EXPECT_EQ(t.watchdog, 0u);
  EXPECT_TRUE(t.safe_outputs.empty());
  ASSERT_EQ(c.drivers.size(), 1u);
  const DriverConfig& d = c.drivers[0];
  EXPECT_EQ(d.kind, "sim");
  EXPECT_EQ(d.name, "sim");
  EXPECT_EQ(d.period_s, 0.01);
  EXPECT_FALSE(d.priority);
  EXPECT_FALSE(d.cpu);
  EXPECT_TRUE(d.settings.has_value());  // the sim kind's settings, with its default plant
  ASSERT_EQ(sim::settings_of(d).plants.size(), 1u);  // the documented default plant
  EXPECT_EQ(sim::settings_of(d).plants[0].model, "second-order");
  EXPECT_EQ(sim::settings_of(d).plants[0].input, "p0.d0.c0");
  EXPECT_EQ(sim::settings_of(d).plants[0].output, "p0.d0.c0");
  EXPECT_EQ(sim::settings_of(d).plants[0].pos.line, 4u);
  EXPECT_TRUE(r.diags.items().empty());
}

TEST(Config, tasks_alone_are_a_config) {
  LoadResult r = parse("tasks: [{program: a.fbd}]\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_TRUE(r.config->drivers.empty());
}

TEST(Config, every_key_lands_in_its_field_with_its_position) {
  LoadResult r = parse(
      "runtime:\n"
      "  name: cell-7\n"
      "  socket: run/cell.sock\n"
      "  retain_file: /var/lib/rtplc/cell.retain\n"
      "  priority_band: [20, 60]\n"
      "  cpu_dma_latency: false\n"
      "  lock_memory: false\n"
      "tasks:\n"
      "  - name: fast\n"  // 9
      "    program: ../progs/flow.fbd\n"
      "    period: 250us\n"
      "    priority: 55\n"
      "    cpu: 3\n"
      "    overrun: stop\n"
      "    watchdog: 7\n"
      "    safe_outputs:\n"
      "      FV_101: 12.5\n"  // 17
      "      FV.102: -1\n"
      "drivers:\n"
      "  - kind: sim\n"  // 20
      "    name: rig\n"
      "    period: 2ms\n"
      "    priority: 70\n"
      "    cpu: 0\n"
      "    plants:\n"
      "      - model: fopdt:K=2,T=4,L=0.5\n"  // 26
      "        input: p0.d3.c01\n"
      "        output: p1.d2.c5\n",
      "/etc/rtplc");
  ASSERT_TRUE(r.ok()) << r.render();
  const RuntimeConfig& c = *r.config;
  EXPECT_EQ(c.name, "cell-7");
  EXPECT_EQ(c.name_pos.line, 2u);
  EXPECT_EQ(c.socket_path, "/etc/rtplc/run/cell.sock");
  EXPECT_EQ(c.socket_pos.line, 3u);
  EXPECT_EQ(c.retain_path, "/var/lib/rtplc/cell.retain");
  EXPECT_EQ(c.retain_pos.line, 4u);
  EXPECT_EQ(c.band_lo, 20);
  EXPECT_EQ(c.band_hi, 60);
  EXPECT_EQ(c.band_pos.line, 5u);
  EXPECT_EQ(c.band_pos.col, 18u);
  EXPECT_FALSE(c.cpu_dma_latency);
  EXPECT_FALSE(c.lock_memory);

  const TaskConfig& t = c.tasks.at(0);
  EXPECT_EQ(t.name, "fast");
  EXPECT_EQ(t.name_pos.line, 9u);
  EXPECT_EQ(t.name_pos.col, 11u);
  EXPECT_EQ(t.program, "/etc/progs/flow.fbd");
  EXPECT_EQ(t.program_pos.line, 10u);
  EXPECT_EQ(t.period_s, 250e-6);
  EXPECT_EQ(t.period_pos.line, 11u);
  EXPECT_EQ(t.priority, 55);
  EXPECT_EQ(t.priority_pos.line, 12u);
  EXPECT_EQ(t.priority_pos.col, 15u);
  EXPECT_EQ(t.cpu, 3u);
  EXPECT_EQ(t.cpu_pos.line, 13u);
  EXPECT_EQ(t.overrun, OverrunPolicy::kStop);
  EXPECT_EQ(t.watchdog, 7u);
  EXPECT_EQ(t.watchdog_pos.line, 15u);
  ASSERT_EQ(t.safe_outputs.size(), 2u);
  EXPECT_EQ(t.safe_outputs[0].label, "FV_101");
  EXPECT_EQ(t.safe_outputs[0].value, 12.5);
  EXPECT_EQ(t.safe_outputs[0].pos.line, 17u);
  EXPECT_EQ(t.safe_outputs[0].pos.col, 7u);
  EXPECT_EQ(t.safe_outputs[1].label, "FV.102");
  EXPECT_EQ(t.safe_outputs[1].value, -1.0);

  const DriverConfig& d = c.drivers.at(0);
  EXPECT_EQ(d.kind, "sim");
  EXPECT_EQ(d.kind_pos.line, 20u);
  EXPECT_EQ(d.name, "rig");
  EXPECT_EQ(d.period_s, 0.002);
  EXPECT_EQ(d.priority, 70);
  EXPECT_EQ(d.priority_pos.line, 23u);
  EXPECT_EQ(d.cpu, 0u);
  ASSERT_EQ(sim::settings_of(d).plants.size(), 1u);
  const sim::PlantConfig& p = sim::settings_of(d).plants[0];
  EXPECT_EQ(p.model, "fopdt:K=2,T=4,L=0.5");
  EXPECT_EQ(p.model_pos.line, 26u);
  EXPECT_EQ(p.input, "p0.d3.c1");  // canonical spelling
  EXPECT_EQ(p.input_addr, (ChannelAddress{0, 3, 1}));
  EXPECT_EQ(p.input_pos.line, 27u);
  EXPECT_EQ(p.output, "p1.d2.c5");
  EXPECT_EQ(p.output_addr, (ChannelAddress{1, 2, 5}));
  EXPECT_EQ(p.output_pos.line, 28u);
  EXPECT_TRUE(r.diags.items().empty()) << r.render();
}

TEST(Config, watchdog_defaults_to_three_with_stop_and_zero_with_skip) {
  LoadResult r = parse(
      "tasks:\n"
      "  - {program: a.fbd, overrun: stop}\n"
      "  - {program: b.fbd, overrun: skip}\n"
      "  - {program: c.fbd, watchdog: 5}\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_EQ(r.config->tasks[0].watchdog, 3u);
  EXPECT_EQ(r.config->tasks[1].watchdog, 0u);
  EXPECT_EQ(r.config->tasks[2].watchdog, 5u);
  EXPECT_EQ(r.config->tasks[2].overrun, OverrunPolicy::kSkip);
}

TEST(Config, retain_selects_all_none_or_named_blocks) {
  LoadResult r = parse(
      "runtime: {retain_every: 250ms}\n"
      "tasks:\n"
      "  - {program: a.fbd}\n"
      "  - {program: b.fbd, retain: none}\n"
      "  - {program: c.fbd, retain: [F10, step]}\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_EQ(r.config->retain_every_s, 0.25);
  EXPECT_TRUE(r.config->tasks[0].retain_all);
  EXPECT_FALSE(r.config->tasks[1].retain_all);
  EXPECT_TRUE(r.config->tasks[1].retain_blocks.empty());
  EXPECT_FALSE(r.config->tasks[2].retain_all);
  EXPECT_EQ(r.config->tasks[2].retain_blocks, (std::vector<std::string>{"F10", "step"}));
  EXPECT_EQ(r.config->tasks[2].retain_pos.line, 5u);
}

TEST(Config, a_bad_retain_is_an_error_at_its_value) {
  LoadResult r = parse(
      "tasks:\n"
      "  - {program: a.fbd, retain: some}\n"
      "  - {program: b.fbd, retain: [F1, F1]}\n"
      "  - {program: c.fbd, retain: {F1: 2}}\n");
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(has_diag(r, 2, 30, "'retain' expects `all`, `none` or a list of block names"));
  EXPECT_TRUE(has_diag(r, 3, 35, "block 'F1' is listed twice"));
  EXPECT_TRUE(has_diag(r, 4, 30, "'retain' expects"));
}

TEST(Config, plain_number_periods_are_seconds) {
  LoadResult r =
      parse("tasks:\n  - {program: a.fbd, period: 0.5}\n  - {program: b.fbd, period: 2}\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_EQ(r.config->tasks[0].period_s, 0.5);
  EXPECT_EQ(r.config->tasks[1].period_s, 2.0);
}

TEST(Config, empty_sections_mean_their_defaults) {
  LoadResult r = parse("runtime:\ntasks:\n  - program: a.fbd\n    safe_outputs:\ndrivers:\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_EQ(r.config->name, "rtplc");
  EXPECT_TRUE(r.config->drivers.empty());
}

TEST(Config, absolute_program_paths_stay_and_empty_base_keeps_relative_ones) {
  LoadResult r = parse("tasks: [{program: /opt/x/a.fbd}, {program: sub/./b.fbd}]\n", "");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_EQ(r.config->tasks[0].program, "/opt/x/a.fbd");
  EXPECT_EQ(r.config->tasks[1].program, "sub/b.fbd");
}

TEST(Config, anchors_and_aliases_work) {
  LoadResult r = parse(
      "tasks:\n"
      "  - {name: a, program: a.fbd, safe_outputs: &safe {MV: 0}}\n"
      "  - {name: b, program: b.fbd, overrun: stop, safe_outputs: *safe}\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_EQ(r.config->tasks[1].safe_outputs.at(0).label, "MV");
}

TEST(Config, sixteen_tasks_fit_exactly) {
  std::string y = "tasks:\n";
  for (size_t i = 0; i < kMaxTasks; ++i) y += "  - program: t" + std::to_string(i) + ".fbd\n";
  LoadResult r = parse(y);
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_EQ(r.config->tasks.size(), kMaxTasks);
}

TEST(Config, find_task_and_driver_by_name) {
  LoadResult r = parse("tasks: [{program: a.fbd}]\ndrivers: [{kind: sim, name: rig}]\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_NE(r.config->find_task("a"), nullptr);
  EXPECT_EQ(r.config->find_task("b"), nullptr);
  EXPECT_NE(r.config->find_driver("rig"), nullptr);
}

TEST(Config, crlf_line_ends_read_the_same) {
  LoadResult r = parse("tasks:\r\n  - program: a.fbd\r\n    period: 10ms\r\n");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_EQ(r.config->tasks[0].period_s, 0.01);
  EXPECT_EQ(r.config->tasks[0].period_pos.line, 3u);
}

TEST(Config, program_files_are_checked_on_disk_when_asked) {
  const auto dir = std::filesystem::temp_directory_path() / "rtplc_cfg_test_files";
  std::filesystem::create_directories(dir / "sub");
  std::ofstream(dir / "here.fbd") << "%%\nEND\n";
  std::ofstream(dir / "cell.yaml") << "tasks:\n  - program: here.fbd\n  - program: gone.fbd\n"
                                      "  - program: sub\n";
  LoadResult r = load_config((dir / "cell.yaml").string());
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.file, (dir / "cell.yaml").string());
  EXPECT_TRUE(has_diag(r, 3, 14, "program file not found: " + (dir / "gone.fbd").string()));
  EXPECT_TRUE(has_diag(r, 4, 14, "not a regular file"));
  EXPECT_EQ(r.diags.error_count(), 2u) << r.render();
  std::filesystem::remove_all(dir);
}

TEST(Config, load_config_reports_a_missing_or_odd_file_without_position) {
  LoadResult r = load_config("/nonexistent/dir/x.yaml");
  EXPECT_FALSE(r.ok());
  ASSERT_EQ(r.diags.items().size(), 1u);
  EXPECT_EQ(r.diags.items()[0].pos.line, 0u);
  EXPECT_NE(r.render().find("/nonexistent/dir/x.yaml: error: config file not found"),
            std::string::npos)
      << r.render();
  LoadResult d = load_config("/tmp");
  EXPECT_FALSE(d.ok());
  EXPECT_NE(d.render().find("the config is a folder, not a file"), std::string::npos) << d.render();
}

// The shipped examples load with their programs in place, and say what they claim.
TEST(Examples, seed_pid_is_the_smallest_config) {
  LoadResult r = load_config(kSrc + "/examples/seed_pid.yaml");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_TRUE(r.diags.items().empty()) << r.render();
  const RuntimeConfig& c = *r.config;
  ASSERT_EQ(c.tasks.size(), 1u);
  EXPECT_EQ(c.tasks[0].name, "seed_pid");
  EXPECT_TRUE(std::filesystem::equivalent(c.tasks[0].program, kSrc + "/examples/seed_pid.fbd"));
  ASSERT_EQ(c.drivers.size(), 1u);
  ASSERT_EQ(sim::settings_of(c.drivers[0]).plants.size(), 1u);
  EXPECT_EQ(sim::settings_of(c.drivers[0]).plants[0].model, "second-order");  // 1/(s^2 + s + 1)
  EXPECT_EQ(sim::settings_of(c.drivers[0]).plants[0].input, "p0.d0.c0");
}

TEST(Examples, plant_uses_every_key_of_the_schema_and_the_sim_kind) {
  LoadResult r = load_config(kSrc + "/examples/plant.yaml");
  ASSERT_TRUE(r.ok()) << r.render();
  EXPECT_TRUE(r.diags.items().empty()) << r.render();
  const RuntimeConfig& c = *r.config;
  EXPECT_EQ(c.tasks.size(), 4u);
  EXPECT_EQ(c.tasks[3].program_instance, "task0");
  EXPECT_EQ(c.tasks[0].period_s, 0.01);
  EXPECT_EQ(c.tasks[1].period_s, 0.1);
  EXPECT_EQ(c.drivers.size(), 2u);
  // Every key of every section appears somewhere in the file.
  std::ifstream f(kSrc + "/examples/plant.yaml");
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  auto uses = [&](const SectionSpec& s) {
    for (const KeySpec& k : s.keys) {
      EXPECT_NE(text.find(std::string(k.key) + ":"), std::string::npos) << s.id << "." << k.key;
    }
  };
  uses(top_section());
  uses(runtime_section());
  uses(task_section());
  uses(driver_section());
  // Other kinds talk to hardware, so their examples live in files of their own.
  const DriverKind* sim = find_driver_kind("sim");
  ASSERT_NE(sim, nullptr);
  uses(*sim->keys);
  for (const SectionSpec* sub : sim->subsections) uses(*sub);
}

TEST(Examples, sixteen_runs_the_most_tasks_at_periods_from_1_to_100_ms) {
  LoadResult r = load_config(kSrc + "/examples/sixteen.yaml");
  ASSERT_TRUE(r.ok()) << r.render();
  const RuntimeConfig& c = *r.config;
  ASSERT_EQ(c.tasks.size(), kMaxTasks);
  double lo = 1, hi = 0;
  for (const TaskConfig& t : c.tasks) {
    ASSERT_TRUE(t.period_s);
    lo = std::min(lo, *t.period_s);
    hi = std::max(hi, *t.period_s);
    EXPECT_FALSE(t.priority);  // rate-monotonic
  }
  EXPECT_EQ(lo, 0.001);
  EXPECT_EQ(hi, 0.1);
  ASSERT_EQ(c.drivers.size(), 1u);
  EXPECT_EQ(sim::settings_of(c.drivers[0]).plants.size(), kMaxTasks);
}

}  // namespace
}  // namespace rtplc::config
