// Forked unprivileged children for the kernel_rt tests.
#include "privilege_drop.h"

#include <grp.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace rtplc::kernel_rt::testing {

bool can_drop_privileges() {
  return geteuid() == 0;
}

ChildOutcome run_unprivileged(const ChildLimits& limits, const std::function<std::string()>& body) {
  ChildOutcome out;
  int fds[2];
  if (pipe(fds) != 0) {
    out.problem = "pipe failed";
    return out;
  }
  const pid_t pid = fork();
  if (pid < 0) {
    out.problem = "fork failed";
    close(fds[0]);
    close(fds[1]);
    return out;
  }
  if (pid == 0) {
    close(fds[0]);
    auto fail = [&](const char* what) {
      const std::string msg = std::string("!") + what + ": " + std::strerror(errno);
      (void)!write(fds[1], msg.data(), msg.size());
      _exit(3);
    };
    if (limits.memlock) {
      rlimit r{*limits.memlock, *limits.memlock};
      if (setrlimit(RLIMIT_MEMLOCK, &r) != 0) fail("setrlimit memlock");
    }
    if (limits.rtprio) {
      rlimit r{*limits.rtprio, *limits.rtprio};
      if (setrlimit(RLIMIT_RTPRIO, &r) != 0) fail("setrlimit rtprio");
    }
    if (setgroups(0, nullptr) != 0) fail("setgroups");
    if (setgid(65534) != 0) fail("setgid");
    if (setuid(65534) != 0) fail("setuid");
    const std::string result = "=" + body();
    (void)!write(fds[1], result.data(), result.size());
    _exit(0);
  }
  close(fds[1]);
  std::string data;
  char buf[1024];
  ssize_t n = 0;
  while ((n = read(fds[0], buf, sizeof buf)) > 0) data.append(buf, static_cast<size_t>(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!data.empty() && data.front() == '=') {
    out.ran = true;
    out.output = data.substr(1);
  } else {
    out.problem = data.empty() ? "child died without a word" : data.substr(1);
  }
  return out;
}

}  // namespace rtplc::kernel_rt::testing
