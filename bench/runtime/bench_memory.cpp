// Memory of a running runtime (the real `rtplc run`, memory locked as in
// production): resident and locked bytes of 16 tasks of 10,010 blocks each, and
// of the 16 tiny tasks of examples/sixteen.yaml, side by side with the bytes the
// programs themselves need (task images and arenas, measured in this process) and
// the process image. Goal: <= 64 MiB resident for the 16 big tasks.
//   build/release/bench/bench_memory [--rtplc PATH]
#include <signal.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/support/loop_program.h"
#include "blocks/executor.h"
#include "lang/compiler.h"

using namespace rtplc;

namespace {

constexpr int kLoops = 715;  // 10,010 blocks
constexpr int kTasks = 16;

// 10,010 blocks of the benchmark workload (bench/support/loop_program.h) for
// task `t`, with the I/O of its first loop only: 16 such tasks need 64 channels
// (every loop with its own would be 45,760, beyond kMaxChannels). The other
// loops read the first loop's set-point and enable, and end in compute blocks.
std::string task_program(int t) {
  std::string s = bench::loop_program(1, 0.01, t);
  s.erase(s.rfind("END\n"));
  for (int i = 1; i < kLoops; ++i) {
    const int b = i * 20;
    auto F = [&](int k) { return "F" + std::to_string(b + k); };
    auto D = [&](int k) { return "D" + std::to_string(b + k); };
    s += F(0) + " = scale(F0, 1, " + std::to_string(i) + ")\n";
    s += F(1) + " = filt(" + F(7) + ", 0.5)\n";
    s += F(2) + " = sub(" + F(0) + ", " + F(1) + ")\n";
    s += F(3) + " = epi(" + F(2) + ", 2, 5)\n";
    s += F(4) + " = derv(" + F(1) + ", 0.2)\n";
    s += F(5) + " = sub(" + F(3) + ", " + F(4) + ")\n";
    s += F(6) + " = lim(" + F(5) + ", 0, 100)\n";
    s += F(7) + " = filt(" + F(6) + ", 3)\n";
    s += F(8) + " = max(" + F(6) + ", " + F(7) + ")\n";
    s += D(9) + " = and(D9, D9)\n";
    s += D(10) + " = time(" + D(9) + ", 0.05)\n";
    s += D(11) + " = not(" + D(9) + ")\n";
    s += D(12) + " = cnt(" + D(10) + ", " + D(11) + ", 10)\n";
    s += D(13) + " = not(" + D(12) + ")\n";
  }
  return s + "END\n";
}

std::string temp_dir() {
  char tmpl[] = "/tmp/rtplc-bench-mem-XXXXXX";
  return mkdtemp(tmpl);
}

// kB fields of /proc/PID/status (VmRSS, VmLck, RssAnon, ...), -1 if absent.
long status_kb(pid_t pid, const char* field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  const size_t n = std::strlen(field);
  while (std::getline(in, line)) {
    if (line.compare(0, n, field) == 0 && line.size() > n && line[n] == ':') {
      return std::atol(line.c_str() + n + 1);
    }
  }
  return -1;
}

// Resident kB of the mappings whose name contains `what` (/proc/PID/smaps).
long mapping_rss_kb(pid_t pid, const std::string& what) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/smaps");
  std::string line;
  bool match = false;
  long kb = 0;
  while (std::getline(in, line)) {
    // A mapping's header line starts with its address range "lo-hi ".
    const size_t dash = line.find('-');
    if (dash != std::string::npos && dash > 0 && line.find(' ') > dash &&
        std::isxdigit(static_cast<unsigned char>(line[0]))) {
      match = line.find(what) != std::string::npos;
    } else if (match && line.compare(0, 4, "Rss:") == 0) {
      kb += std::atol(line.c_str() + 4);
    }
  }
  return kb;
}

struct Figures {
  long rss = -1, lck = -1, anon = -1, heap = -1, image = -1, threads = -1;
};

// Starts `rtplc run CONFIG`, waits until every task has run (its status
// answers), reads its memory, stops it.
bool measure(const std::string& rtplc, const std::string& config, const std::string& name, Figures& f) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    if (null >= 0) {
      dup2(null, 1);
      dup2(null, 2);
    }
    execl(rtplc.c_str(), rtplc.c_str(), "run", config.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  if (pid < 0) return false;
  bool up = false;
  for (int i = 0; i < 300 && !up; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    int st = 0;
    if (waitpid(pid, &st, WNOHANG) == pid) return false;  // it died
    const std::string cmd = rtplc + " status --name " + name + " >/dev/null 2>&1";
    up = std::system(cmd.c_str()) == 0;
  }
  if (up) {
    std::this_thread::sleep_for(std::chrono::seconds(2));  // steady state
    f.rss = status_kb(pid, "VmRSS");
    f.lck = status_kb(pid, "VmLck");
    f.anon = status_kb(pid, "RssAnon");
    f.threads = status_kb(pid, "Threads");
    f.heap = mapping_rss_kb(pid, "[heap]");
    f.image = mapping_rss_kb(pid, "/dev/shm/rtplc-" + name);
  }
  kill(pid, SIGTERM);
  int st = 0;
  waitpid(pid, &st, 0);
  return up;
}

double mib(long kb) { return static_cast<double>(kb) / 1024.0; }

void print(const char* what, const Figures& f, double programs_mib) {
  std::printf("  %-34s RSS %6.1f MiB  locked %6.1f MiB  (anon %.1f, heap %.1f, process image %.1f; %ld threads)\n",
              what, mib(f.rss), mib(f.lck), mib(f.anon), mib(f.heap), mib(f.image), f.threads);
  if (programs_mib > 0) {
    std::printf("  %-34s programs' own bytes %.1f MiB: RSS / programs = %.2f\n", "", programs_mib,
                mib(f.rss) / programs_mib);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string rtplc = std::string(RTPLC_BINARY_DIR) + "/rtplc";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--rtplc") == 0) rtplc = argv[i + 1];
  }
  const std::string dir = temp_dir();
  const std::string name = "benchmem" + std::to_string(getpid());
  std::string yaml = "runtime:\n  name: " + name + "\n  socket: " + dir + "/s.sock\n  retain_file: " + dir +
                     "/r.retain\n  programs: config\ntasks:\n";
  // What the programs themselves need: the compiled images and one arena each.
  double program_bytes = 0;
  uint32_t blocks = 0;
  for (int t = 0; t < kTasks; ++t) {
    const std::string src = task_program(t);
    const std::string file = dir + "/big" + std::to_string(t) + ".fbd";
    std::ofstream(file) << src;
    yaml += "  - {name: big" + std::to_string(t) + ", program: big" + std::to_string(t) + ".fbd, period: 10ms, retain: RETAIN}\n";
    auto compiled = lang::compile_source(src);
    if (!compiled.ok()) {
      std::fprintf(stderr, "bench_memory: the generated program does not compile\n");
      return 1;
    }
    const TaskImage& image = *compiled.image;
    blocks = image.header().n_instr;
    const TaskArena arena(image);
    program_bytes += static_cast<double>(image.header().total_size) +
                     8.0 * static_cast<double>(arena.values.size() + arena.state.size() + arena.errors.size() +
                                               arena.io_in.size() + arena.io_out.size());
  }
  // Retained block state (the default, `retain: all`) keeps a snapshot and its
  // layout per task; `retain: none` shows the runtime without it.
  auto with_retain = [&](const std::string& how) {
    std::string y = yaml;
    for (size_t at = 0; (at = y.find("RETAIN", at)) != std::string::npos;) y.replace(at, 6, how);
    return y;
  };
  std::ofstream(dir + "/big.yaml") << with_retain("all");
  std::ofstream(dir + "/bignr.yaml") << with_retain("none");
  // The tiny tasks: examples/sixteen.yaml under a name of its own.
  std::ifstream ex(std::string(RTPLC_SOURCE_DIR) + "/examples/sixteen.yaml");
  std::stringstream tiny;
  tiny << "runtime:\n  name: " << name << "t\n  socket: " << dir << "/t.sock\n  retain_file: " << dir
       << "/t.retain\n  programs: config\n"
       << ex.rdbuf();
  std::string tiny_yaml = tiny.str();
  for (size_t at = 0; (at = tiny_yaml.find("program: sixteen/", at)) != std::string::npos;) {
    tiny_yaml.replace(at, 9, "program: " + std::string(RTPLC_SOURCE_DIR) + "/examples/");
    at += 9;
  }
  std::ofstream(dir + "/tiny.yaml") << tiny_yaml;

  std::printf("== rtplc memory: %d tasks of %u blocks, and %d tiny tasks, as `rtplc run` ==\n", kTasks, blocks,
              kTasks);
  Figures big, bare, small;
  if (!measure(rtplc, dir + "/big.yaml", name, big) || !measure(rtplc, dir + "/bignr.yaml", name, bare)) {
    std::fprintf(stderr, "bench_memory: `%s run %s/big.yaml` did not come up\n", rtplc.c_str(), dir.c_str());
    return 1;
  }
  if (!measure(rtplc, dir + "/tiny.yaml", name + "t", small)) {
    std::fprintf(stderr, "bench_memory: `%s run %s/tiny.yaml` did not come up\n", rtplc.c_str(), dir.c_str());
    return 1;
  }
  print("16 x 10,010 blocks, retain all:", big, program_bytes / 1048576.0);
  print("16 x 10,010 blocks, retain none:", bare, program_bytes / 1048576.0);
  print("16 tiny tasks:", small, 0);
  for (const auto& [what, f] : {std::pair<const char*, const Figures*>{"retain all (the default)", &big},
                                {"retain none", &bare}}) {
    const bool met = f->rss >= 0 && mib(f->rss) <= 64.0;
    std::printf("  goal: RSS <= 64 MiB for the 16 big tasks, %s: %s (%.1f MiB)\n", what, met ? "met" : "NOT met",
                mib(f->rss));
  }
  if (big.lck <= 0) std::printf("  (memory was not locked: run as root for the production figure)\n");
  std::string rm = "rm -rf " + dir;
  (void)std::system(rm.c_str());
  return 0;
}
