// The control client takes an answer only when it is whole: a peer that sends
// a frame header and part of the JSON it announced and then closes (a runtime
// that died mid-answer) makes the request fail, saying the outcome is unknown,
// never pass as success. A peer that does not speak the API is named as such.
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

// Serves one connection on `path`: reads the request's header line, writes `answer`, closes.
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

std::string framed(const std::string& json) {
  return "RTPLC-API 1 " + std::to_string(json.size()) + " 0\n" + json;
}

TEST(ControlClient, an_answer_cut_off_before_its_end_is_not_taken_for_success) {
  test::Scratch s("rtplc-ctl");
  const std::string sock = s.path("ctl.sock");
  const std::string whole =
      R"J({"v":1,"ok":true,"op":"set","result":{"label":"Setpoint","value":60,"was":50,"text":"Setpoint = 60 (was 50)"}})J";
  {
    OneShotPeer peer(sock, framed(whole).substr(0, framed(whole).size() - 20));  // the JSON's end is missing
    ASSERT_TRUE(peer.ok());
    Result<std::string> r = control_request(sock, "set Setpoint 60", "", 5000);
    ASSERT_FALSE(r.ok()) << "a cut-off answer passed as: " << *r;
    EXPECT_NE(r.error().find("cut off"), std::string::npos) << r.error();
  }
  unlink(sock.c_str());
  {
    OneShotPeer peer(sock, framed(whole));
    ASSERT_TRUE(peer.ok());
    Result<std::string> r = control_request(sock, "set Setpoint 60", "", 5000);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(*r, "Setpoint = 60 (was 50)\n");
  }
  unlink(sock.c_str());
  {
    // The old prose protocol's answer: not an API frame.
    OneShotPeer peer(sock, "OK\nSetpoint = 60 (was 50)\n.\n");
    ASSERT_TRUE(peer.ok());
    Result<std::string> r = control_request(sock, "set Setpoint 60", "", 5000);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().find("does not speak the rtplc operator API"), std::string::npos) << r.error();
  }
  unlink(sock.c_str());
  {
    // A refusal carries the runtime's message.
    OneShotPeer peer(sock, framed(R"J({"v":1,"ok":false,"op":"set","error":{"code":"forbidden","message":"uid 1001 is a viewer"}})J"));
    ASSERT_TRUE(peer.ok());
    Result<std::string> r = control_request(sock, "set Setpoint 60", "", 5000);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error(), "uid 1001 is a viewer");
  }
}

TEST(ControlClient, the_commands_words_become_typed_requests) {
  auto set = request_of_words("set SP 42.5");
  ASSERT_TRUE(set.ok());
  EXPECT_EQ(*set, (nlohmann::json{{"op", "set"}, {"args", {{"label", "SP"}, {"value", 42.5}}}}));
  // What is not a finite number goes as typed, for the runtime to refuse in its words.
  auto nan = request_of_words("force X nan");
  ASSERT_TRUE(nan.ok());
  EXPECT_EQ((*nan)["args"]["value"], "nan");
  auto swap = request_of_words("swap pid new.fbd 120 drop=A,B");
  ASSERT_TRUE(swap.ok());
  EXPECT_EQ((*swap)["args"], (nlohmann::json{{"task", "pid"}, {"name", "new.fbd"}, {"drop_outputs", {"A", "B"}}}));
  auto keep = request_of_words("trace-keep t1");
  ASSERT_TRUE(keep.ok());
  EXPECT_EQ((*keep)["op"], "trace_keep");
  EXPECT_FALSE(request_of_words("set SP").ok());
  EXPECT_FALSE(request_of_words("audit many").ok());
  EXPECT_FALSE(request_of_words("").ok());
}

}  // namespace
}  // namespace rtplc::sched
