// bench_drive: the drive link (`can`) and direct I/O (`gpio`) drivers on the
// host with their fake transports (issue 10, item 5, "Benchmark"), each beside
// a hand-written reference measured in the same run:
//   CAN   frames decoded per second per core by the driver's bridge (a map of
//         7 frames, 31 signals of 1..8 bytes, both byte orders, scales and
//         offsets, into its input region) vs a hand-written decode of the same
//         frames into a double array; and frames taken by the driver's I/O
//         thread from the fake bus at paced rates through a bounded receive
//         queue (lost frames must be 0 at the paced rate) vs a bare recv loop.
//   GPIO  pulses counted by the driver's edge-event thread from the fake chip,
//         flat out (every pulse counted) and at paced rates through the
//         kernel's 16-event line queue, vs a bare wait/read loop.
// CPU is each thread's own clock (the scheduler's schedstat, or
// CLOCK_THREAD_CPUTIME_ID), never wall time. Exits 1 only when a count is
// wrong (a frame or pulse lost at the paced rate, or unaccounted for at any
// rate, or a decoded value that differs from the reference), never on timing.
#include "bench/drive/drive_bench.h"

#include <dirent.h>
#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <iterator>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <thread>

#include "kernel_rt/clock.h"

namespace rtplc::bench {

int64_t self_cpu_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return kernel_rt::to_ns(ts);
}

int64_t task_cpu_ns(pid_t tid) {
  std::ifstream f(fmt::format("/proc/self/task/{}/schedstat", tid));
  int64_t ns = -1;
  if (!(f >> ns)) return -1;
  return ns;
}

pid_t find_task(std::string_view comm) {
  pid_t found = 0;
  if (DIR* d = ::opendir("/proc/self/task")) {
    while (const dirent* e = ::readdir(d)) {
      if (e->d_name[0] == '.') continue;
      std::ifstream f(fmt::format("/proc/self/task/{}/comm", e->d_name));
      std::string name;
      if (std::getline(f, name) && name == comm) found = static_cast<pid_t>(std::atoi(e->d_name));
    }
    ::closedir(d);
  }
  return found;
}

pid_t current_tid() { return static_cast<pid_t>(::syscall(SYS_gettid)); }

std::string policy_text(pid_t tid) {
  const int p = ::sched_getscheduler(tid);
  sched_param sp{};
  ::sched_getparam(tid, &sp);
  if (p == SCHED_FIFO) return fmt::format("SCHED_FIFO {}", sp.sched_priority);
  return p == SCHED_OTHER ? "SCHED_OTHER" : p < 0 ? "unknown" : fmt::format("policy {}", p);
}

StreamRow run_stream(double rate, uint64_t n, const std::function<void(uint64_t)>& produce, const Consumer& c) {
  StreamRow r;
  r.rate = rate;
  r.sent = n;
  const uint64_t taken0 = c.taken(), dropped0 = c.dropped();
  const int64_t cpu0 = c.cpu_ns();
  const int64_t t0 = kernel_rt::monotonic_now_ns() + kernel_rt::kNsPerMs;
  const double interval = rate > 0 ? 1e9 / rate : 0;
  kernel_rt::sleep_until_ns(t0);
  for (uint64_t i = 0; i < n; ++i) {
    if (rate > 0) {
      const int64_t due = t0 + static_cast<int64_t>(static_cast<double>(i) * interval);
      // Sleep to 80 us before the item (a wake on a loaded host is late by tens
      // of us), then spin to it: items leave evenly, as frames on a wire do.
      if (due - kernel_rt::monotonic_now_ns() > 150 * kernel_rt::kNsPerUs) {
        kernel_rt::sleep_until_ns(due - 80 * kernel_rt::kNsPerUs);
      }
      while (kernel_rt::monotonic_now_ns() < due) {
      }
    }
    produce(i);
  }
  const int64_t t1 = kernel_rt::monotonic_now_ns();
  r.produced_rate = static_cast<double>(n) / (static_cast<double>(t1 - t0) / 1e9);
  // Drained when every item was taken or dropped; the bound (3 s without
  // progress) only keeps a broken consumer from hanging the run.
  uint64_t last = 0;
  int64_t progress_at = t1;
  for (;;) {
    const uint64_t done = (c.taken() - taken0) + (c.dropped() - dropped0);
    if (done >= n) {
      r.drained = true;
      break;
    }
    const int64_t now = kernel_rt::monotonic_now_ns();
    if (done != last) {
      last = done;
      progress_at = now;
    } else if (now - progress_at > 3 * kernel_rt::kNsPerSec) {
      break;
    }
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  r.taken = c.taken() - taken0;
  r.dropped = c.dropped() - dropped0;
  r.cpu_ns = c.cpu_ns() - cpu0;
  return r;
}

std::string per_item(int64_t cpu_ns, uint64_t items) {
  if (items == 0 || cpu_ns < 0) return "-";
  const double ns = static_cast<double>(cpu_ns) / static_cast<double>(items);
  return ns >= 10000 ? fmt::format("{:.1f} us", ns / 1000) : fmt::format("{:.0f} ns", ns);
}

std::string rate_text(double v) {
  if (v >= 1e6) return fmt::format("{:.2f} M/s", v / 1e6);
  if (v >= 1e3) return fmt::format("{:.1f} k/s", v / 1e3);
  return fmt::format("{:.0f} /s", v);
}

void print_stream_header(const char* item, const char* consumer_a, const char* consumer_b) {
  std::printf("  %-22s %-11s| %-46s| %s\n", "", "", consumer_a, consumer_b);
  std::printf("  %-22s %-11s| %-10s %-9s %-9s %-15s| %-10s %-9s %-9s %s\n", "rate asked (achieved)", item, "taken",
              "dropped", "lost", "CPU per item", "taken", "dropped", "lost", "CPU per item");
}

void print_stream_row(const char* label, const StreamRow& a, const StreamRow* b) {
  auto side = [](const StreamRow& r) {
    std::string s = fmt::format("{:<10} {:<9} {:<9} {:<15}", r.taken, r.dropped, r.lost(), per_item(r.cpu_ns, r.taken));
    if (!r.drained) s += " (NOT drained)";
    if (r.unaccounted() != 0) s += fmt::format(" ({} UNACCOUNTED)", r.unaccounted());
    return s;
  };
  const std::string rate = fmt::format("{} ({})", label, rate_text(a.produced_rate));
  std::printf("  %-22s %-11llu| %s| %s\n", rate.c_str(), static_cast<unsigned long long>(a.sent), side(a).c_str(),
              b ? side(*b).c_str() : "");
  std::fflush(stdout);
}

void prepare_driver_bench(DriverBench& b, const char* what, const char* yaml, const std::string& region,
                          uint32_t provides, uint32_t channel_capacity, int64_t period_ns,
                          const Options& o) {
  b.cfg = config::parse_config(yaml, "bench.yaml", "", config::LoadOptions{false});
  if (!b.cfg.ok()) {
    std::fprintf(stderr, "bench_drive: the %s map does not load:\n%s\n", what, b.cfg.render().c_str());
    std::exit(1);
  }
  io::ImageLayout l;
  l.name = "bench-" + region + "-" + std::to_string(::getpid());
  l.channel_capacity = channel_capacity;
  l.regions.push_back({"task:t", io::RegionKind::kTask, 0, 1});
  l.regions.push_back({"driver:" + region, io::RegionKind::kDriver, 0, provides});
  l.n_tasks = 1;
  l.task_stats_bytes = 64;
  l.n_links = 1;
  auto img = io::ProcessImage::create(l);
  if (!img) {
    std::fprintf(stderr, "bench_drive: %s\n", img.error().c_str());
    std::exit(1);
  }
  b.image = std::move(img).value();
  b.setup.config = &b.cfg.config->drivers[0];
  b.setup.image = &b.image;
  b.setup.region = 1;
  b.setup.n_provides = provides;
  b.setup.period_ns = period_ns;
  b.setup.priority = o.bridge_priority;
  b.setup.helper_priority = o.helper_priority;
  b.setup.events = &b.events;
}

}  // namespace rtplc::bench

namespace {

using rtplc::bench::Options;

const char* kHelp =
    "bench_drive [can|gpio] [--quick] [--scale X] [--can-rate F] [--gpio-rate P] [--paced-seconds S]\n"
    "            [--can-queue N] [--gpio-queue N] [--helper-priority F]\n"
    "\n"
    "Measures the can and gpio drivers on this host with their in-process fakes (no SocketCAN,\n"
    "no GPIO chip needed), each beside a hand-written reference in the same run, as CPU time of\n"
    "the threads doing the work (not wall time):\n"
    "  can   1. decode: the bridge's receive path (7 frames, 31 signals into the driver's input\n"
    "           region) vs a hand-written decode of the same frames into doubles: frames/s per core;\n"
    "        2. stream: frames pushed through the fake bus (a receive queue of --can-queue frames\n"
    "           per port, dropping when full, as a full socket buffer does) at --can-rate frames/s\n"
    "           for --paced-seconds (must lose none), then at rising rates and flat out: frames\n"
    "           taken by the driver's I/O thread vs a bare recv loop, and CPU per frame.\n"
    "  gpio  1. flood: pulses generated as fast as the fake chip takes them with an unbounded\n"
    "           event queue (every one must be counted): pulses/s per core, CPU per pulse;\n"
    "        2. paced: --gpio-rate pulses/s for --paced-seconds through a --gpio-queue event\n"
    "           queue (16: the kernel's, uAPI v1) must lose none, then rising rates: the highest\n"
    "           rate counted without loss, the driver's edge thread vs a bare wait/read loop.\n"
    "\n"
    "  can | gpio           one half only (default: both)\n"
    "  --quick              a fifth of the items (a smoke run)\n"
    "  --scale X            multiply every item count by X (0.01..100)\n"
    "  --can-rate F         the paced CAN rate, frames/s (default 8000: a 1 Mbit/s bus of 8-byte\n"
    "                       frames is saturated near 8,000 frames/s)\n"
    "  --gpio-rate P        the paced pulse rate, pulses/s (default 1000)\n"
    "  --paced-seconds S    how long the paced runs last (default 2, 0.1..600)\n"
    "  --can-queue N        receive queue of a fake bus port, frames (default 256, 1..1000000)\n"
    "  --gpio-queue N       event queue of a fake line, events (default 16, 1..1000000)\n"
    "  --helper-priority F  SCHED_FIFO of the I/O threads and the bare loops (default 9, the\n"
    "                       runtime's helper priority; 0: SCHED_OTHER)\n"
    "Exit status: 0 all counts right, 1 a count wrong (loss at the paced rate, items unaccounted\n"
    "for, decoded values differing from the reference), 2 bad arguments. Timing never fails it.\n";

[[noreturn]] void usage_error(const std::string& msg) {
  std::fprintf(stderr, "bench_drive: %s (see --help)\n", msg.c_str());
  std::exit(2);
}

double number_arg(std::string_view name, const char* text, double lo, double hi) {
  double v = 0;
  const std::string_view s = text;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || p != s.data() + s.size() || !(v >= lo && v <= hi)) {
    usage_error(fmt::format("{} wants a number in {}..{}, not '{}'", name, lo, hi, s));
  }
  return v;
}

Options parse(int argc, char** argv) {
  Options o;
  bool half = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kHelp, stdout);
      std::exit(0);
    }
    if (a == "can" || a == "gpio") {
      if (!half) o.can = o.gpio = false;
      half = true;
      (a == "can" ? o.can : o.gpio) = true;
      continue;
    }
    if (a == "--quick") {
      o.scale = 0.2;
      continue;
    }
    constexpr std::string_view kValued[] = {"--scale",      "--can-rate",  "--gpio-rate",      "--paced-seconds",
                                            "--can-queue",  "--gpio-queue", "--helper-priority"};
    if (std::find(std::begin(kValued), std::end(kValued), a) == std::end(kValued)) {
      usage_error(fmt::format("unknown argument '{}'", a));
    }
    if (i + 1 >= argc) usage_error(fmt::format("{} wants a value", a));
    const char* v = argv[++i];
    if (a == "--scale") o.scale = number_arg(a, v, 0.01, 100);
    else if (a == "--can-rate") o.can_paced_rate = number_arg(a, v, 1, 1e7);
    else if (a == "--gpio-rate") o.gpio_paced_rate = number_arg(a, v, 1, 1e7);
    else if (a == "--paced-seconds") o.paced_seconds = number_arg(a, v, 0.1, 600);
    else if (a == "--can-queue") o.can_queue = static_cast<unsigned>(number_arg(a, v, 1, 1e6));
    else if (a == "--gpio-queue") o.gpio_queue = static_cast<unsigned>(number_arg(a, v, 1, 1e6));
    else if (a == "--helper-priority") o.helper_priority = static_cast<int>(number_arg(a, v, 0, 98));
    else usage_error(fmt::format("unknown argument '{}'", a));
  }
  o.decode_cycles = static_cast<int64_t>(static_cast<double>(o.decode_cycles) * o.scale);
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  std::string load;
  {
    std::ifstream f("/proc/loadavg");
    std::getline(f, load);
  }
  std::printf("bench_drive: %u CPUs, load average %s; I/O threads %s\n", std::thread::hardware_concurrency(),
              load.c_str(),
              o.helper_priority > 0 ? fmt::format("SCHED_FIFO {} (if allowed)", o.helper_priority).c_str()
                                    : "SCHED_OTHER");
  int failed = 0;
  if (o.can) failed += rtplc::bench::run_can(o);
  if (o.gpio) failed += rtplc::bench::run_gpio(o);
  if (failed != 0) {
    std::printf("\nbench_drive: %d count check(s) FAILED (see above)\n", failed);
    return 1;
  }
  std::printf("\nbench_drive: every count check passed\n");
  return 0;
}
