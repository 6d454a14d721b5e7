// What broke when a new user followed the README (the first-hour issue), each
// as the user met it: the built binary, its exit code and what it says.
// Defects: the runtime dying of its log pipe, compile over its own source,
// unbounded reads of devices and FIFOs, the tank example refusing /tmp, and
// output paths checked only after the work.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <regex>
#include <string>

#include "tests/support/run_tool.h"
#include "tests/support/scratch.h"

namespace rtplc::test {
namespace {

const std::string kExamples = std::string(RTPLC_SOURCE_DIR) + "/examples";



bool exists(const std::string& p) {
  struct stat st{};
  return lstat(p.c_str(), &st) == 0;
}

bool has(const ToolRun& r, const std::string& s) { return r.out.find(s) != std::string::npos; }

// Reads `fd` until `marker` has been seen or the writer closed it (or the
// generous guard ran out, so a broken runtime fails the test, not hangs it).
bool read_until(int fd, const std::string& marker, std::string& seen) {
  char buf[4096];
  for (int guard = 0; guard < 600; ++guard) {
    if (seen.find(marker) != std::string::npos) return true;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    const ssize_t n = read(fd, buf, sizeof buf);
    if (n <= 0) return false;
    seen.append(buf, static_cast<size_t>(n));
  }
  return seen.find(marker) != std::string::npos;
}

// ---- 1. the log pipe ---------------------------------------------------------

TEST(FirstHour, the_runtime_outlives_the_reader_of_its_log_and_logs_on_in_its_folder) {
  Scratch s("rtplc-first");
  const std::string name = "fh" + std::to_string(getpid());
  const std::string sock = s.path("ctl.sock");
  s.write("pid.fbd", slurp(kExamples + "/seed_pid.fbd"));
  const std::string cfg = s.write(
      "rt.yaml", "runtime:\n  name: " + name + "\n  socket: " + sock + "\n  retain_file: " + s.path("rt.retain") +
                     "\ntasks:\n  - {name: pid, program: pid.fbd}\ndrivers:\n  - kind: sim\n");
  int out[2];
  ASSERT_EQ(pipe(out), 0);
  const std::string bin = rtplc_binary();
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(out[1], STDOUT_FILENO);
    dup2(out[1], STDERR_FILENO);
    close(out[0]);
    close(out[1]);
    // The default disposition a shell gives a pipeline's members.
    signal(SIGPIPE, SIG_DFL);
    execl(bin.c_str(), bin.c_str(), "run", cfg.c_str(), "--no-lock", "--duration", "120", nullptr);
    _exit(127);
  }
  close(out[1]);
  std::string seen;
  const bool up = read_until(out[0], "running;", seen);
  close(out[0]);  // the reader goes away: `rtplc run ... | head`, a killed `tee`
  ASSERT_TRUE(up) << seen;
  // Each of these makes the runtime log a line into the dead pipe.
  for (const char* v : {"20", "30", "40"}) {
    const ToolRun set = run_tool("set --socket " + sock + " Setpoint " + v);
    EXPECT_EQ(set.status, 0) << set.out;
  }
  const ToolRun status = run_tool("status --socket " + sock);
  EXPECT_EQ(status.status, 0) << "the runtime died of its log: " << status.out;
  const ToolRun stop = run_tool("stop --socket " + sock);
  EXPECT_EQ(stop.status, 0) << stop.out;
  int st = 0;
  ASSERT_EQ(waitpid(pid, &st, 0), pid);
  EXPECT_TRUE(WIFEXITED(st)) << "killed by signal " << (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
  EXPECT_EQ(WIFEXITED(st) ? WEXITSTATUS(st) : -1, 0);
  // The log moved to the runtime's own folder, with the lines the pipe missed.
  const std::string log = slurp(s.path(name + ".log"));
  EXPECT_NE(log.find("standard output failed"), std::string::npos) << log;
  EXPECT_NE(log.find("40"), std::string::npos) << log;
}

// ---- 2. compile over its own source ------------------------------------------

TEST(FirstHour, compile_refuses_an_output_that_is_its_source_and_leaves_it_whole) {
  Scratch s("rtplc-first");
  const std::string src = slurp(kExamples + "/seed_pid.fbd");
  const std::string f = s.write("pid.fbd", src);
  ToolRun r = run_tool("compile " + f + " -o " + f);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "refusing to overwrite a source")) << r.out;
  EXPECT_EQ(slurp(f), src);
  // The same file by another name (a link, a ./ path) is the same file.
  ASSERT_EQ(symlink(f.c_str(), s.path("alias.img").c_str()), 0);
  r = run_tool("compile " + f + " -o " + s.path("alias.img"));
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_EQ(slurp(f), src);
  // A real output still works.
  r = run_tool("compile " + f + " -o " + s.path("pid.img"));
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(exists(s.path("pid.img")));
}

// ---- 3. devices, FIFOs and endless inputs ------------------------------------

TEST(FirstHour, every_command_refuses_a_device_with_a_reason_instead_of_reading_it_forever) {
  for (const std::string cmd : {"check", "compile", "sim", "analyze"}) {
    for (const char* dev : {"/dev/zero", "/dev/urandom"}) {
      // `timeout` turns the old endless read into a failure, not a hung suite.
      const ToolRun r = run_shell("timeout 60 " + rtplc_binary() + " " + cmd + " " + dev);
      EXPECT_EQ(r.status, 2) << cmd << " " << dev << ": " << r.out;
      EXPECT_TRUE(has(r, dev)) << r.out;
      EXPECT_TRUE(has(r, "not a regular file") || has(r, "character device")) << cmd << ": " << r.out;
      EXPECT_FALSE(has(r, "bad_alloc")) << r.out;
    }
  }
  const ToolRun swap = run_shell("timeout 60 " + rtplc_binary() + " swap pid /dev/zero --name nosuchrt");
  EXPECT_EQ(swap.status, 2) << swap.out;
  EXPECT_TRUE(has(swap, "not a regular file")) << swap.out;
}

TEST(FirstHour, check_of_a_fifo_says_so_instead_of_waiting_for_a_writer) {
  Scratch s("rtplc-first");
  for (const char* n : {"prog.fbd", "plant.yaml"}) {
    const std::string fifo = s.path(n);
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    const ToolRun r = run_shell("timeout 60 " + rtplc_binary() + " check " + fifo);
    EXPECT_EQ(r.status, 2) << n << ": " << r.out;
    EXPECT_TRUE(has(r, "not a regular file")) << r.out;
  }
}

// ---- 4. the tank example -------------------------------------------------------

TEST(FirstHour, the_tank_example_runs_as_the_readme_says_and_shows_unsent_outputs_as_such) {
  // Under another name, so a user's own `tank` runtime is not disturbed; its
  // state goes to folders of this test's own.
  Scratch s("rtplc-first");
  const std::string name = "fhtank" + std::to_string(getpid());
  const std::string env = "RUNTIME_DIRECTORY=" + s.dir() + " STATE_DIRECTORY=" + s.dir() + " ";
  const ToolRun check = run_shell(env + rtplc_binary() + " check " + kExamples + "/tank.yaml");
  EXPECT_EQ(check.status, 0) << check.out;
  const ToolRun r = run_shell(env + rtplc_binary() + " run " + kExamples + "/tank.yaml --name " + name +
                              " --no-lock --duration 30 > " + s.path("run.log") + " 2>&1 & " +
                              "for i in $(seq 1 300); do " + rtplc_binary() + " status --name " + name +
                              " >/dev/null 2>&1 && break; sleep 0.1; done; " +
                              // until both tasks and the plant have published a cycle
                              "for i in $(seq 1 300); do " + rtplc_binary() + " monitor --once --name " + name +
                              " | grep -q 'LV_201 .* good ' && break; sleep 0.1; done; " + rtplc_binary() +
                              " monitor --once --name " + name + "; " + rtplc_binary() + " stop --name " + name);
  const std::string log = slurp(s.path("run.log"));
  EXPECT_FALSE(has(ToolRun{0, log}, "refusing")) << log;
  EXPECT_FALSE(has(ToolRun{0, log}, "chmod")) << log;
  EXPECT_TRUE(has(r, "runtime " + name + " stopped")) << r.out << log;
  // valve1, valve2 and lamp1: no driver claims p0.d1.*, so nothing sends them.
  for (const char* out : {"valve1", "valve2", "lamp1"}) {
    const size_t at = r.out.find(std::string("  ") + out + " ");
    ASSERT_NE(at, std::string::npos) << r.out;
    const std::string row = r.out.substr(at, r.out.find('\n', at) - at);
    EXPECT_NE(row.find("unsent"), std::string::npos) << row;
    EXPECT_NE(row.find("(no driver sends it)"), std::string::npos) << row;
    EXPECT_EQ(row.find(" good "), std::string::npos) << row;
  }
  // LV_201 goes to the sim plant: sent, and good.
  const size_t lv = r.out.find("  LV_201 ");
  ASSERT_NE(lv, std::string::npos) << r.out;
  EXPECT_NE(r.out.substr(lv, r.out.find('\n', lv) - lv).find(" good "), std::string::npos) << r.out;
}

// ---- 5. output paths -------------------------------------------------------------

TEST(FirstHour, sim_refuses_an_output_in_a_missing_folder_before_running_and_prints_no_png) {
  const ToolRun r = run_tool("sim " + kExamples + "/seed_pid.fbd --duration 2 --plot /nonexistent/dir/x.png");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "/nonexistent/dir/x.png")) << r.out;
  EXPECT_TRUE(has(r, "folder /nonexistent/dir does not exist")) << r.out;
  EXPECT_FALSE(has(r, "PNG")) << "picture bytes on the terminal";
  EXPECT_FALSE(has(r, "gnuplot")) << "blames gnuplot: " << r.out;
  EXPECT_FALSE(has(r, "cycles")) << "ran before checking: " << r.out;
}

TEST(FirstHour, sim_csv_into_a_folder_is_refused_and_leaves_no_tmp_beside_it) {
  Scratch s("rtplc-first");
  const std::string dir = s.path("out");
  ASSERT_EQ(mkdir(dir.c_str(), 0700), 0);
  const ToolRun r = run_tool("sim " + kExamples + "/seed_pid.fbd --duration 2 --csv " + dir);
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_TRUE(has(r, "is a folder")) << r.out;
  EXPECT_FALSE(exists(dir + ".tmp"));
  // And the sim's own writer leaves none when the rename fails late.
  const ToolRun t = run_tool("sim " + kExamples + "/seed_pid.fbd --duration 2 --csv " + s.path("ok.csv"));
  EXPECT_EQ(t.status, 0) << t.out;
  EXPECT_FALSE(exists(s.path("ok.csv.tmp")));
  EXPECT_EQ(slurp(s.path("ok.csv")).rfind("t,", 0), 0u);
}

TEST(FirstHour, sim_plot_writes_the_png_whole_or_not_at_all) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "gnuplot is not installed (scripts/setup-deps installs it)";
  }
  Scratch s("rtplc-first");
  const ToolRun r = run_tool("sim " + kExamples + "/seed_pid.fbd --duration 2 --plot " + s.path("x.png"));
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(slurp(s.path("x.png")).substr(1, 3), "PNG");
  EXPECT_FALSE(exists(s.path("x.png.tmp")));
}

// ---- 8. check says what run would refuse on this machine ------------------------

TEST(FirstHour, check_of_a_config_refuses_a_cpu_this_machine_lacks_at_its_position) {
  Scratch s("rtplc-first");
  s.write("pid.fbd", slurp(kExamples + "/seed_pid.fbd"));
  const std::string cfg = s.write("c.yaml", "tasks:\n  - program: pid.fbd\n    cpu: 1000\ndrivers:\n  - kind: sim\n");
  const ToolRun r = run_tool("check " + cfg);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r, cfg + ":3:10: error: task pid: CPU 1000 is not available on this machine")) << r.out;
}

TEST(FirstHour, a_period_without_unit_and_one_that_replaces_the_stime_are_said) {
  Scratch s("rtplc-first");
  s.write("pid.fbd", slurp(kExamples + "/seed_pid.fbd"));  // stime(0.1)
  const std::string cfg = s.write("c.yaml", "tasks:\n  - program: pid.fbd\n    period: 100\ndrivers:\n  - kind: sim\n");
  const ToolRun r = run_tool("check " + cfg);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, cfg + ":3:13: warning: 'period: 100' has no unit, so it means 100s")) << r.out;
  EXPECT_TRUE(has(r, "task pid: period 100s replaces the stime 100ms")) << r.out;
  // Said with its unit and equal to the stime: nothing to say.
  const std::string same = s.write("d.yaml", "tasks:\n  - program: pid.fbd\n    period: 100ms\ndrivers:\n  - kind: sim\n");
  const ToolRun q = run_tool("check " + same);
  EXPECT_EQ(q.status, 0) << q.out;
  EXPECT_FALSE(has(q, "warning")) << q.out;
}

TEST(FirstHour, check_name_previews_the_warm_start_of_that_runtime) {
  const ToolRun r = run_tool("check " + kExamples + "/seed_pid.yaml --name fhpreview");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, "/fhpreview.state")) << r.out;
  EXPECT_FALSE(has(r, "/rtplc.state")) << r.out;
}

// ---- 11. the smaller ones ------------------------------------------------------------

TEST(FirstHour, client_and_modbus_typos_get_the_message_that_fits) {
  ToolRun r = run_tool("modbus read --port 1502 hr:0");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(has(r, "'hr:0' is an item, not a host")) << r.out;
  r = run_tool("modbus scan 127.0.0.1 --from 10 --to 1");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(has(r, "--from 10 is above --to 1")) << r.out;
  r = run_tool("modbus fake-slave --set hr:0:f32=abc");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(has(r, "'abc' is not a number")) << r.out;
  r = run_tool("set Setpoint ''");
  EXPECT_EQ(r.status, 2);
  EXPECT_TRUE(has(r, "'' is not a number")) << r.out;
  r = run_tool("sim " + kExamples + "/seed_pid.fbd --duration -1");
  EXPECT_EQ(r.status, 2);
  size_t said = 0;
  for (size_t p = r.out.find("must be"); p != std::string::npos; p = r.out.find("must be", p + 1)) ++said;
  EXPECT_EQ(said, 1u) << "one reason, once: " << r.out;
}

TEST(FirstHour, program_mistakes_are_named_once_and_for_what_they_are) {
  Scratch s("rtplc-first");
  // A wrong stime is one error, not also a "no stime" note.
  const std::string bad = s.write("s.fbd", "%%\nF1 = dai(p0, d0, c0, \"X\")\nstime(-1)\nEND\n");
  ToolRun r = run_tool("check " + bad);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_FALSE(has(r, "no stime")) << r.out;
  // A Petri net is analysed, not compiled: one line saying so.
  const std::string pnml = std::string(RTPLC_SOURCE_DIR) + "/tests/petri/corpus/mutex.pnml";
  r = run_tool("check " + pnml);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r, "is a Petri net (PNML)")) << r.out;
  EXPECT_TRUE(has(r, "1 error, 0 warnings")) << r.out;
  // --entry means something only for PLCopen XML.
  r = run_tool("check " + kExamples + "/seed_pid.fbd --entry Fast");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r, "leave the entry out")) << r.out;
  // A numerator of several terms is in parentheses.
  r = run_tool("sim " + kExamples + "/seed_pid.fbd --plant tf:2,1/1,3,1 --duration 1");
  EXPECT_TRUE(has(r, "(2 s + 1)/(s^2 + 3 s + 1)")) << r.out;
}

TEST(FirstHour, stop_waits_for_the_runtime_to_let_go_and_says_who_asked) {
  Scratch s("rtplc-first");
  const std::string name = "fhstop" + std::to_string(getpid());
  const std::string sock = s.path("ctl.sock");
  s.write("pid.fbd", slurp(kExamples + "/seed_pid.fbd"));
  const std::string cfg = s.write(
      "rt.yaml", "runtime:\n  name: " + name + "\n  socket: " + sock + "\n  retain_file: " + s.path("rt.retain") +
                     "\ntasks:\n  - {name: pid, program: pid.fbd}\ndrivers:\n  - kind: sim\n");
  const std::string log = s.path("run.log");
  const std::string bin = rtplc_binary();
  auto start = [&] {
    const pid_t pid = fork();
    if (pid == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0600);
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      execl(bin.c_str(), bin.c_str(), "run", cfg.c_str(), "--no-lock", "--duration", "120", nullptr);
      _exit(127);
    }
    return pid;
  };
  auto wait_up = [&] {
    for (int i = 0; i < 300; ++i) {
      if (run_tool("status --socket " + sock).status == 0) return true;
      usleep(100 * 1000);
    }
    return false;
  };
  pid_t pid = start();
  ASSERT_TRUE(wait_up()) << slurp(log);
  // A swap to a task that does not exist names the ones that do.
  ToolRun r = run_tool("swap nosuch " + s.path("pid.fbd") + " --socket " + sock);
  EXPECT_NE(r.status, 0);
  EXPECT_TRUE(has(r, "no task named nosuch; the tasks are pid")) << r.out;
  // list shows it running.
  r = run_tool("list");
  EXPECT_EQ(r.status, 0) << r.out;
  // (The name column is as wide as the longest name on the machine.)
  EXPECT_TRUE(std::regex_search(r.out, std::regex(name + " +running"))) << r.out;
  // stop returns once the runtime let go: the same name starts at once.
  r = run_tool("stop --socket " + sock);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, "runtime " + name + " stopped")) << r.out;
  const ToolRun again = run_tool("run " + cfg + " --no-lock -q --duration 0.5");
  EXPECT_EQ(again.status, 0) << again.out;
  int st = 0;
  waitpid(pid, &st, 0);
  EXPECT_TRUE(has(ToolRun{0, slurp(log)}, "stop requested by uid " + std::to_string(getuid()))) << slurp(log);
}

// ---- 7. sim's summary: per step, labelled, or none --------------------------------

TEST(FirstHour, sim_gives_figures_per_setpoint_step_timed_from_the_step) {
  // The README's flow_pidc run: the set-point falls from an unreachable 150 to 20
  // at 11 s, and the loop settles in under a second after that step.
  ToolRun r = run_tool("sim " + kExamples + "/flow_pidc.fbd --plant fopdt:K=1,T=0.5,L=0.05 --duration 20 "
                       "--step FIC_101_SP=150@1 --step FIC_101_SP=20@11");
  EXPECT_EQ(r.status, 0) << r.out;
  const size_t at = r.out.find("step at 11 s, FIC_101_SP 150 -> 20");
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::string step = r.out.substr(at);
  const size_t settle = step.find("settling time (2% band) ");
  ASSERT_NE(settle, std::string::npos) << step;
  EXPECT_LT(std::stod(step.substr(settle + 24)), 2.0) << step;
  EXPECT_EQ(r.out.find("400.0%"), std::string::npos) << r.out;
  EXPECT_TRUE(has(r, "step at 1 s, FIC_101_SP 20 -> 150")) << r.out;
  EXPECT_TRUE(has(r, "never reached 90% of the step before the next step")) << r.out;
  // A second step peaks as long after itself as the first after the start.
  r = run_tool("sim " + kExamples + "/seed_pid.fbd --step Setpoint=60@20 --duration 40");
  EXPECT_TRUE(has(r, "overshoot 17.6% (peak 58.7785, 1.5 s after the start)")) << r.out;
  EXPECT_TRUE(has(r, "step at 20 s, Setpoint 50 -> 60")) << r.out;
  EXPECT_TRUE(has(r, "1.5 s after the step")) << r.out;
  // No set-point at all: no invented figures.
  r = run_tool("sim " + kExamples + "/plcopen_tank.xml --duration 5");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, "no step figures")) << r.out;
  EXPECT_FALSE(has(r, "rise time")) << r.out;
}

// ---- 10. compiled images have a use ------------------------------------------------

TEST(FirstHour, a_compiled_image_is_accepted_wherever_a_program_is_and_verified_on_load) {
  Scratch s("rtplc-first");
  const std::string img = s.path("pid.img");
  ToolRun r = run_tool("compile " + kExamples + "/seed_pid.fbd -o " + img);
  ASSERT_EQ(r.status, 0) << r.out;
  r = run_tool("check " + img);
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(r, "OK, 7 blocks, period 0.1 s")) << r.out;
  // The same closed loop as from the source.
  const ToolRun from_img = run_tool("sim " + img + " --duration 5");
  const ToolRun from_src = run_tool("sim " + kExamples + "/seed_pid.fbd --duration 5");
  EXPECT_EQ(from_img.status, 0) << from_img.out;
  EXPECT_EQ(from_img.out.substr(from_img.out.find('\n')), from_src.out.substr(from_src.out.find('\n')));
  // Its parameters are prepared for its period: another one is refused.
  r = run_tool("sim " + img + " --period 0.2 --duration 1");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r, "compiled for a period of 0.1 s")) << r.out;
  // A damaged image is refused, not run: flip a byte of its code.
  std::string bytes = slurp(img);
  ASSERT_GT(bytes.size(), 200u);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x5a);
  const std::string bad = s.write("bad.img", bytes);
  r = run_tool("check " + bad);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r, "the task image is damaged")) << r.out;
  // A config task may name an image, and a runtime may swap to one.
  s.write("rt.yaml", "runtime:\n  name: fhimg" + std::to_string(getpid()) + "\n  socket: " + s.path("ctl.sock") +
                         "\n  retain_file: " + s.path("rt.retain") +
                         "\ntasks:\n  - {name: pid, program: pid.img}\ndrivers:\n  - kind: sim\n");
  r = run_tool("check " + s.path("rt.yaml"));
  EXPECT_EQ(r.status, 0) << r.out;
  r = run_shell(rtplc_binary() + " run " + s.path("rt.yaml") + " --no-lock -q --duration 30 & " +
                "for i in $(seq 1 300); do " + rtplc_binary() + " status --socket " + s.path("ctl.sock") +
                " >/dev/null 2>&1 && break; sleep 0.1; done; " + rtplc_binary() + " swap pid " + img + " --socket " +
                s.path("ctl.sock") + "; " + rtplc_binary() + " stop --socket " + s.path("ctl.sock"));
  EXPECT_TRUE(has(r, "now running " + img)) << r.out;
  EXPECT_TRUE(has(r, "stopped")) << r.out;
}

}  // namespace
}  // namespace rtplc::test
