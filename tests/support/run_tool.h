// Runs the built `rtplc` (or any shell command) and collects its exit code and
// output, for tests of the command line as a user meets it.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace rtplc::test {

struct ToolRun {
  int status = -1;  // the exit code; -1 when killed by a signal or not started
  std::string out;  // stdout and stderr together, in order
};

inline std::string rtplc_binary() { return std::string(RTPLC_BINARY_DIR) + "/rtplc"; }

// `command` through /bin/sh, stderr merged into stdout.
inline ToolRun run_shell(const std::string& command) {
  ToolRun r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// `rtplc ARGS` (ARGS as a shell would split them).
inline ToolRun run_tool(const std::string& args) { return run_shell(rtplc_binary() + " " + args); }

}  // namespace rtplc::test
