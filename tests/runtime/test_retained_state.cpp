// Retained block state (docs/runtime.md, "Retained block state"): the state
// file's format and its damage checks, the task -> control snapshot under a
// same-CPU preemption, and warm and cold restarts of the real runtime, also
// after kill -9.
#include <gtest/gtest.h>

#include <map>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <thread>

#include "lang/compiler.h"
#include "sched/control.h"
#include "sched/state_file.h"
#include "sched/state_snapshot.h"
#include "tests/support/run_tool.h"
#include "tests/support/runtime_fixture.h"
#include "tests/support/same_cpu_preemption.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;

void sleep_s(double s) {
  std::this_thread::sleep_for(std::chrono::duration<double>(s));
}

// An integrator of a set-point: with SP 0 it holds its value, so a restart can
// be checked for an exact one.
const char* kIntegrator =
    "%%\nF1 = asp(d0, c0, 1, \"SP\")\nF2 = intg(F1, 1)\nD4 = dsp(d0, c1, 1, \"RUN\")\nD3 = "
    "time(D4, 100)\n"
    "dao(F2, p0, d0, c0, \"OUT\")\nEND\n";

double block_value_of(const TaskImage& img, const TaskArena& a, const std::string& name) {
  for (uint32_t i = 0; i < img.blocks().size(); ++i) {
    if (name == img.str(img.blocks()[i].name)) return a.values[img.code()[i].out];
  }
  ADD_FAILURE() << "no block " << name;
  return 0;
}

TaskImage compile(const std::string& src) {
  lang::CompileResult r = lang::compile_source(src);
  EXPECT_TRUE(r.ok());
  return std::move(*r.image);
}

SavedState sample_state() {
  SavedState s;
  s.runtime = "plant";
  s.saved_unix_ms = 1764619801123;
  s.tasks.push_back(
      {"loop", 1234, {{"F2", "intg", {0.1 + 0.2, -3.5e-300}}, {"F3", "time", {1, 7}}}});
  s.tasks.push_back({"idle", 0, {}});
  return s;
}

TEST(StateFile, round_trips_every_double_bit_exact) {
  const SavedState s = sample_state();
  auto back = decode_state(encode_state(s), "x.state");
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(back->runtime, "plant");
  EXPECT_EQ(back->saved_unix_ms, 1764619801123);
  ASSERT_EQ(back->tasks.size(), 2u);
  EXPECT_EQ(back->tasks[0].cycle, 1234u);
  ASSERT_EQ(back->tasks[0].blocks.size(), 2u);
  EXPECT_EQ(back->tasks[0].blocks[0].values[0], 0.1 + 0.2);
  EXPECT_EQ(back->tasks[0].blocks[0].values[1], -3.5e-300);
  EXPECT_EQ(back->tasks[0].blocks[1].kind, "time");
  EXPECT_TRUE(back->tasks[1].blocks.empty());
}

TEST(StateFile, a_changed_byte_is_a_checksum_mismatch) {
  std::string text = encode_state(sample_state());
  const size_t at = text.find("1234");
  ASSERT_NE(at, std::string::npos);
  text[at] = '9';  // still well-formed: only the checksum can tell
  auto r = decode_state(text, "/var/x.state");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("/var/x.state: checksum mismatch"), std::string::npos) << r.error();
}

TEST(StateFile, a_truncated_file_is_reported_as_torn) {
  const std::string text = encode_state(sample_state());
  for (const size_t keep : {text.size() - 1, text.size() - 10, text.size() / 2, size_t{20}}) {
    auto r = decode_state(text.substr(0, keep), "x.state");
    ASSERT_FALSE(r.ok()) << "kept " << keep;
    EXPECT_NE(r.error().find("truncated"), std::string::npos) << r.error();
  }
}

TEST(StateFile, another_file_or_version_is_refused) {
  EXPECT_NE(decode_state("hello\n", "x").error().find("not an rtplc state file"),
            std::string::npos);
  std::string text = encode_state(sample_state());
  text.replace(text.find(" 1\n"), 3, " 9\n");
  // Re-seal it so the version check itself is what refuses it.
  const size_t last = text.rfind("crc32 ");
  std::string body = text.substr(0, last);
  char crc[32];
  std::snprintf(crc, sizeof crc, "crc32 %08x\n", crc32(body));
  auto r = decode_state(body + crc, "x");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("format version 9"), std::string::npos) << r.error();
}

TEST(StateFile, restores_only_blocks_of_the_same_name_kind_and_size) {
  TaskImage img = compile(kIntegrator);
  auto layout = retained_blocks(img, true, {});
  TaskArena arena(img);
  SavedTask saved{"t",
                  10,
                  {{"F2", "intg", {4.25}},    // matches
                   {"D3", "pid", {1, 2, 3}},  // another kind now
                   {"F99", "intg", {1}}}};    // no such block
  RestoreOutcome o = restore_task(saved, layout, arena);
  ASSERT_EQ(o.restored.size(), 1u);
  EXPECT_EQ(o.restored[0], "F2");
  ASSERT_EQ(o.refused.size(), 1u);
  EXPECT_NE(o.refused[0].find("D3 (saved as pid"), std::string::npos) << o.refused[0];
  EXPECT_EQ(block_value_of(img, arena, "F2"), 4.25);
  std::fill(arena.io_in.begin(), arena.io_in.end(), 1.0);  // SP = 1: dt/Ti more each cycle
  execute_cycle(img, arena);
  EXPECT_GT(block_value_of(img, arena, "F2"), 4.25);
}

TEST(StateFile, a_block_list_selects_blocks_and_what_they_expand_to) {
  TaskImage img = compile(kIntegrator);
  std::vector<std::string> unknown;
  auto some = retained_blocks(img, false, {"F2", "F7"}, &unknown);
  ASSERT_EQ(some.size(), 1u);
  EXPECT_EQ(some[0].name, "F2");
  EXPECT_EQ(some[0].kind, "intg");
  ASSERT_EQ(unknown.size(), 1u);
  EXPECT_EQ(unknown[0], "F7");
  EXPECT_TRUE(retained_blocks(img, false, {}).empty());
}

TEST(StateFile, an_output_is_kept_only_where_a_later_cycle_reads_it) {
  // F3 is read by F2 from the previous cycle (a delayed reference): its output
  // is state. F2 and F4 are recomputed from their inputs: nothing to keep. The
  // integrator's output is its state; the filter keeps its output too.
  TaskImage img = compile(
      "%%\nF1 = asp(d0, c0, 1, \"SP\")\nF2 = add(F3, F1)\nF3 = lim(F2, 0, 100)\nF4 = sub(F1, F3)\n"
      "F5 = intg(F4, 1)\nF6 = filt(F5, 2)\ndao(F6, p0, d0, c0, \"OUT\")\nEND\n");
  std::map<std::string, bool> kept;  // name -> its output is in the snapshot
  for (const RetainedBlock& rb : retained_blocks(img, true, {})) kept[rb.name] = rb.value != RetainedBlock::kNoValue;
  EXPECT_EQ(kept.count("F1"), 0u) << "a set-point load is not the program's state";
  EXPECT_EQ(kept.count("F2"), 0u);
  EXPECT_EQ(kept.count("F4"), 0u);
  ASSERT_EQ(kept.count("F3"), 1u);
  EXPECT_TRUE(kept["F3"]);
  ASSERT_EQ(kept.count("F5"), 1u);
  EXPECT_TRUE(kept["F5"]);
  ASSERT_EQ(kept.count("F6"), 1u);
  EXPECT_TRUE(kept["F6"]);
}

// ---- the snapshot protocol

TEST(StateSnapshot, a_reader_gets_the_last_whole_snapshot_while_the_next_is_half_written) {
  StateSnapshot s;
  s.prepare({{"A", "intg", RetainedBlock::kNoValue, 0, 4}});
  std::vector<double> out;
  uint64_t cycle = 0;
  int64_t at = 0;
  EXPECT_FALSE(s.read(out, cycle, at)) << "nothing published yet";
  uint32_t w = s.begin_take();
  for (uint32_t i = 0; i < 4; ++i) s.store(w, i, 1.0);
  s.end_take(w, 7, 70);
  w = s.begin_take();
  s.store(w, 0, 2.0);
  s.store(w, 1, 2.0);  // the writer stops here
  ASSERT_TRUE(s.read(out, cycle, at));
  EXPECT_EQ(out, std::vector<double>(4, 1.0));
  EXPECT_EQ(cycle, 7u);
  s.store(w, 2, 2.0);
  s.store(w, 3, 2.0);
  s.end_take(w, 8, 80);
  ASSERT_TRUE(s.read(out, cycle, at));
  EXPECT_EQ(out, std::vector<double>(4, 2.0));
  EXPECT_EQ(cycle, 8u);
  EXPECT_EQ(s.taken(), 2u);
}

// The watch's layout and copy: every block that writes a value but the loads,
// in textual order, each as [output, status], through the same buffers.
TEST(StateSnapshot, the_watch_holds_every_computed_output_with_its_status) {
  lang::CompileResult c = lang::compile_source(
      "%%\nF1 = asp(d0, c0, 3, \"SP\")\nF2 = mult(F1, F1)\nF3 = add(F2, F1)\ndao(F3, p0, d0, c0, \"OUT\")\nEND\n");
  ASSERT_TRUE(c.ok());
  const std::vector<RetainedBlock> blocks = watched_blocks(*c.image);
  ASSERT_EQ(blocks.size(), 2u);
  EXPECT_EQ(blocks[0].name, "F2");
  EXPECT_EQ(blocks[1].name, "F3");
  StateSnapshot s;
  s.prepare(blocks);
  EXPECT_EQ(s.size(), 4u);
  TaskArena arena(*c.image);
  StatusLane lane(*c.image);
  arena.values[blocks[0].value] = 9;
  arena.values[blocks[1].value] = 12;
  lane.values[blocks[1].value] = static_cast<uint8_t>(Lane::kBad);
  arena.cycles = 5;
  s.take_watch(arena, lane, 50);
  std::vector<double> out;
  uint64_t cycle = 0;
  int64_t at = 0;
  ASSERT_TRUE(s.read(out, cycle, at));
  EXPECT_EQ(out, (std::vector<double>{9, 0, 12, 2}));
  EXPECT_EQ(cycle, 5u);
  EXPECT_EQ(at, 50);
}

TEST(StateSnapshot, a_reader_preempting_the_writer_on_its_cpu_reads_at_once) {
  constexpr uint32_t kN = 64;
  StateSnapshot s;
  s.prepare({{"A", "dely", RetainedBlock::kNoValue, 0, kN}});
  uint32_t w = s.begin_take();
  for (uint32_t i = 0; i < kN; ++i) s.store(w, i, 1.0);
  s.end_take(w, 1, 1);
  auto res = rtplc::testing::run_preempting_reader(
      [&](const std::function<void()>& preempt) {
        const uint32_t b = s.begin_take();
        for (uint32_t i = 0; i < kN; ++i) {
          s.store(b, i, 2.0);
          if (i == kN / 2) preempt();  // the reader runs now, this snapshot half written
        }
        s.end_take(b, 2, 2);
      },
      [&] {
        std::vector<double> out;
        uint64_t cycle = 0;
        int64_t at = 0;
        // One try: the finished buffer must be readable at once.
        if (!s.read(out, cycle, at, 1)) return false;
        return cycle == 1 && out == std::vector<double>(kN, 1.0);
      });
  if (!res.ran) GTEST_SKIP() << res.why;
  EXPECT_TRUE(res.reader_preempted_writer)
      << "the reader did not run while the writer was mid-snapshot";
  EXPECT_TRUE(res.read_ok) << "the reader did not get the previous snapshot whole at once";
}

// ---- the runtime

std::string config_for(RuntimeFixture& fx, const std::string& name,
                       const std::string& task_extra = "", const std::string& program = "p.fbd") {
  return fx.write(name + ".yaml", "runtime:\n  name: " + name + "\n  socket: " + fx.dir() + "/" +
                                      name + ".sock\n  retain_file: " + fx.dir() + "/" + name +
                                      ".retain\n  retain_every: 20ms\n  programs: config\n"
                                      "tasks:\n  - {name: t, program: " +
                                      program + ", period: 5ms" + task_extra + "}\n");
}

std::unique_ptr<Runtime> load(const std::string& file, RuntimeOptions opt,
                              std::string* log = nullptr, bool start = true) {
  config::LoadResult cfg = config::load_config(file);
  EXPECT_TRUE(cfg.ok()) << cfg.render();
  if (!cfg.ok()) return nullptr;
  LoadReport report;
  auto rt = Runtime::load(*cfg.config, opt, report);
  if (log) *log = report.render();
  EXPECT_NE(rt, nullptr) << report.render();
  if (rt) {
    if (log) {
      for (const std::string& l : rt->describe()) *log += l + "\n";
    }
    if (start) {
      EXPECT_TRUE(rt->start().ok());
    }
  }
  return rt;
}

// Waits (bounded by counts, not asserted on time) for the task to have run.
void wait_cycles(Runtime& rt, uint64_t n) {
  const auto* stats = static_cast<const CycleStats*>(rt.image().task_stats(0));
  for (int i = 0; i < 400 && stats->cycles() < n; ++i) sleep_s(0.01);
}

TEST(RetainedState, a_stopped_runtime_restarts_warm_from_the_state_at_its_stop) {
  RuntimeFixture fx;
  fx.write("p.fbd", kIntegrator);
  const std::string cfg = config_for(fx, fx.unique_name());
  double at_stop = 0;
  {
    auto rt = load(cfg, {});
    ASSERT_NE(rt, nullptr);
    wait_cycles(*rt, 20);
    rt->stop();
    at_stop = rtplc::testing::block_value(rt->task(0).last_run(), "F2");
    ASSERT_GT(at_stop, 0.0);
    ASSERT_TRUE(rt->stop_state_error().empty()) << rt->stop_state_error();
  }
  std::string log;
  auto rt = load(cfg, {}, &log, /*start=*/false);
  ASSERT_NE(rt, nullptr);
  EXPECT_NE(log.find("task t: restored 2 blocks (F2, D3)"), std::string::npos) << log;
  // Not started yet: the arena is the restored one, exactly the state at the stop.
  EXPECT_EQ(rtplc::testing::block_value(rt->task(0).last_run(), "F2"), at_stop);
}

TEST(RetainedState, cold_starts_from_zero_and_says_so) {
  RuntimeFixture fx;
  fx.write("p.fbd", kIntegrator);
  const std::string cfg = config_for(fx, fx.unique_name());
  {
    auto rt = load(cfg, {});
    ASSERT_NE(rt, nullptr);
    wait_cycles(*rt, 20);
    rt->stop();
  }
  std::string log;
  RuntimeOptions opt;
  opt.cold = true;
  auto rt = load(cfg, opt, &log, /*start=*/false);
  ASSERT_NE(rt, nullptr);
  EXPECT_NE(log.find("cold start (--cold)"), std::string::npos) << log;
  EXPECT_EQ(rtplc::testing::block_value(rt->task(0).last_run(), "F2"), 0.0);
}

TEST(RetainedState, a_damaged_file_is_reported_and_every_block_starts_cold) {
  RuntimeFixture fx;
  fx.write("p.fbd", kIntegrator);
  const std::string name = fx.unique_name();
  const std::string cfg = config_for(fx, name);
  std::string state;
  {
    auto rt = load(cfg, {});
    ASSERT_NE(rt, nullptr);
    wait_cycles(*rt, 20);
    rt->stop();
    state = rt->state_path();
  }
  {
    std::fstream f(state, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(30);
    f.put('#');
  }
  std::string log;
  auto rt = load(cfg, {}, &log);
  ASSERT_NE(rt, nullptr);
  EXPECT_NE(log.find("retained block state ignored"), std::string::npos) << log;
  EXPECT_NE(log.find(state + ": checksum mismatch"), std::string::npos) << log;
  EXPECT_EQ(log.find("restored"), std::string::npos) << log;
}

TEST(RetainedState, retain_none_keeps_nothing_and_an_unknown_block_name_is_an_error) {
  RuntimeFixture fx;
  fx.write("p.fbd", kIntegrator);
  const std::string name = fx.unique_name();
  {
    auto rt = load(config_for(fx, name, ", retain: none"), {});
    ASSERT_NE(rt, nullptr);
    wait_cycles(*rt, 5);
    rt->stop();
    std::ifstream f(rt->state_path());
    EXPECT_FALSE(f.good()) << "nothing retained: no state file";
  }
  config::LoadResult cfg = config::load_config(config_for(fx, name, ", retain: [F2, F42]"));
  ASSERT_TRUE(cfg.ok()) << cfg.render();
  LoadReport report;
  auto rt = Runtime::load(*cfg.config, {}, report);
  EXPECT_EQ(rt, nullptr);
  EXPECT_NE(report.render().find("'retain' names 'F42', not a block of its program"),
            std::string::npos)
      << report.render();
}

TEST(RetainedState, a_state_file_that_cannot_be_written_is_an_error_naming_it) {
  RuntimeFixture fx;
  fx.write("p.fbd", kIntegrator);
  const std::string name = fx.unique_name();
  const std::string cfg = config_for(fx, name);
  const std::string state = fx.dir() + "/" + name + ".state";
  ASSERT_EQ(mkdir(state.c_str(), 0700), 0);  // a folder where the file belongs: rename fails
  auto rt = load(cfg, {});
  ASSERT_NE(rt, nullptr);
  wait_cycles(*rt, 5);
  std::string err;
  EXPECT_FALSE(rt->persist_state(&err));
  EXPECT_NE(err.find("cannot write the retained block state"), std::string::npos) << err;
  EXPECT_NE(err.find(state), std::string::npos) << err;
  rt->stop();
  EXPECT_NE(rt->stop_state_error().find(state), std::string::npos) << rt->stop_state_error();
  rmdir(state.c_str());
}

TEST(RetainedState, a_plant_at_rest_costs_no_write) {
  RuntimeFixture fx;
  fx.write(
      "p.fbd",
      "%%\nF1 = asp(d0, c0, 0, \"SP\")\nF2 = intg(F1, 1)\ndao(F2, p0, d0, c0, \"OUT\")\nEND\n");
  const std::string cfg = config_for(fx, fx.unique_name());
  auto rt = load(cfg, {});
  ASSERT_NE(rt, nullptr);
  const auto* stats = static_cast<const CycleStats*>(rt->image().task_stats(0));
  wait_cycles(*rt, 3);
  ASSERT_TRUE(rt->persist_state());
  auto first = load_state_file(rt->state_path());
  ASSERT_TRUE(first.ok() && *first) << (first.ok() ? "no file" : first.error());
  const uint64_t seen = stats->cycles();
  wait_cycles(*rt, seen + 10);  // more snapshots, all of the same state
  ASSERT_TRUE(rt->persist_state());
  auto second = load_state_file(rt->state_path());
  ASSERT_TRUE(second.ok() && *second);
  EXPECT_EQ((*second)->saved_unix_ms, (*first)->saved_unix_ms)
      << "rewritten though nothing changed";
  EXPECT_EQ((*second)->tasks[0].cycle, (*first)->tasks[0].cycle);
  rt->stop();
}

// After a swap the file holds the new program's blocks; a restart into the
// config's program restores what it shares and names what it drops.
TEST(RetainedState, a_swapped_program_is_what_the_file_holds) {
  RuntimeFixture fx;
  fx.write("p.fbd", kIntegrator);
  const std::string cfg = config_for(fx, fx.unique_name());
  std::string swapped = kIntegrator;
  swapped.insert(swapped.find("dao("), "F5 = filt(F2, 2)\n");
  double f2_at_stop = 0;
  {
    auto rt = load(cfg, {});
    ASSERT_NE(rt, nullptr);
    wait_cycles(*rt, 5);
    auto r = rt->swap("t", swapped, "with_filter.fbd");
    ASSERT_TRUE(r.ok()) << r.error();
    rt->stop();
    f2_at_stop = rtplc::testing::block_value(rt->task(0).last_run(), "F2");
    auto st = load_state_file(rt->state_path());
    ASSERT_TRUE(st.ok() && *st);
    std::vector<std::string> names;
    for (const SavedBlock& b : (*st)->tasks[0].blocks) names.push_back(b.name);
    EXPECT_EQ(names, (std::vector<std::string>{"F2", "D3", "F5"}));
  }
  std::string log;
  auto rt = load(cfg, {}, &log, /*start=*/false);  // programs: config runs p.fbd again
  ASSERT_NE(rt, nullptr);
  EXPECT_NE(log.find("task t: restored 2 blocks (F2, D3)"), std::string::npos) << log;
  EXPECT_NE(log.find("1 saved block no longer retained by its program, dropped (F5)"),
            std::string::npos)
      << log;
  EXPECT_EQ(rtplc::testing::block_value(rt->task(0).last_run(), "F2"), f2_at_stop);
}

// SFC steps are blocks too: a chart left in its third step comes back in it.
TEST(RetainedState, an_sfc_chart_restarts_in_the_step_it_was_in) {
  RuntimeFixture fx;
  fx.write("seq.sfc",
           "SFC seq STEPS d0\n"
           "INPUT GO = dsp(d0, c5, 0, \"GO\")\n"
           "OUTPUT Q = ddo(p0, d1, c0, \"Q\")\n"
           "INITIAL STEP A\nEND_STEP\nSTEP B\nEND_STEP\nSTEP C\n  N Q\nEND_STEP\n"
           "TRANSITION t1 FROM A TO B WHEN GO\nTRANSITION t2 FROM B TO C WHEN NOT GO\n"
           "TRANSITION t3 FROM C TO A WHEN GO\n");
  const std::string cfg = config_for(fx, fx.unique_name(), "", "seq.sfc");
  auto wait_for = [](Runtime& rt, const std::string& label, double v) {
    for (int i = 0; i < 400 && rtplc::testing::channel_value(rt, label) != v; ++i) sleep_s(0.005);
    return rtplc::testing::channel_value(rt, label) == v;
  };
  {
    auto rt = load(cfg, {});
    ASSERT_NE(rt, nullptr);
    ASSERT_TRUE(rt->set_value("GO", 1).ok());
    ASSERT_TRUE(wait_for(*rt, "seq.B", 1));
    ASSERT_TRUE(rt->set_value("GO", 0).ok());
    ASSERT_TRUE(wait_for(*rt, "seq.C", 1));
    rt->stop();
  }
  {
    auto rt = load(cfg, {});  // GO is retained at 0: nothing moves the chart
    ASSERT_NE(rt, nullptr);
    EXPECT_TRUE(wait_for(*rt, "seq.C", 1)) << "a warm start continues in step C";
    EXPECT_EQ(rtplc::testing::channel_value(*rt, "seq.A"), 0);
    EXPECT_EQ(rtplc::testing::channel_value(*rt, "Q"), 1);
    rt->stop();
  }
  RuntimeOptions cold;
  cold.cold = true;
  auto rt = load(cfg, cold);
  ASSERT_NE(rt, nullptr);
  EXPECT_TRUE(wait_for(*rt, "seq.A", 1)) << "a cold start begins at the initial step";
  EXPECT_EQ(rtplc::testing::channel_value(*rt, "seq.C"), 0);
  rt->stop();
}

// The real binary, killed with SIGKILL: while integrating, the restart goes on
// from the retained value; frozen (SP 0) at a value the state file holds, the
// restarted one outputs exactly that value; a --cold restart outputs 0.
TEST(RetainedState, kill_9_then_restart_continues_the_integrator_and_cold_starts_from_zero) {
  RuntimeFixture fx;
  fx.write("p.fbd", kIntegrator);
  const std::string name = fx.unique_name();
  const std::string cfg = config_for(fx, name);
  const std::string sock = fx.dir() + "/" + name + ".sock";
  const std::string state = fx.dir() + "/" + name + ".state";
  auto launch = [&](bool cold) {
    return rtplc::testing::launch_rtplc_run(cfg, sock, cold ? std::vector<std::string>{"--cold"}
                                                            : std::vector<std::string>{});
  };
  // The first good OUT after a start (the task's first cycles); `cycles`, when
  // given, is how many cycles the task had run when OUT was read, or more.
  auto first_output = [&](uint64_t* cycles = nullptr) {
    auto img = io::ProcessImage::attach(name);
    EXPECT_TRUE(img.ok()) << img.error();
    if (!img.ok()) return -1.0;
    const int c = img->find_channel("OUT");
    EXPECT_GE(c, 0);
    io::ChannelValue v;
    for (int i = 0; i < 200; ++i) {
      v = img->read_channel(static_cast<uint32_t>(c));
      if (v.fresh && v.quality == Quality::kGood) break;
      sleep_s(0.01);
    }
    if (cycles) *cycles = static_cast<const CycleStats*>(img->task_stats(0))->cycles();
    return v.value;
  };
  auto saved_f2 = [&]() -> double {
    auto s = load_state_file(state);
    if (!s.ok() || !*s || (*s)->tasks.empty()) return -1;
    for (const SavedBlock& b : (*s)->tasks[0].blocks) {
      if (b.name == "F2") return b.values[0];
    }
    return -1;
  };

  pid_t pid = launch(false);
  // Whatever assertion returns early, no runtime is left running behind the test.
  struct KillAtExit {
    pid_t& pid;
    ~KillAtExit() {
      if (pid > 0 && waitpid(pid, nullptr, WNOHANG) == 0) {
        kill(pid, SIGKILL);
        waitpid(pid, nullptr, 0);
      }
    }
  } reaper{pid};
  double out = 0;
  for (int i = 0; i < 400 && (out = first_output()) < 0.05; ++i) sleep_s(0.01);
  ASSERT_GE(out, 0.05) << "the integrator did not run";
  for (int i = 0; i < 400 && saved_f2() <= 0; ++i) sleep_s(0.01);  // a first write
  // Killed while integrating: the restart goes on from the last value written,
  // plus at most one step (dt/Ti = 0.005) per cycle it has run since.
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  const double at_kill = saved_f2();
  ASSERT_GT(at_kill, 0.0) << "no state was written while it ran";
  pid = launch(false);
  uint64_t cycles = 0;
  out = first_output(&cycles);
  EXPECT_GE(out, at_kill) << "a warm restart continues from the retained value, not from 0";
  EXPECT_LE(out, at_kill + 0.005 * static_cast<double>(cycles + 1) + 1e-9);
  ASSERT_TRUE(control_request(sock, "set SP 0").ok());
  // Frozen: wait until the image and the state file agree on the held value.
  double held = -2;
  for (int i = 0; i < 400; ++i) {
    held = first_output();
    if (saved_f2() == held) break;
    sleep_s(0.01);
  }
  ASSERT_EQ(saved_f2(), held);
  ASSERT_GE(held, at_kill);  // it went on from there until SP went to 0
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  // `rtplc check` says what a start would restore, without writing anything.
  const rtplc::test::ToolRun check = rtplc::test::run_tool("check " + cfg);
  EXPECT_EQ(check.status, 0) << check.out;
  EXPECT_NE(check.out.find("task t: restored 2 blocks (F2, D3) from the state saved"),
            std::string::npos)
      << check.out;

  pid = launch(false);
  EXPECT_EQ(first_output(), held) << "a warm restart continues from the retained value";
  (void)control_request(sock, "stop");
  waitpid(pid, nullptr, 0);
  EXPECT_EQ(saved_f2(), held) << "the stop wrote the state again, the same";

  pid = launch(true);
  EXPECT_EQ(first_output(), 0.0) << "--cold starts from zero";
  (void)control_request(sock, "stop");
  waitpid(pid, nullptr, 0);
}

}  // namespace
}  // namespace rtplc::sched
