// Block errors are said, not only counted: the control thread logs each
// erring block with its name, kind, source position and the registry's words
// for what counts as its error, rate-limited, and `status` shows the last one.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "kernel_rt/clock.h"
#include "tests/support/eventually.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::eventually;
using rtplc::testing::RuntimeFixture;

// F3 divides by a set-point that starts at 0: an error every cycle.
const char* kDivide =
    "%%\nF1 = dai(p0, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 0, \"Divisor\")\n"
    "F3 = div(F1, F2)\ndao(F3, p0, d0, c0, \"Out\")\nEND\n";
// The same program with the division one line lower.
const char* kDivideLater =
    "%%\nF1 = dai(p0, d0, c0, \"ProcVal\")\nF2 = asp(d0, c0, 0, \"Divisor\")\n\n"
    "F3 = div(F1, F2)\ndao(F3, p0, d0, c0, \"Out\")\nEND\n";

struct Log {
  std::vector<std::string> lines;
  size_t count(const std::string& s) const {
    size_t n = 0;
    for (const std::string& l : lines) n += l.find(s) != std::string::npos;
    return n;
  }
};

TEST(BlockErrors, each_erring_block_is_logged_with_its_position_and_reason_and_shown_in_status) {
  RuntimeFixture fx;
  const std::string file = fx.write("div.fbd", kDivide);
  auto rt = fx.start("tasks:\n  - {name: calc, program: div.fbd, period: 10ms}\ndrivers:\n  - kind: sim\n");
  ASSERT_NE(rt, nullptr);
  Log log;
  auto sink = [&](bool, const std::string& l) { log.lines.push_back(l); };
  const int64_t t0 = kernel_rt::monotonic_now_ns();
  ASSERT_TRUE(eventually([&] {
    rt->tick(sink);
    return log.count("block F3 (div)") > 0;
  })) << "no block error was logged";
  std::string first;
  for (const std::string& l : log.lines) {
    if (l.find("block F3 (div)") != std::string::npos) first = l;
  }
  EXPECT_NE(first.find("task calc: block F3 (div) at " + file + ":4:1"), std::string::npos) << first;
  EXPECT_NE(first.find("b = 0"), std::string::npos) << first;  // the registry's words
  const std::string status = rt->status();
  EXPECT_NE(status.find("last block error: F3 (div) at " + file + ":4:1"), std::string::npos) << status;

  // Every cycle errs, but the log is not flooded: after the first report the
  // gaps double from one second (so at most 2 + log2(1 + seconds) reports).
  ASSERT_TRUE(eventually([&] {
    rt->tick(sink);
    return rt->image().task_info(0).block_errors.load() >= 300;
  }));
  for (int i = 0; i < 10; ++i) rt->tick(sink);
  const double seconds = static_cast<double>(kernel_rt::monotonic_now_ns() - t0) / 1e9;
  const size_t reports = log.count("block F3 (div)");
  EXPECT_LE(static_cast<double>(reports), 2 + std::ceil(std::log2(1 + seconds)))
      << reports << " reports in " << seconds << " s";

  // A swapped-in program's first error is said at once, at its own position.
  ASSERT_TRUE(rt->swap("calc", kDivideLater, "later.fbd").ok());
  ASSERT_TRUE(eventually([&] {
    rt->tick(sink);
    return log.count("at later.fbd:5:1") > 0;
  })) << "the new program's error was not said";
  rt->stop();
}

}  // namespace
}  // namespace rtplc::sched
