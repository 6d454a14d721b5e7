// The web console's routes against a real runtime and control socket:
// deny by default (401 without a session, 403 for a lower role, a foreign
// Origin or a state-changing request without its CSRF token, and nothing
// changed), login and its throttle, the one-time link, and a set through the
// console done and audited by the runtime as the console's user.
#include <gtest/gtest.h>
#include <httplib.h>

#include <fstream>
#include <set>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>

#include "sched/control.h"
#include "tests/support/eventually.h"
#include "tests/support/runtime_fixture.h"
#include "tests/support/scratch.h"
#include "web/server.h"
#include "web/chart.h"
#include "web/users.h"

namespace rtplc::web {
namespace {

using nlohmann::json;

const char* kTask = "tasks:\n  - {name: t, program: p.fbd, period: 10ms, setpoints: {SP: {min: 0, max: 100}}}\n";
const char* kProgram = "%%\nF1 = asp(d0, c0, 50, \"SP\")\ndao(F1, p0, d0, c0, \"OUT\")\nEND\n";

struct Route {
  const char* method;
  const char* path;
  Role need;
  const char* body;
};

const Route kRoutes[] = {
    {"GET", "/api/session", Role::kViewer, ""},
    {"GET", "/api/status", Role::kViewer, ""},
    {"GET", "/api/stats", Role::kViewer, ""},
    {"GET", "/api/channels", Role::kViewer, ""},
    {"GET", "/api/jitter", Role::kViewer, ""},
    {"GET", "/api/live", Role::kViewer, ""},
    {"GET", "/api/audit", Role::kViewer, ""},
    {"POST", "/api/logout", Role::kViewer, "{}"},
    {"POST", "/api/set", Role::kOperator, R"({"label": "SP", "value": 77})"},
    {"POST", "/api/force", Role::kEngineer, R"({"label": "OUT", "value": 1})"},
    {"POST", "/api/unforce", Role::kEngineer, R"({"label": "OUT"})"},
    {"POST", "/api/swap", Role::kEngineer, R"({"task": "t", "source": "%%\nEND\n"})"},
    {"POST", "/api/rollback", Role::kEngineer, R"({"task": "t"})"},
    {"POST", "/api/swap/check", Role::kEngineer, R"({"task": "t", "source": "%%\nEND\n"})"},
    {"GET", "/api/program?task=t", Role::kViewer, ""},
    {"GET", "/api/watch?task=t", Role::kViewer, ""},
    {"GET", "/api/chart?task=t", Role::kViewer, ""},
    {"POST", "/api/trend", Role::kEngineer, R"({"labels": ["SP"]})"},
    {"POST", "/api/trend/stop", Role::kEngineer, R"({"id": "x"})"},
    {"GET", "/api/trend/stream?id=x", Role::kEngineer, ""},
    {"GET", "/api/blocks", Role::kViewer, ""},
    {"POST", "/api/fbd/to-diagram", Role::kViewer, R"({"text": "%%\nEND\n"})"},
    {"POST", "/api/fbd/to-text", Role::kViewer, R"({"diagram": {"blocks": []}})"},
    {"POST", "/api/fbd/check", Role::kViewer, R"({"diagram": {"blocks": []}})"},
    {"POST", "/api/fbd/simulate", Role::kViewer, R"({"diagram": {"blocks": []}})"},
    {"POST", "/api/view", Role::kViewer, R"({"text": "not a chart"})"},
    {"GET", "/api/workspace", Role::kViewer, ""},
    {"GET", "/api/workspace/file?name=p.fbd", Role::kViewer, ""},
    {"POST", "/api/workspace/save", Role::kEngineer, R"({"name": "p.fbd", "text": "%%\nEND\n"})"},
};

class WebConsoleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fx_.write("p.fbd", kProgram);
    rt_ = fx_.start(kTask);
    ASSERT_NE(rt_, nullptr);
    server_ = std::make_unique<sched::ControlServer>(*rt_, [](bool, const std::string&) {});
    ASSERT_TRUE(server_->start(rt_->socket_path()).ok());
    UserFile users(scratch_.path("users"));
    ASSERT_TRUE(users.add("vera", Role::kViewer, "viewer-password").ok());
    ASSERT_TRUE(users.add("otto", Role::kOperator, "operator-password").ok());
    ASSERT_TRUE(users.add("erin", Role::kEngineer, "engineer-password").ok());
    WebOptions o;
    o.runtime_name = rt_->name();
    o.socket = rt_->socket_path();
    o.port = 0;
    o.users_path = users.path();
    web_ = std::make_unique<WebConsole>(o);
    ASSERT_TRUE(web_->start().ok());
    thread_ = std::thread([this] { web_->run(); });
  }
  void TearDown() override {
    if (web_) web_->stop();
    if (thread_.joinable()) thread_.join();
    if (server_) server_->stop();
    if (rt_) rt_->stop();
  }
  std::string origin() const { return "http://127.0.0.1:" + std::to_string(web_->port()); }
  httplib::Client client() const {
    httplib::Client c("127.0.0.1", web_->port());
    c.set_read_timeout(15, 0);
    return c;
  }
  // Logs in; returns the session's cookie and CSRF token.
  std::pair<std::string, std::string> login(const std::string& user, const std::string& password) {
    auto c = client();
    auto r = c.Post("/api/login", json{{"user", user}, {"password", password}}.dump(), "application/json");
    if (!r || r->status != 200) return {};
    const std::string cookie = r->get_header_value("Set-Cookie");
    return {cookie.substr(0, cookie.find(';')), json::parse(r->body)["csrf"].get<std::string>()};
  }
  int send(const Route& route, const std::string& cookie, const std::string& csrf, const std::string& from = "") {
    auto c = client();
    httplib::Headers h;
    if (!cookie.empty()) h.emplace("Cookie", cookie);
    if (!csrf.empty()) h.emplace("X-CSRF-Token", csrf);
    if (!from.empty()) h.emplace("Origin", from);
    auto r = std::string(route.method) == "GET" ? c.Get(route.path, h) : c.Post(route.path, h, route.body, "application/json");
    return r ? r->status : -1;
  }
  double sp() { return rt_->image().read_channel(static_cast<uint32_t>(rt_->image().find_channel("SP"))).value; }

  test::Scratch scratch_{"rtplc-web"};
  testing::RuntimeFixture fx_;
  std::unique_ptr<sched::Runtime> rt_;
  std::unique_ptr<sched::ControlServer> server_;
  std::unique_ptr<WebConsole> web_;
  std::thread thread_;
};

TEST_F(WebConsoleTest, every_route_refuses_no_session_a_lower_role_a_foreign_origin_and_a_missing_token) {
  const auto viewer = login("vera", "viewer-password");
  const auto op = login("otto", "operator-password");
  const auto eng = login("erin", "engineer-password");
  ASSERT_FALSE(viewer.first.empty());
  ASSERT_FALSE(op.first.empty());
  ASSERT_FALSE(eng.first.empty());
  for (const Route& r : kRoutes) {
    SCOPED_TRACE(std::string(r.method) + " " + r.path);
    EXPECT_EQ(send(r, "", ""), 401);
    EXPECT_EQ(send(r, "rtplc_session=0123456789abcdef", ""), 401);  // a made-up session
    // A foreign page, with a valid session and token: refused.
    EXPECT_EQ(send(r, eng.first, eng.second, "http://evil.example"), 403);
    if (r.need == Role::kOperator) {
      EXPECT_EQ(send(r, viewer.first, viewer.second), 403);
    }
    if (r.need == Role::kEngineer) {
      EXPECT_EQ(send(r, viewer.first, viewer.second), 403);
      EXPECT_EQ(send(r, op.first, op.second), 403);
    }
    if (std::string(r.method) == "POST") {
      EXPECT_EQ(send(r, eng.first, ""), 403);               // no token
      EXPECT_EQ(send(r, eng.first, viewer.second), 403);    // another session's token
    }
  }
  // Nothing above changed anything.
  EXPECT_EQ(sp(), 50);
  EXPECT_TRUE(rt_->forces().empty());
  EXPECT_EQ(rt_->task(0).params().name, "t");
  // And the sessions survived (logout needed its token).
  EXPECT_EQ(send(kRoutes[0], viewer.first, ""), 200);
}

TEST_F(WebConsoleTest, a_set_through_the_console_is_the_runtimes_own_set_audited_as_the_web_user) {
  const auto op = login("otto", "operator-password");
  ASSERT_FALSE(op.first.empty());
  auto c = client();
  httplib::Headers h{{"Cookie", op.first}, {"X-CSRF-Token", op.second}, {"Origin", origin()}};
  auto r = c.Post("/api/set", h, R"({"label": "SP", "value": 61})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(sp(), 61);
  // Limits are the runtime's: refused there, said here.
  r = c.Post("/api/set", h, R"({"label": "SP", "value": 150})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 409) << r->body;
  EXPECT_NE(r->body.find("outside the range"), std::string::npos) << r->body;
  EXPECT_EQ(sp(), 61);
  std::ifstream f(rt_->api().audit().path());
  std::stringstream trail;
  trail << f.rdbuf();
  EXPECT_NE(trail.str().find("web otto [operator] set label=SP value=61: SP = 61 (was 50)"), std::string::npos)
      << trail.str();
  // The live stream carries the new value.
  std::string got;
  auto live = client();
  live.Get("/api/live?channels=SP", httplib::Headers{{"Cookie", op.first}}, [&](const char* data, size_t n) {
    got.append(data, n);
    return got.find("\"value\":61") == std::string::npos && got.size() < 100000;
  });
  EXPECT_NE(got.find("\"label\":\"SP\""), std::string::npos) << got;
  EXPECT_NE(got.find("\"value\":61"), std::string::npos) << got;
  EXPECT_EQ(got.find("\"label\":\"OUT\""), std::string::npos) << "a channel nobody subscribed was sent: " << got;
  // `channels=` (a page that shows none): the runtime's state, no values.
  got.clear();
  live.Get("/api/live?channels=", httplib::Headers{{"Cookie", op.first}}, [&](const char* data, size_t n) {
    got.append(data, n);
    return got.find("\n\n") == std::string::npos;
  });
  EXPECT_NE(got.find("\"alive\":true"), std::string::npos) << got;
  EXPECT_NE(got.find("\"values\":[]"), std::string::npos) << got;
}

// The live stream sends a new client everything, then only what changed, and
// everything again in the next key frame (every second): a quiet plant costs
// no frames between keys, and a slow client resynchronises on the whole set.
TEST_F(WebConsoleTest, the_live_stream_sends_everything_then_changes_only_then_a_key_frame) {
  const auto op = login("otto", "operator-password");
  ASSERT_FALSE(op.first.empty());
  std::vector<json> frames;
  std::string buf;
  bool set_done = false;
  auto live = client();
  live.Get("/api/live", httplib::Headers{{"Cookie", op.first}}, [&](const char* data, size_t n) {
    buf.append(data, n);
    for (size_t end; (end = buf.find("\n\n")) != std::string::npos; buf.erase(0, end + 2)) {
      if (buf.rfind("data: ", 0) != 0) continue;
      frames.push_back(json::parse(buf.substr(6, end - 6)));
    }
    if (!frames.empty() && !set_done) {
      set_done = true;
      EXPECT_TRUE(rt_->set_value("SP", 62, false).ok());
    }
    // Until a key frame that came after a frame of changes, or plenty of frames.
    bool delta = false, key_after = false;
    for (size_t i = 1; i < frames.size(); ++i) {
      if (!frames[i]["full"].get<bool>()) delta = true;
      else if (delta) key_after = true;
    }
    return !key_after && frames.size() < 200;
  });
  ASSERT_GE(frames.size(), 3u);
  auto labels = [](const json& f) {
    std::set<std::string> out;
    for (const json& v : f["values"]) out.insert(v["label"].get<std::string>());
    return out;
  };
  EXPECT_TRUE(frames[0]["full"].get<bool>());
  EXPECT_EQ(labels(frames[0]), (std::set<std::string>{"SP", "OUT"}));
  // The changes: SP and OUT move to 62 (in one frame or two); nothing else
  // rides along, and sequence numbers follow each other.
  bool saw_62 = false, saw_key = false;
  for (size_t i = 1; i < frames.size(); ++i) {
    const json& f = frames[i];
    SCOPED_TRACE(f.dump());
    EXPECT_EQ(f["seq"].get<uint64_t>(), frames[i - 1]["seq"].get<uint64_t>() + 1);
    if (f["full"].get<bool>()) {
      if (saw_62) saw_key = true;
      EXPECT_EQ(labels(f), (std::set<std::string>{"SP", "OUT"}));
      continue;
    }
    EXPECT_FALSE(f["values"].empty()) << "a frame with no change was sent";
    for (const json& v : f["values"]) {
      EXPECT_EQ(v["value"].get<double>(), 62);
      saw_62 = true;
    }
  }
  EXPECT_TRUE(saw_62);
  EXPECT_TRUE(saw_key) << "no key frame followed the changes";
}

// The editor's routes as the page uses them: the palette, a program to a
// diagram, the diagram checked by the real compiler, an error placed on its
// block, and a text that does not parse refused with its position.
TEST_F(WebConsoleTest, the_editor_routes_turn_text_into_a_checked_diagram_and_back) {
  const auto v = login("vera", "viewer-password");
  ASSERT_FALSE(v.first.empty());
  auto c = client();
  httplib::Headers h{{"Cookie", v.first}, {"X-CSRF-Token", v.second}, {"Origin", origin()}};
  auto r = c.Get("/api/blocks", h);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  const json blocks = json::parse(r->body)["blocks"];
  bool pid = false;
  for (const json& b : blocks) {
    if (b["name"] == "pid") {
      pid = true;
      EXPECT_EQ(b["inputs"].size(), 2u);
      EXPECT_EQ(b["params"][0]["name"], "Kp");
    }
  }
  EXPECT_TRUE(pid);
  r = c.Post("/api/fbd/to-diagram", h, json{{"text", kProgram}, {"layout", nullptr}}.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  json d = json::parse(r->body)["diagram"];
  ASSERT_EQ(d["blocks"].size(), 2u);
  EXPECT_EQ(d["blocks"][0]["label"], "SP");
  EXPECT_LT(d["blocks"][0]["row"].get<int>(), d["blocks"][1]["row"].get<int>());
  r = c.Post("/api/fbd/check", h, json{{"diagram", d}}.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  json v1 = json::parse(r->body);
  EXPECT_TRUE(v1["compiles"].get<bool>()) << v1.dump();
  EXPECT_EQ(v1["identity"].get<std::string>().size(), 16u);
  // The output reads a block that does not exist: the error is on block 2, argument 1.
  d["blocks"][1]["args"][0] = {{"ref", "F7"}};
  r = c.Post("/api/fbd/check", h, json{{"diagram", d}}.dump(), "application/json");
  ASSERT_TRUE(r);
  json v2 = json::parse(r->body);
  EXPECT_FALSE(v2["compiles"].get<bool>());
  ASSERT_FALSE(v2["diagnostics"].empty()) << v2.dump();
  EXPECT_EQ(v2["diagnostics"][0]["block"], 1);
  EXPECT_EQ(v2["diagnostics"][0]["arg"], 0);
  EXPECT_NE(v2["rendered"].get<std::string>().find("diagram.fbd:"), std::string::npos);
  r = c.Post("/api/fbd/to-text", h, json{{"diagram", d}}.dump(), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  EXPECT_NE(json::parse(r->body)["text"].get<std::string>().find("dao(F7, p0, d0, c0, \"OUT\")"), std::string::npos);
  EXPECT_EQ(json::parse(r->body)["layout"]["format"], "rtplc-fbd-layout");
  r = c.Post("/api/fbd/to-diagram", h, R"({"text": "%%\nF1 = asp(d0 c0)\nEND\n", "file": "x.fbd"})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 422);
  EXPECT_NE(r->body.find("x.fbd:2:"), std::string::npos) << r->body;
  // A diagram that would smuggle text is refused, not written.
  d["blocks"][0]["args"][3] = {{"string", "SP\")\nF9 = asp("}};
  r = c.Post("/api/fbd/to-text", h, json{{"diagram", d}}.dump(), "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
}

TEST_F(WebConsoleTest, the_login_link_works_once_and_wrong_passwords_are_throttled) {
  const std::string link = web_->login_link();
  const std::string path = link.substr(link.find("/login"));
  auto c = client();
  auto r = c.Get(path);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 303);
  const std::string cookie = r->get_header_value("Set-Cookie");
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos) << cookie;
  EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos) << cookie;
  auto s = c.Get("/api/session", httplib::Headers{{"Cookie", cookie.substr(0, cookie.find(';'))}});
  ASSERT_TRUE(s);
  EXPECT_EQ(json::parse(s->body)["role"], "admin") << s->body;
  r = c.Get(path);  // used up
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);
  EXPECT_EQ(c.Get("/login?token=" + std::string(64, 'a'))->status, 401);
  // Five wrong passwords, then even the right one waits.
  for (int i = 0; i < 5; ++i) {
    auto w = c.Post("/api/login", R"({"user": "vera", "password": "wrong-password"})", "application/json");
    ASSERT_TRUE(w);
    EXPECT_EQ(w->status, 401);
  }
  auto t = c.Post("/api/login", R"({"user": "vera", "password": "viewer-password"})", "application/json");
  ASSERT_TRUE(t);
  EXPECT_EQ(t->status, 429);
  // Every page carries the content security policy.
  auto page = c.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->get_header_value("Content-Security-Policy").find("default-src 'self'"), std::string::npos);
}

TEST(WebConsoleStart, an_address_beyond_loopback_needs_tls) {
  WebOptions o;
  o.host = "0.0.0.0";
  o.port = 0;
  WebConsole w(o);
  auto r = w.start();
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("needs TLS"), std::string::npos) << r.error();
}

TEST(WebUsers, passwords_are_argon2id_hashes_and_short_ones_are_refused) {
  test::Scratch s("rtplc-webusers");
  UserFile f(s.path("u"));
  EXPECT_FALSE(f.add("amy", Role::kViewer, "short").ok());
  EXPECT_FALSE(f.add("bad name", Role::kViewer, "long-enough-password").ok());
  ASSERT_TRUE(f.add("amy", Role::kOperator, "long-enough-password").ok());
  EXPECT_FALSE(f.add("amy", Role::kViewer, "another-password").ok());
  std::ifstream in(f.path());
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("amy operator $argon2id$"), std::string::npos) << text.str();
  EXPECT_EQ(text.str().find("long-enough-password"), std::string::npos);
  EXPECT_EQ(f.check("amy", "long-enough-password"), Role::kOperator);
  EXPECT_EQ(f.check("amy", "wrong-password"), std::nullopt);
  EXPECT_EQ(f.check("nobody", "long-enough-password"), std::nullopt);
  ASSERT_TRUE(f.set_password("amy", "a-new-long-password").ok());
  EXPECT_EQ(f.check("amy", "long-enough-password"), std::nullopt);
  EXPECT_EQ(f.check("amy", "a-new-long-password"), Role::kOperator);
  ASSERT_TRUE(f.remove("amy").ok());
  EXPECT_EQ(f.check("amy", "a-new-long-password"), std::nullopt);
}

TEST(WebChart, a_chart_is_its_steps_transitions_and_conditions_as_written) {
  const std::string sfc =
      "SFC mix STEPS d0\nINPUT A = ddi(p0, d0, c0, \"A\")\nINPUT B = ddi(p0, d0, c1, \"B\")\n"
      "OUTPUT V = ddo(p0, d1, c0, \"V\")\n"
      "INITIAL STEP Idle\nEND_STEP\nSTEP Run\n  S V\nEND_STEP\nSTEP Stop\n  R V\nEND_STEP\n"
      "TRANSITION go FROM Idle TO Run WHEN A AND (B OR NOT A)\n"
      "TRANSITION halt FROM Run TO Stop WHEN NOT B\nTRANSITION back FROM Stop TO Idle WHEN TRUE\n";
  auto c = chart_json(sfc);
  ASSERT_TRUE(c.ok()) << c.error();
  EXPECT_EQ((*c)["chart"], "mix");
  ASSERT_EQ((*c)["steps"].size(), 3u);
  EXPECT_EQ((*c)["steps"][0]["label"], "mix.Idle");
  EXPECT_EQ((*c)["steps"][0]["initial"], true);
  EXPECT_EQ((*c)["steps"][1]["actions"][0], "S V");
  ASSERT_EQ((*c)["transitions"].size(), 3u);
  EXPECT_EQ((*c)["transitions"][0]["when"], "A AND (B OR NOT A)");
  EXPECT_EQ((*c)["transitions"][0]["from"][0], "Idle");
  EXPECT_EQ((*c)["transitions"][1]["when"], "NOT B");
  EXPECT_EQ((*c)["transitions"][2]["to"][0], "Idle");
  EXPECT_FALSE(chart_json(kProgram).ok());                         // FBD
  EXPECT_FALSE(chart_json("SFC broken STEPS d0\nSTEP\n").ok());   // does not parse
}

}  // namespace
}  // namespace rtplc::web
