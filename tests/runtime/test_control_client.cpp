// The control client takes an answer only when it is whole: a peer that says
// "OK" and some lines and then closes (a runtime that died mid-answer) makes
// the request fail, saying the outcome is unknown, never pass as success.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <string>
#include <thread>

#include "sched/control.h"
#include "tests/support/scratch.h"

namespace rtplc::sched {
namespace {

// Serves one connection on `path`: reads the request line, writes `answer`, closes.
class OneShotPeer {
 public:
  OneShotPeer(const std::string& path, std::string answer) : answer_(std::move(answer)) {
    fd_ = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
    ok_ = bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 && listen(fd_, 1) == 0;
    thread_ = std::thread([this] {
      const int c = accept(fd_, nullptr, nullptr);
      if (c < 0) return;
      char ch = 0;
      while (read(c, &ch, 1) == 1 && ch != '\n') {
      }
      (void)!write(c, answer_.data(), answer_.size());
      close(c);
    });
  }
  ~OneShotPeer() {
    thread_.join();
    close(fd_);
  }
  bool ok() const { return ok_; }

 private:
  int fd_ = -1;
  bool ok_ = false;
  std::string answer_;
  std::thread thread_;
};

TEST(ControlClient, an_answer_cut_off_before_its_end_is_not_taken_for_success) {
  test::Scratch s("rtplc-ctl");
  const std::string sock = s.path("ctl.sock");
  {
    OneShotPeer peer(sock, "OK\nSetpoint = 60 (was 50)\n");  // no terminating "."
    ASSERT_TRUE(peer.ok());
    Result<std::string> r = control_request(sock, "set Setpoint 60", "", 5000);
    ASSERT_FALSE(r.ok()) << "a cut-off answer passed as: " << *r;
    EXPECT_NE(r.error().find("cut off"), std::string::npos) << r.error();
  }
  unlink(sock.c_str());
  {
    OneShotPeer peer(sock, "OK\nSetpoint = 60 (was 50)\n.\n");
    ASSERT_TRUE(peer.ok());
    Result<std::string> r = control_request(sock, "set Setpoint 60", "", 5000);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(*r, "Setpoint = 60 (was 50)\n");
  }
}

}  // namespace
}  // namespace rtplc::sched
