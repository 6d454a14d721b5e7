// A pair of connected ptys from socat, the serial line of the RTU tests: what
// one end writes the other reads. Links `a` and `b` in a fresh directory;
// socat is stopped when the pair goes. available() is false (and why() says
// why) when socat is not installed, so a test can skip. fake_rtu_line.h puts
// our fake slave on one end.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

namespace rtplc::modbus::testing {

class PtyPair {
 public:
  PtyPair() {
    if (std::system("command -v socat >/dev/null 2>&1") != 0) {
      why_ = "socat is not installed (scripts/setup-deps installs it)";
      return;
    }
    char tmpl[] = "/tmp/rtplc-pty-XXXXXX";
    if (mkdtemp(tmpl) == nullptr) {
      why_ = "cannot make a temporary directory";
      return;
    }
    dir_ = tmpl;
    a_ = dir_ + "/a";
    b_ = dir_ + "/b";
    pid_ = fork();
    if (pid_ == 0) {
      const std::string pa = "pty,raw,echo=0,link=" + a_;
      const std::string pb = "pty,raw,echo=0,link=" + b_;
      execlp("socat", "socat", pa.c_str(), pb.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    for (int i = 0; i < 500 && !(exists(a_) && exists(b_)); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (!(exists(a_) && exists(b_))) why_ = "socat made no pty pair";
  }
  ~PtyPair() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
    if (!dir_.empty()) {
      unlink(a_.c_str());
      unlink(b_.c_str());
      rmdir(dir_.c_str());
    }
  }
  PtyPair(const PtyPair&) = delete;
  PtyPair& operator=(const PtyPair&) = delete;

  bool available() const { return why_.empty(); }
  const std::string& why() const { return why_; }
  const std::string& a() const { return a_; }  // the slave's end
  const std::string& b() const { return b_; }  // the master's end

 private:
  static bool exists(const std::string& p) { return access(p.c_str(), F_OK) == 0; }
  std::string dir_, a_, b_, why_;
  pid_t pid_ = -1;
};

// A child process (pymodbus), stopped when this goes.
class Child {
 public:
  template <class... Args>
  explicit Child(const char* path, Args... args) {
    pid_ = fork();
    if (pid_ == 0) {
      execl(path, path, args..., static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~Child() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

 private:
  pid_t pid_ = -1;
};

inline bool have_pymodbus() { return std::system("/usr/bin/python3 -c 'import pymodbus' >/dev/null 2>&1") == 0; }

}  // namespace rtplc::modbus::testing
