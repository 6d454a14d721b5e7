// The command line refuses nonsense with one clear line and a non-zero exit, or
// does what it says (issue item 8): numbers, names, inputs of the wrong kind,
// sim without a plant and with a diverging one, version, and finding a runtime
// whose config moves its control socket.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <pwd.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/run_tool.h"
#include "tests/support/scratch.h"

namespace rtplc::test {
namespace {

const std::string kExamples = std::string(RTPLC_SOURCE_DIR) + "/examples";
const std::string kPid = kExamples + "/seed_pid.fbd";


bool has(const ToolRun& r, const std::string& s) { return r.out.find(s) != std::string::npos; }

// ---- numbers that must be positive and finite ------------------------------

TEST(Cli, period_zero_negative_or_nan_is_refused_by_check_compile_and_sim) {
  for (const char* cmd : {"check", "compile", "sim"}) {
    for (const char* v : {"0", "-1", "nan", "inf"}) {
      const ToolRun r = run_tool(std::string(cmd) + " " + kPid + " --period " + v);
      EXPECT_EQ(r.status, 2) << cmd << " --period " << v << ":\n" << r.out;
      EXPECT_TRUE(has(r, "--period")) << r.out;
      EXPECT_TRUE(has(r, "positive number of seconds")) << r.out;
    }
  }
  EXPECT_EQ(run_tool("check " + kPid + " --period 0.05").status, 0);
}

TEST(Cli, check_of_a_configuration_refuses_a_period_it_would_ignore) {
  const ToolRun r = run_tool("check " + kExamples + "/seed_pid.yaml --period 0.05");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "--period applies to one program")) << r.out;
}

TEST(Cli, run_duration_zero_or_negative_is_refused_not_run_forever) {
  for (const char* v : {"0", "-1", "nan"}) {
    const ToolRun r = run_tool("run " + kExamples + "/seed_pid.yaml --duration " + v);
    EXPECT_EQ(r.status, 2) << v << ":\n" << r.out;
    EXPECT_TRUE(has(r, "positive number of seconds")) << r.out;
  }
}

TEST(Cli, monitor_interval_and_stats_watch_below_the_floor_are_refused) {
  for (const char* v : {"0", "-1", "0.001", "nan"}) {
    ToolRun r = run_tool(std::string("monitor --interval ") + v);
    EXPECT_EQ(r.status, 2) << v << ":\n" << r.out;
    EXPECT_TRUE(has(r, "--interval")) << r.out;
    r = run_tool(std::string("stats --watch ") + v);
    EXPECT_EQ(r.status, 2) << v << ":\n" << r.out;
  }
}

// ---- sim --step ----------------------------------------------------------------

TEST(Cli, s7_timeout_must_be_a_positive_number_of_milliseconds) {
  for (const char* v : {"-5", "0"}) {
    const ToolRun r = run_tool(std::string("s7 read 127.0.0.1 MB0 --timeout ") + v);
    EXPECT_EQ(r.status, 2) << v << ": " << r.out;
    EXPECT_TRUE(has(r, "--timeout")) << r.out;
  }
}

TEST(Cli, sim_step_refuses_nan_values_and_times_outside_the_run) {
  ToolRun r = run_tool("sim -q " + kPid + " --step Setpoint=nan@1");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "VALUE must be a finite number")) << r.out;
  for (const char* at : {"-5", "1000", "nan"}) {
    r = run_tool("sim -q " + kPid + " --duration 30 --step Setpoint=60@" + at);
    EXPECT_EQ(r.status, 2) << at << ":\n" << r.out;
    EXPECT_TRUE(has(r, "within the run, 0 to 30 s")) << r.out;
  }
  EXPECT_EQ(run_tool("sim -q " + kPid + " --duration 30 --step Setpoint=60@30").status, 0);
}

// ---- sim without a plant, and with a diverging one ---------------------------

TEST(Cli, sim_runs_a_program_without_plant_channels_open_loop_and_says_so) {
  Scratch s("rtplc-cli");
  const std::string f = s.write("logic.fbd",
                                "%%\nstime(0.1)\nD1 = dsp(d0, c0, 0, \"Start\")\nD2 = time(D1, 1)\n"
                                "ddo(D2, p0, d0, c1, \"Motor\")\nEND\n%%\n");
  const std::string csv = s.dir() + "/t.csv";
  const ToolRun r = run_tool("sim " + f + " --duration 5 --step Start=1@1 --csv " + csv);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, "open loop")) << r.out;
  std::ifstream in(csv);
  std::string header, line, last;
  std::getline(in, header);
  while (std::getline(in, line)) last = line;
  EXPECT_NE(header.find("Motor"), std::string::npos) << header;
  EXPECT_EQ(last.substr(last.size() - 1), "1") << "the timer never fired: " << last;
  // A plant asked for by name is not silently dropped.
  const ToolRun named = run_tool("sim -q " + f + " --plant fopdt");
  EXPECT_EQ(named.status, 1) << named.out;
  EXPECT_TRUE(has(named, "no dao at")) << named.out;
}

// A PLCopen project's variables get a column each; a located global is its
// channel's column, once (here a set-point, so --step can raise it).
TEST(Cli, sim_of_a_plcopen_event_task_traces_each_variable_once) {
  Scratch s("rtplc-cli");
  const std::string f = s.write(
      "ev.xml",
      "<?xml version=\"1.0\"?>\n<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\" "
      "xmlns:xhtml=\"http://www.w3.org/1999/xhtml\"><fileHeader companyName=\"t\"/><types><dataTypes/><pous>\n"
      "<pou name=\"main\" pouType=\"program\"><interface><localVars>"
      "<variable name=\"n\"><type><INT/></type></variable></localVars></interface>\n"
      "<body><ST><xhtml:p><![CDATA[n := n + 1;]]></xhtml:p></ST></body></pou></pous></types>\n"
      "<instances><configurations><configuration name=\"c\"><resource name=\"r\"><globalVars>"
      "<variable name=\"trig\" address=\"%MX0.0\"><type><BOOL/></type></variable></globalVars>\n"
      "<task name=\"ev\" priority=\"1\" single=\"trig\" interval=\"T#10ms\">"
      "<pouInstance name=\"inst\" typeName=\"main\"/></task></resource></configuration></configurations>"
      "</instances></project>\n");
  const ToolRun check = run_tool("check " + f + " --explain");
  EXPECT_EQ(check.status, 0) << check.out;
  EXPECT_TRUE(has(check, "event task: the body runs in the cycles trig rises")) << check.out;
  const std::string csv = s.dir() + "/t.csv";
  const ToolRun r = run_tool("sim -q " + f + " --duration 0.2 --step trig=1@0.05 --csv " + csv);
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream in(csv);
  std::string header, line, last;
  std::getline(in, header);
  while (std::getline(in, line)) last = line;
  EXPECT_EQ(header, "t,trig,inst.n");
  EXPECT_EQ(last.substr(last.rfind(',') + 1), "1") << "one rising edge, one run: " << last;
}

// examples/plcopen_batch.xml on the measuring tank: recipe 2 (the set-point's
// initial value) is two fills per batch, so 60 s make two batches of two.
TEST(Cli, the_plcopen_batch_example_runs_its_recipes_on_the_tank) {
  Scratch s("rtplc-cli");
  const std::string csv = s.dir() + "/b.csv";
  const ToolRun r = run_tool("sim -q " + kExamples + "/plcopen_batch.xml --plant measuring-tank --duration 60 --csv " + csv);
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream in(csv);
  std::string header, line, last;
  std::getline(in, header);
  while (std::getline(in, line)) last = line;
  auto column = [](const std::string& row, const std::string& head, const std::string& name) {
    std::vector<std::string> hs, vs;
    std::stringstream h(head), v(row);
    for (std::string x; std::getline(h, x, ',');) hs.push_back(x);
    for (std::string x; std::getline(v, x, ',');) vs.push_back(x);
    for (size_t i = 0; i < hs.size() && i < vs.size(); ++i) {
      if (hs[i] == name) return vs[i];
    }
    return std::string("missing");
  };
  EXPECT_EQ(column(last, header, "tank.count.batches"), "2") << header << "\n" << last;
  EXPECT_EQ(column(last, header, "tank.count.fills"), "4");
  EXPECT_EQ(column(last, header, "tank.recipes[2].settle"), "3");
}

TEST(Cli, sim_reports_a_diverging_loop_as_unstable_and_fails) {
  // The README's own example plant with the seed's PID diverges.
  ToolRun r = run_tool("sim " + kPid + " --plant tf:2,1/1,3,1");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r, "UNSTABLE")) << r.out;
  EXPECT_FALSE(has(r, "overshoot")) << "a diverging loop reported as a step response:\n" << r.out;
  r = run_tool("sim -q " + kPid + " --plant tf:2,1/1,3,1 --allow-unstable");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, "UNSTABLE")) << r.out;
  // The default plant is stable: no such line.
  r = run_tool("sim " + kPid);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_FALSE(has(r, "UNSTABLE")) << r.out;
}

// ---- commands and version ------------------------------------------------------

TEST(Cli, unknown_command_is_named_not_called_missing) {
  ToolRun r = run_tool("bogus");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "unknown command 'bogus'")) << r.out;
  EXPECT_FALSE(has(r, "A subcommand is required")) << r.out;
  r = run_tool("chek x.fbd");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "did you mean 'check'?")) << r.out;
}

TEST(Cli, version_prints_version_commit_and_build_type) {
  for (const char* args : {"version", "--version"}) {
    const ToolRun r = run_tool(args);
    EXPECT_EQ(r.status, 0) << args << ":\n" << r.out;
    EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(^rtplc \d+\.\d+\.\d+ \(commit ([0-9a-f]+(-dirty)?|unknown), \w+ build\)\n$)")))
        << args << ": " << r.out;
  }
}

// ---- inputs of the wrong kind --------------------------------------------------

TEST(Cli, inputs_of_the_wrong_kind_say_what_the_file_is) {
  Scratch s("rtplc-cli");
  ToolRun r = run_tool("check " + s.dir());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "is a folder")) << r.out;
  EXPECT_FALSE(has(r, "error:")) << "parsed a folder as FBD:\n" << r.out;

  r = run_tool("sim " + kExamples + "/plant.yaml");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "is a runtime configuration")) << r.out;

  const std::string img = s.dir() + "/pid.img";
  ASSERT_EQ(run_tool("compile " + kPid + " -o " + img).status, 0);
  // An image is a program (see FirstHour's image test); only compiling it again is refused.
  r = run_tool("compile " + img);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "is already a compiled task image")) << r.out;
  r = run_tool("run " + kPid);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "is not a runtime configuration")) << r.out;
  r = run_tool("check " + s.dir() + "/nowhere.fbd");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "no such file")) << r.out;
}

TEST(Cli, compile_into_a_folder_is_refused_and_leaves_no_tmp_file) {
  Scratch s("rtplc-cli");
  const ToolRun r = run_tool("compile " + kPid + " -o " + s.dir());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "is a folder")) << r.out;
  struct stat st{};
  EXPECT_NE(stat((s.dir() + ".tmp").c_str(), &st), 0) << s.dir() << ".tmp left behind";
  // A folder that cannot be written: the error names the file, no .tmp stays.
  const ToolRun ro = run_tool("compile " + kPid + " -o /proc/rtplc-test.img");
  EXPECT_EQ(ro.status, 1) << ro.out;
  EXPECT_NE(stat("/proc/rtplc-test.img.tmp", &st), 0);
}

TEST(Cli, runtime_names_that_are_not_names_are_refused_up_front) {
  for (const char* cmd : {"run " RTPLC_SOURCE_DIR "/examples/seed_pid.yaml", "status", "stop", "stats",
                          "monitor --once", "set X 1"}) {
    const ToolRun r = run_tool(std::string(cmd) + " --name ../evil");
    EXPECT_EQ(r.status, 2) << cmd << ":\n" << r.out;
    EXPECT_TRUE(has(r, "is not a runtime name")) << cmd << ":\n" << r.out;
  }
}

TEST(Cli, swap_rollback_refuses_a_file_it_would_ignore) {
  const ToolRun r = run_tool("swap --rollback pid " + kPid);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "takes no FILE")) << r.out;
}

// ---- diagnostics of a binary file ----------------------------------------------

TEST(Cli, check_of_random_bytes_prints_escaped_lines_and_a_count_that_adds_up) {
  Scratch s("rtplc-cli");
  std::string junk;
  uint32_t x = 12345;
  for (int i = 0; i < 20000; ++i) {
    x = x * 1103515245u + 12345u;
    junk += static_cast<char>(x >> 24);
  }
  junk[10] = '\0';
  const ToolRun r = run_tool("check " + s.write("junk.bin", junk));
  EXPECT_EQ(r.status, 1) << r.out.substr(0, 2000);
  for (char c : r.out) {
    const auto b = static_cast<unsigned char>(c);
    ASSERT_FALSE((b < 0x20 && b != '\n' && b != '\t') || b == 0x7F)
        << "raw control byte " << int(b) << " in the output";
  }
  ASSERT_FALSE(r.out.empty());
  EXPECT_EQ(r.out.back(), '\n');
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"((\d+) errors?, (\d+) warnings?; nothing compiled)")))
      << r.out.substr(r.out.size() > 2000 ? r.out.size() - 2000 : 0);
  const size_t errors = std::stoul(m[1].str()), warnings = std::stoul(m[2].str());
  size_t shown = 0;
  for (const char* kind : {": error: ", ": warning: ", ": note: "}) {
    for (size_t p = r.out.find(kind); p != std::string::npos; p = r.out.find(kind, p + 1)) ++shown;
  }
  size_t left_out = 0;
  if (std::regex_search(r.out, m, std::regex(R"((\d+) more diagnostics? not shown)"))) left_out = std::stoul(m[1].str());
  EXPECT_GE(shown + left_out, errors + warnings) << "counted " << errors + warnings << ", shown " << shown
                                                 << ", said left out " << left_out;
  EXPECT_GT(shown, 1u);
}

// ---- a running runtime whose config moves its control socket -------------------

class RunningRuntime : public ::testing::Test {
 protected:
  void SetUp() override {
    name_ = "cli" + std::to_string(getpid());
    sock_ = s_.dir() + "/ctl.sock";
    prog_ = s_.dir() + "/pid.fbd";
    std::ifstream in(kPid);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    s_.write("pid.fbd", text);
    const std::string cfg =
        s_.write("rt.yaml", "runtime:\n  name: " + name_ + "\n  socket: " + sock_ + "\n  retain_file: " +
                                s_.dir() + "/rt.retain\ntasks:\n  - {name: pid, program: pid.fbd}\n"
                                "drivers:\n  - kind: sim\n");
    const std::string bin = rtplc_binary();
    pid_ = fork();
    if (pid_ == 0) {
      execl(bin.c_str(), bin.c_str(), "run", cfg.c_str(), "-q", "--no-lock", "--duration", "60", nullptr);
      _exit(127);
    }
    for (int i = 0; i < 100 && !up_; ++i) {
      struct stat st{};
      up_ = stat(sock_.c_str(), &st) == 0 && run_tool("status --socket " + sock_).status == 0;
      if (!up_) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  void TearDown() override {
    if (pid_ > 0) {
      if (run_tool("stop --socket " + sock_).status != 0) kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }
  Scratch s_;
  std::string name_, sock_, prog_;
  pid_t pid_ = -1;
  bool up_ = false;
};

TEST_F(RunningRuntime, status_by_name_finds_the_socket_its_config_sets) {
  ASSERT_TRUE(up_) << "runtime did not come up";
  const ToolRun r = run_tool("status --name " + name_);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, "runtime " + name_)) << r.out;
  EXPECT_TRUE(has(r, sock_)) << r.out;
  // stop by name reaches it too.
  const ToolRun stop = run_tool("stop --name " + name_);
  EXPECT_EQ(stop.status, 0) << stop.out;
  int st = 0;
  waitpid(pid_, &st, 0);
  pid_ = -1;
  EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0);
}

TEST_F(RunningRuntime, status_and_monitor_json_are_the_same_facts_as_json) {
  ASSERT_TRUE(up_) << "runtime did not come up";
  ASSERT_EQ(run_tool("force ManiVal 4.5 --socket " + sock_).status, 0);
  const ToolRun st = run_tool("status --json --socket " + sock_);
  EXPECT_EQ(st.status, 0) << st.out;
  const nlohmann::json sj = nlohmann::json::parse(st.out, nullptr, false);
  ASSERT_TRUE(sj.is_object()) << st.out;
  EXPECT_EQ(sj.value("runtime", ""), name_) << st.out;
  EXPECT_EQ(sj.value("control_socket", ""), sock_) << st.out;
  ASSERT_TRUE(sj["forced"].is_array() && sj["forced"].size() == 1) << st.out;
  EXPECT_EQ(sj["forced"][0]["label"], "ManiVal");
  EXPECT_EQ(sj["forced"][0]["dir"], "output");
  EXPECT_EQ(sj["forced"][0]["value"], 4.5);
  EXPECT_TRUE(sj["forced"][0].contains("since")) << st.out;
  ASSERT_TRUE(sj["tasks"].is_array() && !sj["tasks"].empty()) << st.out;
  EXPECT_EQ(sj["tasks"][0]["name"], "pid");
  EXPECT_EQ(sj["tasks"][0]["state"], "running");
  EXPECT_TRUE(sj["tasks"][0].contains("file")) << st.out;
  EXPECT_TRUE(sj["links"].is_array()) << st.out;
  // The force lands with the task's next snapshot (value and status together).
  auto mani = [](const ToolRun& r) {
    const nlohmann::json j = nlohmann::json::parse(r.out, nullptr, false);
    if (j.is_object() && j["channels"].is_array()) {
      for (const nlohmann::json& c : j["channels"]) {
        if (c.value("label", "") == "ManiVal") return c;
      }
    }
    return nlohmann::json::object();
  };
  ToolRun mon = run_tool("monitor --json --name " + name_);
  for (int i = 0; i < 50 && mani(mon).value("quality", "") != "forced"; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    mon = run_tool("monitor --json --name " + name_);
  }
  EXPECT_EQ(mon.status, 0) << mon.out;
  EXPECT_EQ(mani(mon).value("dir", ""), "output") << mon.out;
  EXPECT_EQ(mani(mon).value("value", 0.0), 4.5) << mon.out;
  EXPECT_EQ(mani(mon).value("quality", ""), "forced") << mon.out;
  // Both parse as JSON (Debian's python3 reads them).
  for (const ToolRun* r : {&st, static_cast<const ToolRun*>(&mon)}) {
    const std::string f = s_.write("out.json", r->out);
    EXPECT_EQ(std::system(("/usr/bin/python3 -m json.tool " + f + " > /dev/null").c_str()), 0) << r->out;
  }
}

TEST_F(RunningRuntime, audit_lists_every_write_with_who_old_and_new_refused_too) {
  ASSERT_TRUE(up_) << "runtime did not come up";
  EXPECT_EQ(run_tool("set Setpoint 61 --socket " + sock_).status, 0);
  EXPECT_NE(run_tool("set Setpoint nan --socket " + sock_).status, 0);
  EXPECT_EQ(run_tool("force ManiVal 2 --socket " + sock_).status, 0);
  EXPECT_EQ(run_tool("unforce ManiVal --socket " + sock_).status, 0);
  EXPECT_EQ(run_tool("status --socket " + sock_).status, 0);  // a read: not audited
  const ToolRun a = run_tool("audit --socket " + sock_);
  EXPECT_EQ(a.status, 0) << a.out;
  // Who (uid and name), the role, the typed request, what came of it.
  const std::string uid =
      " uid " + std::to_string(geteuid()) + " (" + getpwuid(geteuid())->pw_name + ") [admin] ";
  EXPECT_TRUE(has(a, uid + "set label=Setpoint value=61: Setpoint = 61 (was 50)")) << a.out;
  EXPECT_TRUE(has(a, uid + "set label=Setpoint value=nan: refused: ")) << a.out;
  EXPECT_TRUE(has(a, uid + "force label=ManiVal value=2: ManiVal (output) FORCED to 2 (was ")) << a.out;
  EXPECT_TRUE(has(a, uid + "unforce label=ManiVal: ManiVal released")) << a.out;
  EXPECT_FALSE(has(a, "status")) << a.out;
  const ToolRun last = run_tool("audit --lines 1 --socket " + sock_);
  EXPECT_TRUE(has(last, "unforce label=ManiVal")) << last.out;
  EXPECT_FALSE(has(last, "set label=Setpoint")) << last.out;
}

TEST_F(RunningRuntime, swap_with_another_stime_says_the_task_keeps_its_period) {
  ASSERT_TRUE(up_) << "runtime did not come up";
  std::ifstream in(prog_);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t p = text.find("stime(0.1)");
  ASSERT_NE(p, std::string::npos);
  text.replace(p, 10, "stime(0.5)");
  const std::string slow = s_.write("slow.fbd", text);
  ToolRun r = run_tool("swap pid " + slow + " --name " + name_);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, "says stime 0.5 s, but task pid keeps its period of 0.1 s")) << r.out;
  // The same stime: nothing to say.
  r = run_tool("swap pid " + prog_ + " --name " + name_);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_FALSE(has(r, "keeps its period")) << r.out;
}

TEST_F(RunningRuntime, stats_watch_into_a_pipe_writes_no_terminal_codes) {
  ASSERT_TRUE(up_) << "runtime did not come up";
  const ToolRun r = run_shell("timeout 1 " + rtplc_binary() + " stats --name " + name_ + " --watch 0.2 | cat");
  EXPECT_TRUE(has(r, "T:")) << r.out;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << "ANSI codes written into a pipe";
}

}  // namespace
}  // namespace rtplc::test
