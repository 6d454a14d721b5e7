// The operator API (sched/operator_api.h): each op needs its role and a lower
// role is refused with the role it needs and nothing changed; a malformed
// request (not JSON, no op, mistyped arguments, another version, a frame that
// is not one) is refused with a code, never crashes the runtime; refusals and
// writes are in the audit trail with the caller's name and role.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "sched/control.h"
#include "tests/support/eventually.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using nlohmann::json;
using testing::RuntimeFixture;

const char* kTask = "tasks:\n  - {name: t, program: p.fbd, period: 10ms, setpoints: {SP: {min: 0, max: 100}}}\n";
const char* kProgram = "%%\nF1 = asp(d0, c0, 50, \"SP\")\ndao(F1, p0, d0, c0, \"OUT\")\nEND\n";

class OperatorApiTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fx_.write("p.fbd", kProgram);
    rt_ = fx_.start(kTask);
    ASSERT_NE(rt_, nullptr);
  }
  void TearDown() override {
    if (rt_) rt_->stop();
  }
  ApiAnswer ask(Role role, const json& request) {
    return rt_->api().call(Caller{"tester", 4242, role}, request);
  }
  double sp() { return rt_->image().read_channel(static_cast<uint32_t>(rt_->image().find_channel("SP"))).value; }
  std::string trail() {
    std::ifstream f(rt_->api().audit().path());
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  }
  RuntimeFixture fx_;
  std::unique_ptr<Runtime> rt_;
};

TEST_F(OperatorApiTest, each_op_needs_its_role_and_a_lower_one_changes_nothing) {
  const json set = {{"op", "set"}, {"args", {{"label", "SP"}, {"value", 60}}}};
  ApiAnswer a = ask(Role::kViewer, set);
  EXPECT_FALSE(a.ok);
  EXPECT_EQ(a.code, "forbidden");
  EXPECT_NE(a.message.find("needs the role operator"), std::string::npos) << a.message;
  EXPECT_EQ(sp(), 50);
  a = ask(Role::kNone, {{"op", "status"}});
  EXPECT_EQ(a.code, "forbidden");
  EXPECT_NE(a.message.find("tester is not an operator"), std::string::npos) << a.message;
  a = ask(Role::kOperator, set);
  ASSERT_TRUE(a.ok) << a.message;
  EXPECT_EQ(a.result["was"], 50);
  EXPECT_EQ(a.result["value"], 60);
  EXPECT_EQ(sp(), 60);
  // Force is an engineer's, stop an admin's.
  const json force = {{"op", "force"}, {"args", {{"label", "OUT"}, {"value", 1}}}};
  EXPECT_EQ(ask(Role::kOperator, force).code, "forbidden");
  EXPECT_TRUE(rt_->forces().empty());
  EXPECT_EQ(ask(Role::kEngineer, {{"op", "stop"}}).code, "forbidden");
  EXPECT_FALSE(rt_->api().stop_requested());
  EXPECT_TRUE(ask(Role::kEngineer, force).ok);
  EXPECT_EQ(rt_->forces().size(), 1u);
  EXPECT_TRUE(ask(Role::kAdmin, {{"op", "unforce_all"}}).ok);
  // A viewer reads status, whoami and the trail.
  a = ask(Role::kViewer, {{"op", "status"}});
  ASSERT_TRUE(a.ok);
  EXPECT_EQ(a.result["status"]["runtime"], rt_->name());
  a = ask(Role::kViewer, {{"op", "whoami"}});
  EXPECT_EQ(a.result["role"], "viewer");
  a = ask(Role::kViewer, {{"op", "values"}, {"args", {{"filter", "SP"}}}});
  ASSERT_TRUE(a.ok) << a.message;
  ASSERT_EQ(a.result["monitor"]["channels"].size(), 1u);
  EXPECT_EQ(a.result["monitor"]["channels"][0]["value"], 60);
  const std::string t = trail();
  EXPECT_NE(t.find("tester [viewer] set label=SP value=60: refused: "), std::string::npos) << t;
  EXPECT_NE(t.find("tester [operator] set label=SP value=60: SP = 60 (was 50)"), std::string::npos) << t;
  EXPECT_NE(t.find("tester [none] status: refused"), std::string::npos) << t;
}

TEST_F(OperatorApiTest, malformed_requests_are_refused_with_a_code_and_change_nothing) {
  EXPECT_EQ(ask(Role::kAdmin, json::array({1, 2})).code, "bad_request");
  EXPECT_EQ(ask(Role::kAdmin, {{"args", json::object()}}).code, "bad_request");
  EXPECT_EQ(ask(Role::kAdmin, {{"op", 7}}).code, "bad_request");
  EXPECT_EQ(ask(Role::kAdmin, {{"op", "launch"}}).code, "unknown_op");
  EXPECT_EQ(ask(Role::kAdmin, {{"op", "set"}, {"args", "SP=1"}}).code, "bad_request");
  EXPECT_EQ(ask(Role::kAdmin, {{"op", "set"}, {"args", {{"label", 5}, {"value", 1}}}}).code, "bad_request");
  EXPECT_EQ(ask(Role::kAdmin, {{"op", "set"}, {"args", {{"label", "SP"}}}}).code, "bad_request");
  EXPECT_EQ(ask(Role::kAdmin, {{"op", "set"}, {"args", {{"label", "SP"}, {"value", json::array()}}}}).code,
            "bad_request");
  ApiAnswer a = ask(Role::kAdmin, {{"op", "set"}, {"args", {{"label", "SP"}, {"value", "abc"}}}});
  EXPECT_NE(a.message.find("'abc' is not a number"), std::string::npos) << a.message;
  a = ask(Role::kAdmin, {{"op", "set"}, {"args", {{"label", "SP"}, {"value", 150}}}});
  EXPECT_EQ(a.code, "refused");
  EXPECT_NE(a.message.find("outside the range"), std::string::npos) << a.message;
  EXPECT_EQ(ask(Role::kAdmin, {{"op", "audit"}, {"args", {{"lines", 0}}}}).code, "bad_request");
  EXPECT_EQ(ask(Role::kAdmin, {{"op", "trace"}, {"args", {{"labels", json::array()}}}}).code, "bad_request");
  EXPECT_EQ(ask(Role::kAdmin, {{"op", "swap"}, {"args", {{"task", "t"}}}}).code, "bad_request");
  EXPECT_EQ(sp(), 50);
  EXPECT_TRUE(rt_->forces().empty());
}

// What arrives on the socket raw: a frame of another version, a line that is no
// frame, JSON that does not parse, bytes that are not UTF-8. Each is answered
// with a frame and an error code; the runtime answers `status` after them all.
std::string raw_exchange(const std::string& path, const std::string& bytes) {
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return "";
  }
  (void)!write(fd, bytes.data(), bytes.size());
  std::string out;
  char buf[4096];
  ssize_t n;
  while ((n = read(fd, buf, sizeof buf)) > 0) out.append(buf, static_cast<size_t>(n));
  close(fd);
  return out;
}

json answer_of(const std::string& framed) {
  const size_t nl = framed.find('\n');
  if (nl == std::string::npos) return json();
  return json::parse(framed.substr(nl + 1), nullptr, false);
}

TEST_F(OperatorApiTest, the_socket_answers_bad_frames_with_an_error_frame_and_keeps_serving) {
  ControlServer server(*rt_, [](bool, const std::string&) {});
  ASSERT_TRUE(server.start(rt_->socket_path()).ok());
  const std::string sock = rt_->socket_path();
  const std::string ping = R"({"op":"ping"})";
  json a = answer_of(raw_exchange(sock, "RTPLC-API 2 " + std::to_string(ping.size()) + " 0\n" + ping));
  EXPECT_EQ(a["error"]["code"], "version") << a;
  a = answer_of(raw_exchange(sock, "set SP 60\n"));
  EXPECT_EQ(a["error"]["code"], "bad_request") << a;
  EXPECT_NE(a["error"]["message"].get<std::string>().find("RTPLC-API 1"), std::string::npos) << a;
  a = answer_of(raw_exchange(sock, "RTPLC-API 1 9 0\n{\"op\": }}"));
  EXPECT_EQ(a["error"]["code"], "bad_request") << a;
  a = answer_of(raw_exchange(sock, "RTPLC-API 1 x 0\n"));
  EXPECT_EQ(a["error"]["code"], "bad_request") << a;
  // A label that is not UTF-8: refused, and the answer (which quotes it) is still JSON.
  const std::string odd = "{\"op\":\"set\",\"args\":{\"label\":\"S\xff\",\"value\":1}}";
  a = answer_of(raw_exchange(sock, "RTPLC-API 1 " + std::to_string(odd.size()) + " 0\n" + odd));
  EXPECT_FALSE(a.is_discarded());
  EXPECT_EQ(a.value("ok", true), false) << a;
  auto st = control_request(sock, "status", "", 3000);
  ASSERT_TRUE(st.ok()) << st.error();
  EXPECT_EQ(sp(), 50);
  server.stop();
}

TEST_F(OperatorApiTest, swap_check_reports_what_a_swap_would_do_and_changes_nothing) {
  const std::string v2 = "%%\nF1 = asp(d0, c0, 50, \"SP\")\nF2 = asp(d0, c1, 5, \"Bias\")\n"
                         "F3 = add(F1, F2)\nF4 = intg(F3, 1)\ndao(F4, p0, d0, c0, \"OUT\")\nEND\n";
  const json check = {{"op", "swap_check"}, {"args", {{"task", "t"}, {"name", "v2.fbd"}}}};
  EXPECT_EQ(rt_->api().call(Caller{"tester", 4242, Role::kOperator}, check, v2).code, "forbidden");
  const uint32_t channels = rt_->image().channel_count();
  ApiAnswer a = rt_->api().call(Caller{"tester", 4242, Role::kEngineer}, check, v2);
  ASSERT_TRUE(a.ok) << a.message;
  const std::string text = a.result["text"];
  EXPECT_NE(text.find("new channels: 1 (Bias)"), std::string::npos) << text;
  EXPECT_NE(text.find("new: "), std::string::npos) << text;
  EXPECT_NE(text.find("nothing was changed"), std::string::npos) << text;
  // Nothing entered the image, the store or the task.
  EXPECT_EQ(rt_->image().channel_count(), channels);
  EXPECT_LT(rt_->image().find_channel("Bias"), 0);
  EXPECT_EQ(rt_->image().task_info(0).swaps.load(), 0u);
  auto info = rt_->program_info("t");
  ASSERT_TRUE(info.ok());
  EXPECT_EQ(info->source, kProgram);
  EXPECT_LE(info->history.size(), 1u);
  // A program with errors: the compiler's errors with file:line:col, still nothing changed.
  a = rt_->api().call(Caller{"tester", 4242, Role::kEngineer}, check, "%%\nF1 = nope(1)\nEND\n");
  ASSERT_FALSE(a.ok);
  EXPECT_NE(a.message.find("v2.fbd:2:"), std::string::npos) << a.message;
  EXPECT_EQ(rt_->image().channel_count(), channels);
}

TEST_F(OperatorApiTest, program_op_lists_the_stored_versions_and_reads_any_of_them) {
  const std::string v2 = "%%\nF1 = asp(d0, c0, 50, \"SP\")\nF2 = mult(F1, F1)\ndao(F2, p0, d0, c0, \"OUT\")\nEND\n";
  ApiAnswer a = rt_->api().call(Caller{"tester", 4242, Role::kEngineer},
                                {{"op", "swap"}, {"args", {{"task", "t"}, {"name", "v2.fbd"}}}}, v2);
  ASSERT_TRUE(a.ok) << a.message;
  a = ask(Role::kViewer, {{"op", "program"}, {"args", {{"task", "t"}}}});
  ASSERT_TRUE(a.ok) << a.message;
  EXPECT_EQ(a.result["source"], v2);
  ASSERT_EQ(a.result["history"].size(), 2u) << a.result.dump();
  EXPECT_EQ(a.result["history"][1]["hash"], a.result["running"]);
  EXPECT_EQ(a.result["history"][1]["origin"], "swap v2.fbd");
  const std::string first = a.result["history"][0]["hash"];
  a = ask(Role::kViewer, {{"op", "program"}, {"args", {{"task", "t"}, {"hash", first}}}});
  ASSERT_TRUE(a.ok) << a.message;
  EXPECT_EQ(a.result["source"], kProgram);
  EXPECT_EQ(a.result["hash"], first);
  // Only a version of this task's history is read: no path, no other hash.
  a = ask(Role::kViewer, {{"op", "program"}, {"args", {{"task", "t"}, {"hash", "../../etc/passwd"}}}});
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.message.find("no stored program"), std::string::npos) << a.message;
  EXPECT_EQ(ask(Role::kViewer, {{"op", "program"}, {"args", {{"task", "nope"}}}}).ok, false);
  EXPECT_EQ(ask(Role::kNone, {{"op", "program"}, {"args", {{"task", "t"}}}}).code, "forbidden");
}

// The watch: every block output of the running program by name with its
// status (a division by zero holds its last value and is not good), once the
// task has taken the first watch snapshot; a viewer may ask, nobody else.
TEST_F(OperatorApiTest, watch_answers_every_block_output_with_its_status) {
  const std::string v = "%%\nF1 = asp(d0, c0, 50, \"SP\")\nF2 = asp(d0, c1, 0, \"Z\")\nF3 = mult(F1, F1)\n"
                        "F4 = div(F1, F2)\ndao(F3, p0, d0, c0, \"OUT\")\ndao(F4, p0, d0, c1, \"OUT2\")\nEND\n";
  ApiAnswer a = rt_->api().call(Caller{"tester", 4242, Role::kEngineer},
                                {{"op", "swap"}, {"args", {{"task", "t"}, {"name", "w.fbd"}}}}, v);
  ASSERT_TRUE(a.ok) << a.message;
  json blocks;
  ASSERT_TRUE(rtplc::testing::eventually([&] {
    rt_->tick([](bool, const std::string&) {});
    a = ask(Role::kViewer, {{"op", "watch"}, {"args", {{"task", "t"}}}});
    if (!a.ok || a.result["pending"].get<bool>()) return false;
    blocks = a.result["blocks"];
    return blocks.size() == 2 && blocks[0]["value"].get<double>() == 2500;
  })) << a.message << " " << a.result.dump();
  EXPECT_EQ(blocks[0]["name"], "F3");
  EXPECT_EQ(blocks[0]["kind"], "mult");
  EXPECT_EQ(blocks[0]["quality"], "good");
  EXPECT_EQ(blocks[1]["name"], "F4");
  EXPECT_NE(blocks[1]["quality"], "good") << blocks.dump();
  EXPECT_EQ(a.result["program"].get<std::string>().size(), 16u);
  EXPECT_EQ(ask(Role::kViewer, {{"op", "watch"}, {"args", {{"task", "nope"}}}}).ok, false);
  EXPECT_EQ(ask(Role::kNone, {{"op", "watch"}, {"args", {{"task", "t"}}}}).code, "forbidden");
}

}  // namespace
}  // namespace rtplc::sched
