// bench_petri: reachability speed and memory (issue item 4, "Speed and memory").
//
// Each case runs three times, each run in its own child process so that its peak
// resident memory and CPU time are its own (wait4's rusage): the packed store
// (explore(), bit-packed markings in an open-addressing table) with 1 thread,
// the same with N threads (--threads, default every allowed CPU; Philosophers-10
// is below the size where the parallel search takes over, so it stays on 1), and
// the reference in the same binary (reference_bfs(): std::unordered_set of
// std::vector<int>, std::deque queue). All must find the MCC's figures. "cpu" is
// the child's user + system time (with building the net and its invariants), and
// "CPUs" that over the search's time: below the thread count, other processes had
// the CPUs for part of the run.
//   philosophers  Philosophers-10: 59,049 markings, 459,270 edges
//   kanban        Kanban-5: 2,546,432 markings, 24,460,016 edges
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <algorithm>

#include "kernel_rt/rt_thread.h"
#include "lang/petri/generators.h"
#include "lang/petri/invariants.h"
#include "lang/petri/reachability.h"
#include "lang/petri/reference_bfs.h"

using namespace rtplc::petri;

namespace {

struct Case {
  const char* name;
  Net (*make)(uint32_t);
  uint32_t n;
  uint64_t markings;
  uint64_t edges;
};

struct Figures {
  uint64_t markings = 0;
  uint64_t edges = 0;
  double seconds = 0;
  double store_bytes = 0;  // the search's own estimate of its store
  long peak_kb = 0;        // the child's peak resident set
  unsigned threads = 1;    // threads the search used
  double cpu_seconds = 0;  // the child's user + system time
};

// Runs `work` in a child; its Figures come back through a pipe.
template <typename F>
Figures in_child(F work) {
  int fd[2];
  if (pipe(fd) != 0) std::exit(1);
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    Figures f = work();
    if (write(fd[1], &f, sizeof f) != static_cast<ssize_t>(sizeof f)) _exit(1);
    _exit(0);
  }
  close(fd[1]);
  Figures f;
  if (read(fd[0], &f, sizeof f) != static_cast<ssize_t>(sizeof f))
    std::fprintf(stderr, "child failed\n");
  close(fd[0]);
  int status = 0;
  rusage ru{};
  wait4(pid, &status, 0, &ru);
  f.peak_kb = ru.ru_maxrss;
  f.cpu_seconds = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                  static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) / 1e6;
  return f;
}

void print(const char* who, const Case& c, const Figures& f) {
  const double per_s = f.seconds > 0 ? static_cast<double>(f.markings) / f.seconds : 0;
  const bool ok = f.markings == c.markings && f.edges == c.edges;
  std::printf(
      "  %-10s %9llu markings %10llu edges %s  %7.3f s  %6.2f M markings/s  %6.1f bytes/marking  "
      "peak %6.1f MB  cpu %5.2f s (%4.2f CPUs)\n",
      who, static_cast<unsigned long long>(f.markings), static_cast<unsigned long long>(f.edges),
      ok ? "(exact)" : "(WRONG)", f.seconds, per_s / 1e6,
      f.markings ? f.store_bytes / static_cast<double>(f.markings) : 0.0,
      static_cast<double>(f.peak_kb) / 1024, f.cpu_seconds,
      f.seconds > 0 ? f.cpu_seconds / f.seconds : 0.0);
}

Figures run_packed(const Case& c, unsigned threads) {
  return in_child([&] {
    const Net net = c.make(c.n);
    ExploreOptions opt;
    opt.place_bounds = structural_bounds(net, p_invariants(net));
    opt.threads = threads;
    const ReachabilityResult r = explore(net, opt);
    return Figures{r.markings, r.edges,  r.seconds, static_cast<double>(r.store_bytes),
                   0,          r.threads};
  });
}

int run_case(const Case& c, bool reference, unsigned threads) {
  std::printf("%s-%u (MCC: %llu markings, %llu edges)\n", c.name, c.n,
              static_cast<unsigned long long>(c.markings),
              static_cast<unsigned long long>(c.edges));
  const Figures ours = run_packed(c, 1);
  print("packed 1t", c, ours);
  int failures = ours.markings == c.markings && ours.edges == c.edges ? 0 : 1;
  if (threads > 1) {
    const Figures par = run_packed(c, threads);
    char who[32];
    std::snprintf(who, sizeof who, par.threads == threads ? "packed %ut" : "packed %ut*",
                  par.threads);
    print(who, c, par);
    failures += par.markings == c.markings && par.edges == c.edges ? 0 : 1;
    std::printf("  threads    %u threads %.2fx the speed of 1 thread%s\n", par.threads,
                par.seconds > 0 ? ours.seconds / par.seconds : 0.0,
                par.threads < threads ? " (* fewer threads than asked: the space is too small for "
                                        "the parallel search, or a thread was refused)"
                                      : "");
  }
  if (!reference) return failures;
  const Figures ref = in_child([&] {
    const Net net = c.make(c.n);
    const ReferenceResult r = reference_bfs(net);
    return Figures{r.markings, r.edges, r.seconds, static_cast<double>(r.approx_bytes), 0, 1};
  });
  print("reference", c, ref);
  failures += ref.markings == c.markings && ref.edges == c.edges ? 0 : 1;
  std::printf(
      "  ratio      %.1fx faster, %.1fx less peak memory, %.1fx fewer bytes per marking\n",
      ours.seconds > 0 ? ref.seconds / ours.seconds : 0.0,
      ours.peak_kb > 0 ? static_cast<double>(ref.peak_kb) / static_cast<double>(ours.peak_kb) : 0.0,
      ours.store_bytes > 0 ? ref.store_bytes / ours.store_bytes : 0.0);
  return failures;
}

}  // namespace

int main(int argc, char** argv) {
  std::string only;
  bool reference = true;
  unsigned threads = std::max(1u, rtplc::kernel_rt::allowed_cpu_count());
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--case" && i + 1 < argc) {
      only = argv[++i];
    } else if (a == "--no-reference") {
      reference = false;
    } else if (a == "--threads" && i + 1 < argc && std::atoi(argv[i + 1]) > 0) {
      threads = static_cast<unsigned>(std::atoi(argv[++i]));
    } else {
      std::fprintf(
          stderr,
          "usage: bench_petri [--case philosophers|kanban] [--no-reference] [--threads N]\n"
          "  runs each case with 1 thread, with N threads (default: the CPUs allowed)\n"
          "  and with the reference BFS, each in its own process\n");
      return 2;
    }
  }
  const std::vector<Case> cases = {
      {"philosophers", philosophers, 10, 59049, 459270},
      {"kanban", kanban, 5, 2546432, 24460016},
  };
  // The machine's load as the run starts (other processes compete for the CPUs).
  if (FILE* la = std::fopen("/proc/loadavg", "r")) {
    char line[128] = {};
    if (std::fgets(line, sizeof line, la)) std::printf("load average at start: %s", line);
    std::fclose(la);
  }
  std::printf("CPUs allowed: %u; multi-threaded runs use %u threads\n",
              rtplc::kernel_rt::allowed_cpu_count(), threads);
  int failures = 0;
  for (const Case& c : cases) {
    if (!only.empty() && only != c.name) continue;
    failures += run_case(c, reference, threads);
  }
  return failures == 0 ? 0 : 1;
}
