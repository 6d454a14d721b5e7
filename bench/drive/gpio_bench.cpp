// bench_drive, GPIO half (see bench_drive.cpp): pulse counting by the gpio
// driver over the fake chip, beside a bare loop over the same chip ops.
//
// The driver runs as the runtime starts it (bridge thread every 1 ms, the
// edge-event thread at the helper priority) with one `dpi` counter (rising
// edges, no debounce) on line 1; this thread drives the line up and down
// through the fake chip (as gpio-sim's `pull` attribute does), one rising
// edge event per pulse. The count is the driver's published one, and the
// image's at the end. The reference is one thread doing what a user would
// write: wait for the line's events, read them, count the rising ones.
//   flood  as fast as the fake takes them, with an unbounded event queue:
//          every pulse must be counted; CPU per pulse, pulses/s per core.
//   paced  at rising rates through a bounded queue (default 16: the kernel
//          keeps 16 events per line in uAPI v1, which libgpiod 1.6 uses); the
//          paced rate must lose none; the highest lossless rate is reported.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <thread>

#include "bench/drive/drive_bench.h"
#include "config/config.h"
#include "io/drivers/gpio/config.h"
#include "io/drivers/gpio/driver.h"
#include "io/drivers/gpio/fake_chip.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::bench {
namespace {

const char* kGpioConfig =
    "tasks:\n  - {name: t, program: p.fbd}\n"
    "drivers:\n  - kind: gpio\n    name: dio\n    period: 1ms\n    chip: gpiochip0\n"
    "    counters:\n"
    "      - {channel: p0.d0.c0, line: 1, edge: rising}\n";

constexpr unsigned kLine = 1;

struct GpioRig {
  DriverBench base;
  std::unique_ptr<gpio::GpioDriver> driver;

  GpioRig(const Options& o, gpio::FakeChips& chips) {
    prepare_driver_bench(base, "GPIO", kGpioConfig, "dio", 1, 8, kernel_rt::kNsPerMs, o);
    driver = std::make_unique<gpio::GpioDriver>(base.setup, chips.ops());
  }
  double image_count() {
    uint32_t idx = 0;
    double v = -1;
    (void)base.image.read_values(1, &idx, 1, &v, 8);
    return v;
  }
};

// The reference: wait, read, count rising edges.
struct BareCounter {
  std::atomic<uint64_t> count{0};
  std::atomic<pid_t> tid{0};
  std::atomic<bool> stop{false};
  kernel_rt::RtThread thread;
  const gpio::ChipOps* ops = nullptr;
  void* line = nullptr;

  bool start(gpio::FakeChips& chips, int priority) {
    ops = &chips.ops();
    auto chip = ops->open(ops->context, "gpiochip0");
    if (!chip) return false;
    gpio::LineRequest req;
    req.offset = kLine;
    req.edge = gpio::Edge::kRising;
    auto l = ops->request(*chip, req, "bare");
    if (!l) return false;
    line = *l;
    kernel_rt::ThreadSpec spec;
    spec.name = "bare-gpio";
    spec.fifo_priority = priority;
    auto t = kernel_rt::start_thread(spec, [this] {
      tid.store(current_tid());
      void* const lines[1] = {line};
      bool ready[1] = {false};
      gpio::EdgeEvent evs[16];
      uint64_t n = 0;
      while (!stop.load(std::memory_order_relaxed)) {
        if (ops->wait(std::span<void* const>(lines, 1), kernel_rt::kNsPerMs, ready) <= 0) continue;
        const int got = ops->read_events(line, evs, 16);
        for (int j = 0; j < got; ++j) n += evs[j].rising;
        count.store(n, std::memory_order_relaxed);
      }
    });
    if (!t) return false;
    thread = std::move(*t);
    while (tid.load() == 0) std::this_thread::yield();
    return true;
  }
  void end() {
    stop.store(true);
    thread.join();
    ops->release(line);
  }
};

struct Plan {
  std::string label;
  double rate;  // 0: flat out
  uint64_t n;
  bool bounded;  // through the bounded event queue
};

std::vector<Plan> gpio_plan(const Options& o) {
  auto count = [&](double base) { return static_cast<uint64_t>(std::max(200.0, base * o.scale)); };
  std::vector<Plan> p;
  p.push_back({"flood", 0, count(200000), false});
  p.push_back({"paced", o.gpio_paced_rate, static_cast<uint64_t>(std::max(100.0, o.gpio_paced_rate * o.paced_seconds)),
               true});
  for (double r : {2000.0, 10000.0, 50000.0, 100000.0, 200000.0, 500000.0}) {
    p.push_back({rate_text(r), r, count(r * 0.4), true});
  }
  p.push_back({"flat out", 0, count(200000), true});
  return p;
}

// One pulse: the line up (a rising edge event) and down again, stamped with
// the monotonic clock as the kernel stamps them (the driver's debounce
// compares stamps: they must not go back between runs).
auto pulser(gpio::FakeChips& chips) {
  return [&chips](uint64_t) {
    chips.pull("gpiochip0", kLine, 1, kernel_rt::monotonic_now_ns());
    chips.pull("gpiochip0", kLine, 0, kernel_rt::monotonic_now_ns());
  };
}

}  // namespace

int run_gpio(const Options& o) {
  std::printf("\n== GPIO (kind: gpio) pulse counting over the fake chip ==\n");
  std::fflush(stdout);
  int failed = 0;
  const std::vector<Plan> plan = gpio_plan(o);
  std::vector<StreamRow> drv, bare;
  double image_final = -1;
  uint64_t published_final = 0, generated_total = 0;
  int64_t bridge_cpu = -1;
  double wall = 0;
  std::string io_policy = "not found", bare_policy = "not found";
  {
    gpio::FakeChips chips;
    chips.add_chip("gpiochip0", "gpio-fake.0", 8);
    GpioRig rig(o, chips);
    if (auto r = rig.driver->start(kernel_rt::monotonic_now_ns() + 2 * kernel_rt::kNsPerMs); !r) {
      std::fprintf(stderr, "bench_drive: %s\n", r.error().c_str());
      return 1;
    }
    const pid_t io_tid = find_task("rtplc:gpio-io");
    const pid_t bridge_tid = find_task("rtplc:gpio");
    // edges_of() reads a snapshot slot; a rare miss returns zeros: the count
    // only grows, so keep the highest seen.
    uint64_t seen_count = 0;
    Consumer c{[&] { return seen_count = std::max(seen_count, rig.driver->edges_of(0).count); },
               [&] { return chips.events_dropped(); },
               [&] { return io_tid ? task_cpu_ns(io_tid) : -1; }};
    if (io_tid) io_policy = policy_text(io_tid);
    const int64_t b0 = bridge_tid ? task_cpu_ns(bridge_tid) : -1;
    const int64_t w0 = kernel_rt::monotonic_now_ns();
    for (const Plan& p : plan) {
      chips.limit_events(p.bounded ? o.gpio_queue : 0);
      drv.push_back(run_stream(p.rate, p.n, pulser(chips), c));
      generated_total += p.n;
    }
    wall = static_cast<double>(kernel_rt::monotonic_now_ns() - w0) / 1e9;
    if (bridge_tid && b0 >= 0) bridge_cpu = task_cpu_ns(bridge_tid) - b0;
    // The bridge publishes the count into the image every cycle: let it run a few.
    const uint64_t cycles = rig.driver->cycles();
    for (int i = 0; i < 2000 && rig.driver->cycles() < cycles + 3; ++i) {
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    image_final = rig.image_count();
    published_final = std::max(seen_count, rig.driver->edges_of(0).count);
    rig.driver->request_stop();
    rig.driver->join();
  }
  {
    gpio::FakeChips chips;
    chips.add_chip("gpiochip0", "gpio-fake.0", 8);
    BareCounter b;
    if (!b.start(chips, o.helper_priority)) {
      std::fprintf(stderr, "bench_drive: the bare GPIO loop did not start\n");
      return 1;
    }
    Consumer c{[&] { return b.count.load(std::memory_order_relaxed); }, [&] { return chips.events_dropped(); },
               [&] { return task_cpu_ns(b.tid.load()); }};
    bare_policy = policy_text(b.tid.load());
    for (const Plan& p : plan) {
      chips.limit_events(p.bounded ? o.gpio_queue : 0);
      bare.push_back(run_stream(p.rate, p.n, pulser(chips), c));
    }
    b.end();
  }

  const StreamRow& fd = drv.front();
  const StreamRow& fb = bare.front();
  std::printf("GPIO flood: %llu pulses as fast as the fake chip takes them, unbounded event queue\n",
              static_cast<unsigned long long>(fd.sent));
  std::printf("  consumers: the edge thread %s, the bare loop %s; the producer is this thread\n", io_policy.c_str(),
              bare_policy.c_str());
  std::printf("  %-34s %-22s %-22s %s\n", "", "driver (rtplc:gpio-io)", "bare wait/read loop", "driver / bare");
  std::printf("  %-34s %-22s %-22s\n", "pulses counted",
              fmt::format("{} of {}", fd.taken, fd.sent).c_str(), fmt::format("{} of {}", fb.taken, fb.sent).c_str());
  std::printf("  %-34s %-22s %-22s %.1fx\n", "CPU per pulse (edge thread)", per_item(fd.cpu_ns, fd.taken).c_str(),
              per_item(fb.cpu_ns, fb.taken).c_str(),
              static_cast<double>(fd.cpu_ns) / static_cast<double>(fd.taken ? fd.taken : 1) /
                  std::max(1e-9, static_cast<double>(fb.cpu_ns) / static_cast<double>(fb.taken ? fb.taken : 1)));
  auto per_core = [](const StreamRow& r) {
    return r.cpu_ns > 0 ? rate_text(static_cast<double>(r.taken) / (static_cast<double>(r.cpu_ns) / 1e9)) : "-";
  };
  std::printf("  %-34s %-22s %-22s\n", "pulses/s per core of that thread", per_core(fd).c_str(), per_core(fb).c_str());
  std::printf("  %-34s %-22s %-22s\n", "pulses/s the producer reached", rate_text(fd.produced_rate).c_str(),
              rate_text(fb.produced_rate).c_str());
  if (fd.taken != fd.sent || fb.taken != fb.sent) {
    std::printf("  FAILED: a pulse was not counted with an unbounded queue\n");
    ++failed;
  }

  std::printf("\nGPIO paced: pulses through an event queue of %u per line (full: the edge is dropped)\n",
              o.gpio_queue);
  print_stream_header("pulses", "driver (rtplc:gpio-io)", "bare wait/read loop");
  double best_d = 0, best_b = 0;
  for (size_t i = 1; i < plan.size(); ++i) {
    print_stream_row(plan[i].label.c_str(), drv[i], &bare[i]);
    if (drv[i].lost() == 0) best_d = std::max(best_d, drv[i].produced_rate);
    if (bare[i].lost() == 0) best_b = std::max(best_b, bare[i].produced_rate);
  }
  for (size_t i = 0; i < plan.size(); ++i) {
    if (drv[i].unaccounted() != 0 || bare[i].unaccounted() != 0 || !drv[i].drained || !bare[i].drained) {
      std::printf("  FAILED (%s): pulses unaccounted for (neither counted nor dropped by the queue)\n",
                  plan[i].label.c_str());
      ++failed;
    }
  }
  if (drv[1].lost() != 0) {
    std::printf("  FAILED: the driver lost %llu pulses at the paced rate\n",
                static_cast<unsigned long long>(drv[1].lost()));
    ++failed;
  }
  std::printf("  counted without loss up to (of the rates tried): driver %s, bare loop %s\n", rate_text(best_d).c_str(),
              rate_text(best_b).c_str());
  // What the task sees: the image's count is the published one, every pulse
  // generated less those the bounded queue dropped.
  uint64_t dropped_total = 0;
  for (const StreamRow& r : drv) dropped_total += r.dropped;
  const bool image_ok = image_final == static_cast<double>(published_final) &&
                        published_final + dropped_total == generated_total;
  std::printf("  the image's dpi channel reads %.0f = %llu generated - %llu dropped by the queue%s\n", image_final,
              static_cast<unsigned long long>(generated_total), static_cast<unsigned long long>(dropped_total),
              image_ok ? "" : "  <- FAILED");
  failed += !image_ok;
  if (bridge_cpu >= 0 && wall > 0) {
    std::printf("  the bridge thread (1 ms cycle) used %.1f%% of a core meanwhile\n",
                100.0 * static_cast<double>(bridge_cpu) / 1e9 / wall);
  }
  return failed;
}

}  // namespace rtplc::bench
