// Loop-heavy Structured Text against the same arithmetic in hand-written C++,
// in the same binary and run (docs/st.md, "Loops"): per cycle, a bubble sort
// of 64 values, a CRC-16 (Modbus) over 256 bytes and a 1,000-step search, each
// refilled from a small linear congruential generator so every cycle has the
// same work. Both sides are checked to agree, then timed in interleaved rounds;
// the ratio is rtplc's time over C++'s (target <= 3), for the interpreter and for
// the native code rtplc compiles the same image into (blocks/native.h).
//
//   build/release/bench/bench_loops            (scripts/bench executor runs it)
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <string>
#include <vector>

#include "blocks/executor.h"
#include "blocks/native.h"
#include "lang/compiler.h"

namespace {

using namespace rtplc;

constexpr int kSort = 64, kCrc = 256, kSearch = 1000;

const char* kProgram = R"(PROGRAM Bench
  VAR
    ns AT %IW0 : INT;
    nc AT %IW1 : INT;
    nf AT %IW2 : INT;
    sum AT %QD0 : DINT;
    crc_out AT %QD1 : DINT;
    found_out AT %QD2 : DINT;
  END_VAR
  VAR
    a : ARRAY [0..63] OF DINT;
    data : ARRAY [0..255] OF DINT;
    i, j, k : INT;
    t, seed, crc, found, s : DINT;
  END_VAR
  seed := 7;
  FOR i := 0 TO ns - 1 DO
    seed := (seed * 75 + 74) MOD 65537;
    a[i] := seed MOD 1000;
  END_FOR;
  FOR i := 0 TO ns - 2 DO
    FOR j := 0 TO ns - 2 - i DO
      IF a[j] > a[j + 1] THEN
        t := a[j]; a[j] := a[j + 1]; a[j + 1] := t;
      END_IF;
    END_FOR;
  END_FOR;
  s := 0;
  FOR i := 0 TO ns - 1 DO
    s := s * 3 + a[i];
    s := s MOD 1000003;
  END_FOR;
  FOR i := 0 TO nc - 1 DO
    seed := (seed * 75 + 74) MOD 65537;
    data[i] := seed MOD 256;
  END_FOR;
  crc := 65535;
  FOR i := 0 TO nc - 1 DO
    crc := crc XOR data[i];
    FOR k := 1 TO 8 DO
      IF crc MOD 2 = 1 THEN crc := (crc / 2) XOR 40961; ELSE crc := crc / 2; END_IF;
    END_FOR;
  END_FOR;
  found := -1;
  FOR i := 0 TO nf - 1 DO
    IF found < 0 AND (i * 37 + 11) MOD 1000 = 998 THEN found := i; END_IF;
  END_FOR;
  sum := s;
  crc_out := crc;
  found_out := found;
END_PROGRAM
)";

struct Result3 {
  int64_t sum, crc, found;
};

// The same work by hand.
Result3 reference() {
  int64_t a[kSort];
  int64_t seed = 7;
  for (int i = 0; i < kSort; ++i) {
    seed = (seed * 75 + 74) % 65537;
    a[i] = seed % 1000;
  }
  for (int i = 0; i <= kSort - 2; ++i) {
    for (int j = 0; j <= kSort - 2 - i; ++j) {
      if (a[j] > a[j + 1]) std::swap(a[j], a[j + 1]);
    }
  }
  int64_t s = 0;
  for (int i = 0; i < kSort; ++i) s = (s * 3 + a[i]) % 1000003;
  int64_t data[kCrc];
  for (int i = 0; i < kCrc; ++i) {
    seed = (seed * 75 + 74) % 65537;
    data[i] = seed % 256;
  }
  int64_t crc = 65535;
  for (int i = 0; i < kCrc; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc & 1) ? (crc >> 1) ^ 40961 : crc >> 1;
  }
  int64_t found = -1;
  for (int i = 0; i < kSearch; ++i) {
    if (found < 0 && (i * 37 + 11) % 1000 == 998) found = i;
  }
  return {s, crc, found};
}

double now_ns() {
  return static_cast<double>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
          .count());
}

}  // namespace

int main(int argc, char** argv) {
  lang::CompileOptions opt;
  opt.name = "bench_loops.st";
  const double c0 = now_ns();
  lang::CompileResult r = lang::compile_source(kProgram, opt);
  const double compile_ms = (now_ns() - c0) / 1e6;
  if (!r.ok()) {
    std::fprintf(stderr, "%s", r.diags.render("bench_loops.st", kProgram).c_str());
    return 1;
  }
  const TaskImage& img = *r.image;
  TaskArena arena(img);
  auto input = [&](const char* label, double v) {
    for (const Binding& b : img.bindings()) {
      if (b.dir != BindingDir::kOutput && std::string(img.str(b.label)) == label) arena.io_in[b.io_index] = v;
    }
  };
  auto output = [&](const char* label) {
    for (const Binding& b : img.bindings()) {
      if (b.dir == BindingDir::kOutput && std::string(img.str(b.label)) == label) return arena.io_out[b.io_index];
    }
    return -1e300;
  };
  input("ns", kSort);
  input("nc", kCrc);
  input("nf", kSearch);
  const ExecContext ctx = make_context(img, arena);
  execute_cycle(ctx);
  if (argc == 4) {  // a profile of one part: sizes ns nc nf, rtplc's side only
    input("ns", std::atof(argv[1]));
    input("nc", std::atof(argv[2]));
    input("nf", std::atof(argv[3]));
    const double t = now_ns();
    for (int c = 0; c < 200; ++c) execute_cycle(ctx);
    std::printf("%s %s %s: %.1f us per cycle\n", argv[1], argv[2], argv[3], (now_ns() - t) / 200 / 1e3);
    return 0;
  }
  const Result3 want = reference();
  const bool same = output("sum") == static_cast<double>(want.sum) && output("crc_out") == static_cast<double>(want.crc) &&
                    output("found_out") == static_cast<double>(want.found);
  if (!same || arena.loop_fault != 0) {
    std::fprintf(stderr, "bench_loops: rtplc and C++ disagree: sum %.0f/%lld crc %.0f/%lld found %.0f/%lld (fault %u)\n",
                 output("sum"), static_cast<long long>(want.sum), output("crc_out"),
                 static_cast<long long>(want.crc), output("found_out"), static_cast<long long>(want.found),
                 arena.loop_fault);
    return 1;
  }

  // The same image as native code, on its own arena, checked the same way.
  auto native = compile_native(img);
  if (!native.ok()) {
    std::fprintf(stderr, "bench_loops: %s\n", native.error().c_str());
    return 1;
  }
  TaskArena narena(img);
  ExecContext nctx = make_context(img, narena);
  nctx.native = (*native)->entry();
  narena.io_in = arena.io_in;  // the same image: the same input layout
  execute_cycle(nctx);
  if (narena.values != arena.values || narena.io_out != arena.io_out || narena.loop_fault != 0) {
    std::fprintf(stderr, "bench_loops: the native code and the interpreter disagree\n");
    return 1;
  }

  // Interleaved rounds: each times 200 cycles of one side; medians of 15.
  constexpr int kRounds = 15, kCycles = 200;
  std::vector<double> ours, natives, theirs;
  volatile int64_t sink = 0;
  for (int round = 0; round < kRounds; ++round) {
    double t = now_ns();
    for (int c = 0; c < kCycles; ++c) execute_cycle(ctx);
    ours.push_back((now_ns() - t) / kCycles);
    t = now_ns();
    for (int c = 0; c < kCycles; ++c) execute_cycle(nctx);
    natives.push_back((now_ns() - t) / kCycles);
    t = now_ns();
    for (int c = 0; c < kCycles; ++c) {
      const Result3 x = reference();
      sink = sink + x.sum + x.crc + x.found;
    }
    theirs.push_back((now_ns() - t) / kCycles);
  }
  std::sort(ours.begin(), ours.end());
  std::sort(natives.begin(), natives.end());
  std::sort(theirs.begin(), theirs.end());
  const double o = ours[kRounds / 2], nat = natives[kRounds / 2], h = theirs[kRounds / 2];
  const NativeStats& ns = (*native)->stats();
  std::printf("\n== ST loops vs hand-written C++ (sort 64, CRC-16 over 256 bytes, 1,000-step search; medians of %d) ==\n",
              kRounds);
  std::printf("  rtplc (%s body)  %9.1f us per cycle  (%zu instructions, %u runs, %.1f ms to compile)\n",
              executor_variant(), o / 1e3, img.code().size(), img.header().n_runs, compile_ms);
  std::printf("  rtplc native      %9.1f us per cycle  (%u runs compiled, %u interpreted, %.0f ms to compile)\n",
              nat / 1e3, ns.native_runs, ns.interpreted_runs, ns.compile_ms);
  std::printf("  hand-written C++  %9.1f us per cycle  (-O2, int64)\n", h / 1e3);
  std::printf("  ratio interpreter %9.2f\n", o / h);
  std::printf("  ratio native      %9.2f            (target <= 3.00)\n", nat / h);
  std::printf("  results           the same on every side (sum %lld, crc %lld, found %lld)\n",
              static_cast<long long>(want.sum), static_cast<long long>(want.crc), static_cast<long long>(want.found));
  return 0;
}
