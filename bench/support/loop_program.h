// The benchmark workload, shared by the executor and runtime benchmarks:
// replicated control loops in the spirit of the anchors' MatIEC workload — a
// set-point, a measurement filter, error, PI, derivative on the measurement,
// limit, a first-order plant, the output, and a small logic chain (enable,
// on-delay timer, NOT, counter, alarm output). 14 blocks per loop.
#pragma once

#include <string>

namespace rtplc::bench {

inline constexpr int kBlocksPerLoop = 14;

// An FBD program of `loops` loops (715 loops = 10,010 blocks). `task` > 0 gives
// a copy of its own for one of several tasks in one runtime: its outputs on
// processor p<task>, its set-points on modules d<2 task>, d<2 task + 1>, every
// label prefixed "T<task>_" (one writer per channel, one label per channel).
inline std::string loop_program(int loops, double stime = 0.001, int task = 0) {
  const std::string p = "p" + std::to_string(task);
  const std::string d_sp = "d" + std::to_string(2 * task);
  const std::string d_en = "d" + std::to_string(2 * task + 1);
  const std::string tag = task > 0 ? "T" + std::to_string(task) + "_" : "";
  std::string s = "/* generated: " + std::to_string(loops) + " replicated PID loops */\n%%\n";
  s += "stime(" + std::to_string(stime) + ")\n";
  for (int i = 0; i < loops; ++i) {
    const int b = i * 20;
    auto F = [&](int k) { return "F" + std::to_string(b + k); };
    auto D = [&](int k) { return "D" + std::to_string(b + k); };
    const std::string n = std::to_string(i);
    s += F(0) + " = asp(" + d_sp + ", c" + n + ", 50, \"" + tag + "SP" + n + "\")\n";
    s += F(1) + " = filt(" + F(7) + ", 0.5)\n";  // measurement: last cycle's plant output
    s += F(2) + " = sub(" + F(0) + ", " + F(1) + ")\n";
    s += F(3) + " = epi(" + F(2) + ", 2, 5)\n";
    s += F(4) + " = derv(" + F(1) + ", 0.2)\n";
    s += F(5) + " = sub(" + F(3) + ", " + F(4) + ")\n";
    s += F(6) + " = lim(" + F(5) + ", 0, 100)\n";
    s += F(7) + " = filt(" + F(6) + ", 3)\n";  // the plant: a first-order lag
    s += "dao(" + F(6) + ", " + p + ", d0, c" + n + ", \"" + tag + "MV" + n + "\")\n";
    s += D(9) + " = dsp(" + d_en + ", c" + n + ", 1, \"" + tag + "EN" + n + "\")\n";
    s += D(10) + " = time(" + D(9) + ", 0.05)\n";
    s += D(11) + " = not(" + D(9) + ")\n";
    s += D(12) + " = cnt(" + D(10) + ", " + D(11) + ", 10)\n";
    s += "ddo(" + D(12) + ", " + p + ", d1, c" + n + ", \"" + tag + "ALM" + n + "\")\n";
  }
  s += "END\n";
  return s;
}

}  // namespace rtplc::bench
