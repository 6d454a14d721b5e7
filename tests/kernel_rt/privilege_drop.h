// Runs a piece of a test in a forked child that has given up root, so the tests can see what
// an unprivileged user gets (SCHED_OTHER fallback, refused mlockall) on a machine where the
// test itself runs as root.
#pragma once

#include <sys/resource.h>
#include <functional>
#include <optional>
#include <string>

namespace rtplc::kernel_rt::testing {

struct ChildLimits {
  std::optional<rlim_t> memlock;  // set soft and hard to this before dropping root
  std::optional<rlim_t> rtprio;
};

struct ChildOutcome {
  bool ran = false;     // the child reached `body` (false: fork or the drop failed)
  std::string output;   // what `body` returned
  std::string problem;  // why it did not run
};

// Forks; the child applies `limits`, switches to uid/gid 65534 (which clears every
// capability), runs `body` and sends its string back through a pipe.
ChildOutcome run_unprivileged(const ChildLimits& limits, const std::function<std::string()>& body);

// True when this process can drop privileges in a child (it is root).
bool can_drop_privileges();

}  // namespace rtplc::kernel_rt::testing
