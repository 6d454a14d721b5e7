// Runs a driver's `rtplc` subcommands in process, as a user calls them.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

namespace rtplc::test {

// `rtplc ARGS...` on an app that `add` gave its commands; the exit code (0
// when the callback returned).
inline int run_cli(const std::function<void(CLI::App&)>& add, const std::vector<std::string>& args) {
  CLI::App app("rtplc");
  add(app);
  std::vector<std::string> all = {"rtplc"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<const char*> argv;
  for (const std::string& a : all) argv.push_back(a.c_str());
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    return e.get_exit_code();
  }
  return 0;
}

}  // namespace rtplc::test
