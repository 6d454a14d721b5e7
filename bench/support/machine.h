// The machine a benchmark ran on, printed beside its figures so a figure can be
// compared with another run's: the CPU model, how many CPUs, the kernel, and
// the load average (a figure taken at load 3 is not one taken on a quiet box).
#pragma once

#include <sys/utsname.h>

#include <fstream>
#include <string>
#include <thread>

namespace rtplc::bench {

// "Intel(R) Xeon(R) ... @ 2.20GHz, 2 CPUs, kernel 6.1.0-18-amd64"
inline std::string machine_description() {
  std::string model = "unknown CPU";
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) {
      const size_t colon = line.find(':');
      if (colon != std::string::npos) model = line.substr(line.find_first_not_of(" \t", colon + 1));
      break;
    }
  }
  utsname u{};
  const std::string kernel = ::uname(&u) == 0 ? u.release : "?";
  return model + ", " + std::to_string(std::thread::hardware_concurrency()) + " CPUs, kernel " + kernel;
}

// The 1, 5 and 15 minute load averages as /proc/loadavg gives them ("0.52 0.31 0.20").
inline std::string load_average() {
  std::ifstream f("/proc/loadavg");
  std::string a, b, c;
  f >> a >> b >> c;
  return f ? a + " " + b + " " + c : "unknown";
}

}  // namespace rtplc::bench
