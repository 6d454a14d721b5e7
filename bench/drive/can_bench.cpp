// bench_drive, CAN half (see bench_drive.cpp): the can driver over the fake
// bus with a drive-like receive map, beside hand-written references.
//
// Decode: the bridge's receive path as the runtime runs it (CanDriver::cycle:
// each frame's last sample from its snapshot slot, its timeout, every signal
// unpacked by its layout and put into the input region with quality and
// timestamp, the snapshot published) on the calling thread, after the I/O
// thread took one frame of each id; vs the same 31 signals decoded by code
// written for exactly this map (memcpy, shifts, scale) into a double array.
// Both on one thread, CPU by CLOCK_THREAD_CPUTIME_ID. The decoded values are
// compared: any difference is a failed count.
//
// Stream: the driver started as the runtime starts it (bridge thread every
// 1 ms, I/O thread at the helper priority), frames pushed by this thread
// through the fake bus, whose port queue drops what does not fit (as a
// socket with a full receive buffer does); then a bare loop (one thread:
// recv, count) on the same bus. Per rate: frames taken by the consumer,
// dropped by the queue, and the consumer thread's CPU per frame.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>

#include "bench/drive/drive_bench.h"
#include "config/config.h"
#include "io/drivers/can/config.h"
#include "io/drivers/can/driver.h"
#include "io/drivers/can/fake_bus.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/rt_thread.h"

namespace rtplc::bench {
namespace {

using can::Frame;

// Two drives' status frames (CANopen-style TPDOs: speed, current, status,
// temperature, torque), a position/velocity frame, a float64 frame in
// Motorola order, an engine frame (J1939 EEC1, 29-bit id: bytes with
// offsets, a 16-bit speed), a 29-bit proprietary frame in big-endian, and
// eight digital feedback bytes: 7 frames, 31 signals.
const char* kCanConfig =
    "tasks:\n  - {name: t, program: p.fbd}\n"
    "drivers:\n  - kind: can\n    name: epc\n    period: 1ms\n    interface: vcan0\n"
    "    receive:\n"
    "      - id: 0x181\n        signals:\n"
    "          - {channel: p0.d1.c0, byte: 0, length: 2, type: signed, scale: 0.1}\n"
    "          - {channel: p0.d1.c1, byte: 2, length: 2, type: signed, scale: 0.01}\n"
    "          - {channel: p0.d1.c2, byte: 4}\n"
    "          - {channel: p0.d1.c3, byte: 5, offset: -40}\n"
    "          - {channel: p0.d1.c4, byte: 6, length: 2, type: signed, scale: 0.1}\n"
    "      - id: 0x182\n        signals:\n"
    "          - {channel: p0.d2.c0, byte: 0, length: 2, type: signed, scale: 0.1}\n"
    "          - {channel: p0.d2.c1, byte: 2, length: 2, type: signed, scale: 0.01}\n"
    "          - {channel: p0.d2.c2, byte: 4}\n"
    "          - {channel: p0.d2.c3, byte: 5, offset: -40}\n"
    "          - {channel: p0.d2.c4, byte: 6, length: 2, type: signed, scale: 0.1}\n"
    "      - id: 0x281\n        signals:\n"
    "          - {channel: p0.d3.c0, byte: 0, length: 4, type: signed, scale: 0.001}\n"
    "          - {channel: p0.d3.c1, byte: 4, length: 4, type: float}\n"
    "      - id: 0x381\n        signals:\n"
    "          - {channel: p0.d4.c0, byte: 0, length: 8, type: float, order: big}\n"
    "      - id: 0x0CF00400\n        signals:\n"
    "          - {channel: p1.d1.c0, byte: 0}\n"
    "          - {channel: p1.d1.c1, byte: 1, offset: -125}\n"
    "          - {channel: p1.d1.c2, byte: 2, offset: -125}\n"
    "          - {channel: p1.d1.c3, byte: 3, length: 2, scale: 0.125}\n"
    "          - {channel: p1.d1.c4, byte: 5}\n"
    "          - {channel: p1.d1.c5, byte: 6}\n"
    "          - {channel: p1.d1.c6, byte: 7, offset: -125}\n"
    "      - id: 0x18FF50E5\n        signals:\n"
    "          - {channel: p1.d2.c0, byte: 0, length: 2, order: big, scale: 0.1}\n"
    "          - {channel: p1.d2.c1, byte: 2, length: 2, type: signed, order: big, scale: 0.01}\n"
    "          - {channel: p1.d2.c2, byte: 4, length: 4, order: big}\n"
    "      - id: 0x481\n        signals:\n"
    "          - {channel: p2.d1.c0, byte: 0}\n"
    "          - {channel: p2.d1.c1, byte: 1}\n"
    "          - {channel: p2.d1.c2, byte: 2}\n"
    "          - {channel: p2.d1.c3, byte: 3}\n"
    "          - {channel: p2.d1.c4, byte: 4}\n"
    "          - {channel: p2.d1.c5, byte: 5}\n"
    "          - {channel: p2.d1.c6, byte: 6}\n"
    "          - {channel: p2.d1.c7, byte: 7}\n";

constexpr uint32_t kIds[] = {0x181, 0x182, 0x281, 0x381, 0x0CF00400, 0x18FF50E5, 0x481};
constexpr size_t kFrames = std::size(kIds);
constexpr uint32_t kSignals = 31;
constexpr size_t kSets = 64;  // distinct frame contents the reference cycles through

// Deterministic bytes: frame set s, frame k.
Frame make_frame(size_t k, uint64_t s) {
  Frame f;
  f.id = kIds[k];
  f.extended = f.id > can::kMaxStandardId;
  f.len = 8;
  uint64_t x = (s + 1) * 0x9E3779B97F4A7C15ull ^ (k + 1) * 0xBF58476D1CE4E5B9ull;
  for (uint8_t& b : f.data) {
    x ^= x >> 29;
    x *= 0x94D049BB133111EBull;
    b = static_cast<uint8_t>(x >> 56);
  }
  if (k == 2) {  // a finite float32 velocity in bytes 4..7
    const float v = static_cast<float>(static_cast<int>(s % 2000) - 1000) * 0.37f;
    std::memcpy(f.data + 4, &v, 4);
  }
  if (k == 3) {  // a finite float64 in Motorola order
    const double v = static_cast<double>(s) * 12.5 - 100.0;
    uint64_t bits = 0;
    std::memcpy(&bits, &v, 8);
    for (int i = 0; i < 8; ++i) f.data[i] = static_cast<uint8_t>(bits >> (56 - 8 * i));
  }
  return f;
}

// ---- the reference: this map's decode written by hand --------------------------

inline int16_t le_s16(const uint8_t* p) {
  int16_t v;
  std::memcpy(&v, p, 2);  // x86 is little-endian
  return v;
}
inline uint16_t be_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }

[[gnu::noinline]] void reference_decode(const Frame* f, double* out) noexcept {
  for (int d = 0; d < 2; ++d) {  // 0x181, 0x182
    const uint8_t* p = f[d].data;
    double* o = out + 5 * d;
    o[0] = le_s16(p) * 0.1;
    o[1] = le_s16(p + 2) * 0.01;
    o[2] = p[4];
    o[3] = p[5] - 40.0;
    o[4] = le_s16(p + 6) * 0.1;
  }
  {  // 0x281
    const uint8_t* p = f[2].data;
    int32_t pos;
    float vel;
    std::memcpy(&pos, p, 4);
    std::memcpy(&vel, p + 4, 4);
    out[10] = pos * 0.001;
    out[11] = vel;
  }
  {  // 0x381: float64, big-endian
    uint64_t bits;
    std::memcpy(&bits, f[3].data, 8);
    bits = __builtin_bswap64(bits);
    std::memcpy(&out[12], &bits, 8);
  }
  {  // EEC1
    const uint8_t* p = f[4].data;
    out[13] = p[0];
    out[14] = p[1] - 125.0;
    out[15] = p[2] - 125.0;
    uint16_t rpm;
    std::memcpy(&rpm, p + 3, 2);
    out[16] = rpm * 0.125;
    out[17] = p[5];
    out[18] = p[6];
    out[19] = p[7] - 125.0;
  }
  {  // 0x18FF50E5, big-endian
    const uint8_t* p = f[5].data;
    out[20] = be_u16(p) * 0.1;
    out[21] = static_cast<int16_t>(be_u16(p + 2)) * 0.01;
    out[22] = static_cast<uint32_t>(p[4]) << 24 | static_cast<uint32_t>(p[5]) << 16 |
              static_cast<uint32_t>(p[6]) << 8 | p[7];
  }
  for (int i = 0; i < 8; ++i) out[23 + i] = f[6].data[i];  // digital feedback
}

// ---- the driver as the runtime lays it out ----------------------------------------

struct CanRig {
  DriverBench base;
  can::FakeBus bus;
  std::unique_ptr<can::CanDriver> driver;

  CanRig(const Options& o, int64_t period_ns) {
    prepare_driver_bench(base, "CAN", kCanConfig, "epc", kSignals, 64, period_ns, o);
    driver = std::make_unique<can::CanDriver>(base.setup, bus.transport());
  }
  bool wait_received(uint64_t n) {
    for (int i = 0; i < 20000 && driver->counters().frames_rx < n; ++i) {
      std::this_thread::sleep_for(std::chrono::microseconds(250));
    }
    return driver->counters().frames_rx >= n;
  }
};

// ---- 1. decode -----------------------------------------------------------------

int decode(const Options& o) {
  int failed = 0;
  CanRig rig(o, kernel_rt::kNsPerMs);
  if (auto r = rig.driver->start_io(); !r) {
    std::fprintf(stderr, "bench_drive: %s\n", r.error().c_str());
    return 1;
  }
  Frame set0[kFrames];
  for (size_t k = 0; k < kFrames; ++k) {
    set0[k] = make_frame(k, 0);
    rig.bus.inject(set0[k]);
  }
  if (!rig.wait_received(kFrames)) {
    std::printf("  FAILED: the I/O thread took %llu of %zu frames\n",
                static_cast<unsigned long long>(rig.driver->counters().frames_rx), kFrames);
    return 1;
  }
  const int64_t cycles = std::max<int64_t>(o.decode_cycles, 1000);
  const int64_t now0 = kernel_rt::monotonic_now_ns();
  for (int64_t i = 0; i < 2000; ++i) rig.driver->cycle_now(now0 + i);  // warm caches
  const int64_t d0 = self_cpu_ns();
  for (int64_t i = 0; i < cycles; ++i) rig.driver->cycle_now(now0 + 2000 + i);
  const int64_t driver_ns = self_cpu_ns() - d0;

  std::vector<Frame> sets(kSets * kFrames);
  for (size_t s = 0; s < kSets; ++s) {
    for (size_t k = 0; k < kFrames; ++k) sets[s * kFrames + k] = make_frame(k, s);
  }
  double out[kSignals] = {};
  for (int64_t i = 0; i < 2000; ++i) reference_decode(&sets[(static_cast<size_t>(i) % kSets) * kFrames], out);
  const int64_t r0 = self_cpu_ns();
  for (int64_t i = 0; i < cycles; ++i) {
    reference_decode(&sets[(static_cast<size_t>(i) % kSets) * kFrames], out);
    asm volatile("" : : "r"(out) : "memory");  // the values are used
  }
  const int64_t ref_ns = self_cpu_ns() - r0;

  // The driver's values against the reference's for the frames it holds.
  reference_decode(set0, out);
  uint32_t idx[kSignals];
  double got[kSignals];
  Quality q[kSignals];
  for (uint32_t i = 0; i < kSignals; ++i) idx[i] = i;
  int mismatches = 0;
  if (!rig.base.image.read_values(1, idx, kSignals, got, 8, nullptr, q)) {
    std::printf("  FAILED: no consistent snapshot of the driver's region\n");
    ++failed;
  } else {
    for (uint32_t i = 0; i < kSignals; ++i) {
      const bool same = std::fabs(got[i] - out[i]) <= 1e-12 * std::max(1.0, std::fabs(out[i]));
      if (!same || q[i] != Quality::kGood) {
        ++mismatches;
        std::printf("  MISMATCH signal %u: driver %.17g (%s), reference %.17g\n", i, got[i],
                    q[i] == Quality::kGood ? "good" : "not good", out[i]);
      }
    }
    failed += mismatches != 0;
  }
  const auto frames = static_cast<double>(cycles) * kFrames;
  const double drv_fps = frames / (static_cast<double>(driver_ns) / 1e9);
  const double ref_fps = frames / (static_cast<double>(ref_ns) / 1e9);
  std::printf("\nCAN decode: %zu frames, %u signals (1..8 bytes, both byte orders, int/float, scale/offset), %lld "
              "rounds of all %zu frames, one thread\n",
              kFrames, kSignals, static_cast<long long>(cycles), kFrames);
  std::printf("  %-34s %-20s %-20s %s\n", "", "driver (bridge)", "hand-written", "driver / hand-written");
  std::printf("  %-34s %-20s %-20s %.1fx\n", "CPU per frame", per_item(driver_ns, static_cast<uint64_t>(frames)).c_str(),
              per_item(ref_ns, static_cast<uint64_t>(frames)).c_str(),
              static_cast<double>(driver_ns) / std::max<double>(1.0, static_cast<double>(ref_ns)));
  std::printf("  %-34s %-20s %-20s %.3f\n", "frames decoded per second per core", rate_text(drv_fps).c_str(),
              rate_text(ref_fps).c_str(), drv_fps / ref_fps);
  std::printf("  %-34s %-20s\n", "CPU per bridge cycle (7 frames)", per_item(driver_ns, static_cast<uint64_t>(cycles)).c_str());
  std::printf("  values: %u of %u signals equal to the reference's, all good%s\n", kSignals - static_cast<uint32_t>(mismatches),
              kSignals, mismatches ? "  <- FAILED" : "");
  std::printf("  (the driver's cycle also reads its slots, checks each frame's timeout, writes quality and\n"
              "   timestamp per channel and publishes one snapshot; the reference only computes the doubles)\n");
  return failed;
}

// ---- 2. stream ----------------------------------------------------------------

// A bare consumer: one thread, recv and count, on its own port of the bus.
struct BareLoop {
  std::atomic<uint64_t> taken{0};
  std::atomic<pid_t> tid{0};
  std::atomic<bool> stop{false};
  kernel_rt::RtThread thread;
  can::Port port;

  bool start(can::FakeBus& bus, int priority) {
    std::vector<can::IdFilter> filters;
    for (uint32_t id : kIds) filters.push_back({id, id > can::kMaxStandardId, can::kMaxExtendedId});
    auto p = can::Port::open(bus.transport(), "vcan0", filters, true);
    if (!p) return false;
    port = std::move(*p);
    kernel_rt::ThreadSpec spec;
    spec.name = "bare-can";
    spec.fifo_priority = priority;
    auto t = kernel_rt::start_thread(spec, [this] {
      tid.store(current_tid());
      Frame f;
      int err = 0;
      uint64_t n = 0;
      while (!stop.load(std::memory_order_relaxed)) {
        if (port.recv(f, kernel_rt::kNsPerMs, &err) == can::RecvResult::kFrame) taken.store(++n, std::memory_order_relaxed);
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
    port.close();
  }
};

struct StreamPlan {
  const char* label;
  double rate;  // 0: flat out
  uint64_t n;
};

std::vector<StreamPlan> can_plan(const Options& o) {
  auto count = [&](double base) { return static_cast<uint64_t>(std::max(200.0, base * o.scale)); };
  std::vector<StreamPlan> p;
  // The paced run lasts what --paced-seconds says, whatever the scale.
  p.push_back({"paced", o.can_paced_rate, static_cast<uint64_t>(std::max(100.0, o.can_paced_rate * o.paced_seconds))});
  for (double r : {1000.0, 4000.0, 16000.0, 64000.0, 256000.0}) p.push_back({nullptr, r, count(r * 0.5)});
  p.push_back({"flat out", 0, count(200000)});
  return p;
}

int stream(const Options& o) {
  int failed = 0;
  const std::vector<StreamPlan> plan = can_plan(o);
  auto producer = [](can::FakeBus& bus) {
    return [&bus](uint64_t i) {
      Frame f = make_frame(i % kFrames, i / kFrames % kSets);
      bus.inject(f);
    };
  };
  std::vector<StreamRow> driver_rows, bare_rows;
  int64_t bridge_cpu = -1;
  double stream_wall = 0;
  std::string io_policy = "not found", bare_policy = "not found";
  {
    CanRig rig(o, kernel_rt::kNsPerMs);
    rig.bus.limit_rx(o.can_queue);
    const int64_t first = kernel_rt::monotonic_now_ns() + 2 * kernel_rt::kNsPerMs;
    if (auto r = rig.driver->start(first); !r) {
      std::fprintf(stderr, "bench_drive: %s\n", r.error().c_str());
      return 1;
    }
    const pid_t io_tid = find_task("rtplc:can-io");
    const pid_t bridge_tid = find_task("rtplc:can");
    // counters() reads a snapshot slot; a rare miss returns zeros: the count
    // only grows, so keep the highest seen.
    uint64_t seen_rx = 0;
    Consumer c{[&] { return seen_rx = std::max(seen_rx, rig.driver->counters().frames_rx); },
               [&] { return rig.bus.rx_dropped(); },
               [&] { return io_tid ? task_cpu_ns(io_tid) : -1; }};
    if (io_tid) io_policy = policy_text(io_tid);
    const int64_t b0 = bridge_tid ? task_cpu_ns(bridge_tid) : -1;
    const int64_t w0 = kernel_rt::monotonic_now_ns();
    for (const StreamPlan& s : plan) driver_rows.push_back(run_stream(s.rate, s.n, producer(rig.bus), c));
    stream_wall = static_cast<double>(kernel_rt::monotonic_now_ns() - w0) / 1e9;
    if (bridge_tid && b0 >= 0) bridge_cpu = task_cpu_ns(bridge_tid) - b0;
    rig.driver->request_stop();
    rig.driver->join();
  }
  {
    can::FakeBus bus;
    bus.limit_rx(o.can_queue);
    BareLoop bare;
    if (!bare.start(bus, o.helper_priority)) {
      std::fprintf(stderr, "bench_drive: the bare CAN loop did not start\n");
      return 1;
    }
    Consumer c{[&] { return bare.taken.load(std::memory_order_relaxed); }, [&] { return bus.rx_dropped(); },
               [&] { return task_cpu_ns(bare.tid.load()); }};
    bare_policy = policy_text(bare.tid.load());
    for (const StreamPlan& s : plan) bare_rows.push_back(run_stream(s.rate, s.n, producer(bus), c));
    bare.end();
  }
  std::printf("\nCAN stream: frames of the 7 ids pushed through the fake bus, a receive queue of %u frames per port "
              "(full: dropped)\n",
              o.can_queue);
  std::printf("  consumers: the I/O thread %s, the bare loop %s; the producer is this thread\n", io_policy.c_str(),
              bare_policy.c_str());
  print_stream_header("frames", "driver I/O thread (rtplc:can-io)", "bare recv loop");
  double best_driver = 0, best_bare = 0;
  for (size_t i = 0; i < plan.size(); ++i) {
    const std::string label = plan[i].label ? plan[i].label : rate_text(plan[i].rate);
    print_stream_row(label.c_str(), driver_rows[i], &bare_rows[i]);
    const StreamRow& d = driver_rows[i];
    const StreamRow& b = bare_rows[i];
    if (d.lost() == 0) best_driver = std::max(best_driver, d.produced_rate);
    if (b.lost() == 0) best_bare = std::max(best_bare, b.produced_rate);
    if (d.unaccounted() != 0 || b.unaccounted() != 0 || !d.drained || !b.drained) {
      std::printf("  FAILED: frames unaccounted for (neither taken nor dropped)\n");
      ++failed;
    }
  }
  const StreamRow& paced = driver_rows.front();
  if (paced.lost() != 0) {
    std::printf("  FAILED: the driver lost %llu frames at the paced rate\n",
                static_cast<unsigned long long>(paced.lost()));
    ++failed;
  }
  std::printf("  lossless up to (of the rates tried): driver %s, bare loop %s\n", rate_text(best_driver).c_str(),
              rate_text(best_bare).c_str());
  if (bridge_cpu >= 0 && stream_wall > 0) {
    std::printf("  the bridge thread (1 ms cycle, decodes each frame's last data) used %.1f%% of a core meanwhile\n",
                100.0 * static_cast<double>(bridge_cpu) / 1e9 / stream_wall);
  }
  const StreamRow& flat = driver_rows.back();
  if (flat.taken > 0 && flat.cpu_ns > 0) {
    std::printf("  flat out the I/O thread took %s per core (its CPU; the fake bus's mutex and condition\n"
                "  variable are most of it, a SocketCAN recv() is a system call instead)\n",
                rate_text(static_cast<double>(flat.taken) / (static_cast<double>(flat.cpu_ns) / 1e9)).c_str());
  }
  return failed;
}

}  // namespace

int run_can(const Options& o) {
  std::printf("\n== CAN (kind: can) over the fake bus ==\n");
  std::fflush(stdout);
  int failed = decode(o);
  std::fflush(stdout);
  failed += stream(o);
  return failed;
}

}  // namespace rtplc::bench
