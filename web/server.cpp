// The web console's server (see server.h; routes and their roles in docs/web.md).
#include "web/server.h"

#include <httplib.h>
#include <pwd.h>
#include <sodium.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>
#include <nlohmann/json.hpp>

#include "io/process_image.h"
#include "io/trace_ring.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/rt_thread.h"
#include "sched/control.h"
#include "sched/jitter.h"
#include "sched/stats_source.h"
#include "editor/diagram.h"
#include "editor/plcopen_view.h"
#include "editor/simulate.h"
#include "lang/plcopen/import.h"
#include "web/chart.h"
#include "web/ui_assets.h"

namespace rtplc::web {
namespace {

using nlohmann::json;

constexpr const char* kCookie = "rtplc_session";
constexpr int kMaxFailures = 5;          // failed logins per address ...
constexpr int64_t kFailureWindowNs = 60'000'000'000;  // ... per minute
constexpr size_t kMaxBody = 16u << 20;   // a swap's source and some JSON

std::string random_token() {
  unsigned char b[32];
  randombytes_buf(b, sizeof b);
  char hex[sizeof b * 2 + 1];
  sodium_bin2hex(hex, sizeof hex, b, sizeof b);
  return hex;
}

// Compares two tokens in constant time.
bool same_token(const std::string& a, const std::string& b) {
  return a.size() == b.size() && sodium_memcmp(a.data(), b.data(), a.size()) == 0;
}

std::string cookie_value(const httplib::Request& req, const std::string& name) {
  const std::string all = req.get_header_value("Cookie");
  size_t at = 0;
  while (at < all.size()) {
    size_t end = all.find(';', at);
    if (end == std::string::npos) end = all.size();
    std::string part = all.substr(at, end - at);
    while (!part.empty() && part.front() == ' ') part.erase(part.begin());
    if (part.rfind(name + "=", 0) == 0) return part.substr(name.size() + 1);
    at = end + 1;
  }
  return "";
}

void reply(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_content(body.dump(-1, ' ', false, json::error_handler_t::replace), "application/json");
}

void fail(httplib::Response& res, int status, const std::string& code, const std::string& message) {
  reply(res, status, json{{"ok", false}, {"error", {{"code", code}, {"message", message}}}});
}

// The API's error codes as HTTP statuses.
int status_of(const std::string& code) {
  if (code == "forbidden") return 403;
  if (code == "bad_request") return 400;
  if (code == "unknown_op") return 404;
  if (code == "refused") return 409;
  if (code == "busy") return 503;
  return 502;
}

std::string owner_name() {
  const passwd* pw = getpwuid(geteuid());
  return pw != nullptr ? pw->pw_name : "uid" + std::to_string(geteuid());
}

}  // namespace

bool is_loopback(const std::string& host) {
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

WebConsole::WebConsole(WebOptions opt)
    : opt_(std::move(opt)), users_(opt_.users_path.empty() ? default_users_path(opt_.runtime_name) : opt_.users_path) {}

WebConsole::~WebConsole() { stop(); }

std::string WebConsole::origin() const {
  // A link for people: a wildcard address becomes this machine's name.
  std::string host = opt_.host;
  if (host == "0.0.0.0" || host == "::") {
    char name[256] = {};
    host = gethostname(name, sizeof name - 1) == 0 && name[0] ? name : "localhost";
  }
  return std::string(opt_.tls_cert.empty() ? "http://" : "https://") +
         (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":" + std::to_string(port_);
}

// The origin the browser reached us at (its Host header): a page of ours sends
// exactly this as its Origin; a page of any other site cannot.
std::string WebConsole::origin_of(const httplib::Request& req) const {
  return std::string(opt_.tls_cert.empty() ? "http://" : "https://") + req.get_header_value("Host");
}

Result<void> WebConsole::start() {
  if (sodium_init() < 0) return make_error("libsodium could not be initialised");
  const bool tls = !opt_.tls_cert.empty() || !opt_.tls_key.empty();
  if (tls && (opt_.tls_cert.empty() || opt_.tls_key.empty())) {
    return make_error("TLS needs both --tls-cert and --tls-key");
  }
  if (!tls && !is_loopback(opt_.host)) {
    return make_error("--listen " + opt_.host + " reaches beyond this machine: that needs TLS (--tls-cert FILE "
                      "--tls-key FILE), or listen on 127.0.0.1 and reach it through an SSH tunnel");
  }
  socket_ = sched::control_socket_of(opt_.runtime_name, opt_.socket);
  if (!opt_.workspace.empty()) {
    auto w = editor::Workspace::open(opt_.workspace);
    if (!w) return make_error("--workspace: " + w.error());
    workspace_ = std::move(w).value();
  }
  if (tls) {
    for (const std::string& f : {opt_.tls_cert, opt_.tls_key}) {
      if (access(f.c_str(), R_OK) != 0) return make_error("cannot read " + f);
    }
    auto s = std::make_unique<httplib::SSLServer>(opt_.tls_cert.c_str(), opt_.tls_key.c_str());
    if (!s->is_valid()) {
      return make_error("cannot use " + opt_.tls_cert + " and " + opt_.tls_key +
                        " as a certificate and its key (PEM files that belong together)");
    }
    http_ = std::move(s);
  } else {
    http_ = std::make_unique<httplib::Server>();
  }
  // A thread per connection (a live stream holds one): up to 64 at once.
  http_->new_task_queue = [] { return new httplib::ThreadPool(64); };
  http_->set_payload_max_length(kMaxBody);
  http_->set_read_timeout(10, 0);
  http_->set_write_timeout(5, 0);  // a client that stops reading frees its thread
  http_->set_keep_alive_timeout(5);
  routes();
  if (opt_.port == 0) {
    port_ = http_->bind_to_any_port(opt_.host);
  } else {
    port_ = http_->bind_to_port(opt_.host, opt_.port) ? opt_.port : -1;
  }
  if (port_ <= 0) {
    return make_error("cannot listen on " + opt_.host + ":" + std::to_string(opt_.port) +
                      " (in use, or not an address of this machine; --listen HOST:PORT chooses another)");
  }
  kernel_rt::ThreadSpec spec;  // an ordinary thread: the console is below every task
  spec.name = "rtplc:web-sample";
  auto t = kernel_rt::start_thread(spec, [this] { sample_loop(); });
  if (!t) return make_error("sampler thread: " + t.error());
  sampler_ = std::move(t).value();
  return {};
}

void WebConsole::run() {
  if (http_) http_->listen_after_bind();
}

void WebConsole::stop() {
  quit_.store(true);
  snap_cv_.notify_all();
  if (http_) http_->stop();
  if (sampler_.joinable()) sampler_.join();
}

std::string WebConsole::login_link() {
  const std::string token = random_token();
  std::lock_guard lock(mu_);
  link_tokens_[token] = kernel_rt::monotonic_now_ns() + int64_t{opt_.link_minutes} * 60'000'000'000;
  return origin() + "/login?token=" + token;
}

bool WebConsole::login_throttled(const std::string& addr, bool failed_now) {
  std::lock_guard lock(mu_);
  std::vector<int64_t>& f = failures_[addr];
  const int64_t now = kernel_rt::monotonic_now_ns();
  f.erase(std::remove_if(f.begin(), f.end(), [now](int64_t t) { return now - t > kFailureWindowNs; }), f.end());
  if (failed_now) f.push_back(now);
  return static_cast<int>(f.size()) >= kMaxFailures;
}

const WebConsole::Session* WebConsole::session_of(const httplib::Request& req, std::string* token) {
  const std::string t = cookie_value(req, kCookie);
  if (t.empty()) return nullptr;
  const int64_t now = kernel_rt::monotonic_now_ns();
  auto it = sessions_.find(t);
  if (it == sessions_.end()) return nullptr;
  if (now - it->second.last_used_ns > int64_t{opt_.session_idle_minutes} * 60'000'000'000) {
    sessions_.erase(it);
    return nullptr;
  }
  it->second.last_used_ns = now;
  if (token != nullptr) *token = t;
  return &it->second;
}

// Deny by default: a route names the role it needs; the request must carry a
// live session of at least that role, and a state-changing one also its CSRF
// token and no Origin but ours.
int WebConsole::guard(const httplib::Request& req, httplib::Response& res, Role need, bool state_changing,
                      Session* out) {
  const std::string from = req.get_header_value("Origin");
  if (!from.empty() && from != origin_of(req)) {
    fail(res, 403, "forbidden", "requests from " + from + " are refused: this console serves " + origin_of(req) + " only");
    return 403;
  }
  std::lock_guard lock(mu_);
  const Session* s = session_of(req);
  if (s == nullptr) {
    fail(res, 401, "unauthenticated", "log in first");
    return 401;
  }
  if (!role_allows(s->role, need)) {
    fail(res, 403, "forbidden",
         s->user + " is a " + role_name(s->role) + "; this needs the role " + role_name(need));
    return 403;
  }
  if (state_changing && !same_token(req.get_header_value("X-CSRF-Token"), s->csrf)) {
    fail(res, 403, "forbidden", "missing or wrong X-CSRF-Token (GET /api/session gives it)");
    return 403;
  }
  if (out != nullptr) *out = *s;
  return 0;
}

Result<json> WebConsole::ask(const Session& s, const std::string& op, const json& args, const std::string& payload,
                             int timeout_ms) {
  const json request = {{"op", op}, {"args", args}, {"as", {{"via", "web"}, {"user", s.user}, {"role", role_name(s.role)}}}};
  return sched::api_request(socket_, request, payload, timeout_ms);
}

// One route, one operator API op, on behalf of the session's user.
void WebConsole::api(const httplib::Request& req, httplib::Response& res, const std::string& op, Role need) {
  const bool post = req.method == "POST";
  Session s;
  if (guard(req, res, need, post, &s) != 0) return;
  json body = json::object();
  if (post) {
    body = json::parse(req.body, nullptr, false);
    if (!body.is_object()) return fail(res, 400, "bad_request", "the body must be a JSON object");
  }
  json args = json::object();
  std::string payload;
  auto copy = [&](const char* key, bool required) -> bool {
    if (body.contains(key)) {
      args[key] = body[key];
      return true;
    }
    if (required) fail(res, 400, "bad_request", std::string("'") + key + "' is missing");
    return !required;
  };
  if (op == "set" || op == "force") {
    if (!copy("label", true) || !copy("value", true)) return;
  } else if (op == "unforce") {
    if (!copy("label", true)) return;
  } else if (op == "swap" || op == "swap_check") {
    if (!copy("task", true)) return;
    if (!body.contains("source") || !body["source"].is_string()) {
      return fail(res, 400, "bad_request", "'source' must be the program's text");
    }
    payload = body["source"].get<std::string>();
    args["name"] = body.contains("name") && body["name"].is_string() ? body["name"].get<std::string>() : "web-upload";
    copy("drop_outputs", false);
  } else if (op == "rollback") {
    if (!copy("task", true)) return;
    copy("drop_outputs", false);
  } else if (op == "watch") {
    args["task"] = req.get_param_value("task");
  } else if (op == "program") {
    args["task"] = req.get_param_value("task");
    if (req.has_param("hash")) args["hash"] = req.get_param_value("hash");
  } else if (op == "audit") {
    const std::string n = req.get_param_value("lines");
    if (!n.empty()) {
      char* end = nullptr;
      const long v = std::strtol(n.c_str(), &end, 10);
      if (*end != '\0') return fail(res, 400, "bad_request", "lines must be a number");
      args["lines"] = v;
    }
  }
  auto answer = ask(s, op, args, payload, op == "swap" || op == "rollback" ? sched::kSwapAnswerMs : op == "swap_check" ? 60000 : 10000);
  if (!answer) return fail(res, 502, "unreachable", answer.error());
  if (answer->value("ok", false)) return reply(res, 200, *answer);
  const std::string code = (*answer)["error"].value("code", "refused");
  reply(res, status_of(code), *answer);
}

std::string WebConsole::live_event(const Snapshot& snap, const std::vector<std::string>* wanted, bool changes_only,
                                   size_t* count) {
  // Written by hand, not through a json object: this runs 20 times a second
  // over a thousand channels and is most of the console's work.
  std::string out = "data: {\"seq\":" + std::to_string(snap.seq) + ",\"alive\":" + (snap.alive ? "true" : "false") +
                    ",\"runtime\":" + json(snap.runtime).dump() + ",\"full\":" + (changes_only ? "false" : "true") +
                    ",\"values\":[";
  out.reserve(out.size() + 80 * snap.values.size());
  bool first = true;
  char num[64];
  if (count) *count = 0;
  for (const Snapshot::Value& v : snap.values) {
    if (changes_only && !v.changed) continue;
    if (wanted && !std::binary_search(wanted->begin(), wanted->end(), v.label)) continue;
    if (count) ++*count;
    if (!first) out += ',';
    first = false;
    out += "{\"label\":";
    out += json(v.label).dump();
    out += ",\"value\":";
    if (std::isfinite(v.value)) {
      out.append(num, std::to_chars(num, num + sizeof num, v.value).ptr);
    } else {
      out += "null";
    }
    out += ",\"quality\":\"";
    out += v.quality;
    out += "\",\"age_s\":";
    if (v.age_s >= 0) {
      out.append(num, std::to_chars(num, num + sizeof num, v.age_s, std::chars_format::fixed, 3).ptr);
    } else {
      out += "null";
    }
    out += v.forced ? ",\"forced\":true}" : ",\"forced\":false}";
  }
  out += "]}\n\n";
  return out;
}

void WebConsole::routes() {
  httplib::Headers headers = {
      {"Content-Security-Policy", "default-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'self'"},
      {"X-Content-Type-Options", "nosniff"},
      {"Referrer-Policy", "no-referrer"},
      {"X-Frame-Options", "DENY"},
      {"Cache-Control", "no-store"},
  };
  if (!opt_.tls_cert.empty()) headers.emplace("Strict-Transport-Security", "max-age=31536000");
  http_->set_default_headers(headers);

  for (size_t i = 0; i < kUiAssetCount; ++i) {
    const UiAsset& a = kUiAssets[i];
    const std::string path = std::string(a.path) == "/index.html" ? "/" : a.path;
    http_->Get(path, [a](const httplib::Request&, httplib::Response& res) { res.set_content(a.body, a.type); });
  }

  http_->Post("/api/login", [this](const httplib::Request& req, httplib::Response& res) {
    const std::string from = req.get_header_value("Origin");
    if (!from.empty() && from != origin_of(req)) return fail(res, 403, "forbidden", "requests from " + from + " are refused");
    if (login_throttled(req.remote_addr, false)) {
      return fail(res, 429, "throttled", "too many failed logins from " + req.remote_addr + "; wait a minute");
    }
    const json body = json::parse(req.body, nullptr, false);
    const std::string user = body.is_object() && body.contains("user") && body["user"].is_string() ? body["user"].get<std::string>() : "";
    const std::string pass = body.is_object() && body.contains("password") && body["password"].is_string()
                                 ? body["password"].get<std::string>()
                                 : "";
    const auto role = UserFile::valid_name(user) ? users_.check(user, pass) : std::nullopt;
    if (!role) {
      login_throttled(req.remote_addr, true);
      return fail(res, 401, "unauthenticated", "wrong user name or password");
    }
    Session s{user, *role, random_token(), kernel_rt::monotonic_now_ns()};
    const std::string token = random_token();
    {
      std::lock_guard lock(mu_);
      sessions_[token] = s;
    }
    res.set_header("Set-Cookie", std::string(kCookie) + "=" + token + "; Path=/; HttpOnly; SameSite=Strict" +
                                     (opt_.tls_cert.empty() ? "" : "; Secure"));
    reply(res, 200, json{{"ok", true}, {"user", s.user}, {"role", role_name(s.role)}, {"csrf", s.csrf}});
  });

  // The owner's one-time link: an admin session, once, within link_minutes.
  http_->Get("/login", [this](const httplib::Request& req, httplib::Response& res) {
    const std::string t = req.get_param_value("token");
    bool ok = false;
    std::string session_token;
    {
      std::lock_guard lock(mu_);
      for (auto it = link_tokens_.begin(); it != link_tokens_.end(); ++it) {
        if (!same_token(it->first, t)) continue;
        ok = kernel_rt::monotonic_now_ns() < it->second;
        link_tokens_.erase(it);  // used or expired: gone either way
        break;
      }
      if (ok) {
        session_token = random_token();
        sessions_[session_token] = Session{owner_name(), Role::kAdmin, random_token(), kernel_rt::monotonic_now_ns()};
      }
    }
    if (!ok) {
      res.status = 401;
      res.set_content("This login link is used up, expired or wrong. Run `rtplc web` again for a new one, "
                      "or log in with a user name (rtplc web user add).\n",
                      "text/plain");
      return;
    }
    res.set_header("Set-Cookie", std::string(kCookie) + "=" + session_token + "; Path=/; HttpOnly; SameSite=Strict" +
                                     (opt_.tls_cert.empty() ? "" : "; Secure"));
    res.set_redirect("/", 303);
  });

  http_->Post("/api/logout", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kViewer, true, &s) != 0) return;
    {
      std::lock_guard lock(mu_);
      sessions_.erase(cookie_value(req, kCookie));
    }
    res.set_header("Set-Cookie", std::string(kCookie) + "=; Path=/; HttpOnly; SameSite=Strict; Max-Age=0");
    reply(res, 200, json{{"ok", true}});
  });

  http_->Get("/api/session", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kViewer, false, &s) != 0) return;
    reply(res, 200, json{{"ok", true}, {"user", s.user}, {"role", role_name(s.role)}, {"csrf", s.csrf},
                         {"runtime", opt_.runtime_name}});
  });

  http_->Get("/api/status", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "status", Role::kViewer);
  });
  http_->Get("/api/stats", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "stats", Role::kViewer);
  });
  http_->Get("/api/audit", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "audit", Role::kViewer);
  });
  http_->Post("/api/set", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "set", Role::kOperator);
  });
  http_->Post("/api/force", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "force", Role::kEngineer);
  });
  http_->Post("/api/unforce", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "unforce", Role::kEngineer);
  });
  http_->Post("/api/swap", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "swap", Role::kEngineer);
  });
  http_->Post("/api/rollback", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "rollback", Role::kEngineer);
  });
  // What a swap would do (the compiler's errors or the migration report), changing nothing.
  http_->Post("/api/swap/check", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "swap_check", Role::kEngineer);
  });
  // A task's program store: the versions it ran, newest last, and one's source.
  http_->Get("/api/program", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "program", Role::kViewer);
  });
  // Every block output of a task with its status (the editor's live wires):
  // renews the task's watch lease; polled while the editor is online.
  http_->Get("/api/watch", [this](const httplib::Request& req, httplib::Response& res) {
    api(req, res, "watch", Role::kViewer);
  });
  // An SFC task's chart (steps, transitions, conditions) from the source it runs.
  http_->Get("/api/chart", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kViewer, false, &s) != 0) return;
    const std::string task = req.get_param_value("task");
    auto answer = ask(s, "program", {{"task", task}}, "", 10000);
    if (!answer) return fail(res, 502, "unreachable", answer.error());
    if (!answer->value("ok", false)) return reply(res, status_of((*answer)["error"].value("code", "refused")), *answer);
    const json& r = (*answer)["result"];
    auto chart = chart_json(r.value("source", std::string()));
    if (!chart) return fail(res, 404, "not_a_chart", "task " + task + ": " + chart.error());
    (*chart)["ok"] = true;
    (*chart)["task"] = task;
    (*chart)["program"] = r.value("running", std::string());
    reply(res, 200, *chart);
  });

  // The FBD editor's routes (docs/editor.md): the palette, text <-> diagram,
  // and the real compiler's verdict placed on blocks. They change nothing in
  // the runtime (a swap from the editor is /api/swap), so a viewer may use
  // them; the POSTs still carry the session's CSRF token.
  http_->Get("/api/blocks", [this](const httplib::Request& req, httplib::Response& res) {
    if (guard(req, res, Role::kViewer, false, nullptr) != 0) return;
    reply(res, 200, json{{"ok", true}, {"blocks", editor::registry_json()}});
  });
  http_->Post("/api/fbd/to-diagram", [this](const httplib::Request& req, httplib::Response& res) {
    if (guard(req, res, Role::kViewer, true, nullptr) != 0) return;
    const json body = json::parse(req.body, nullptr, false);
    if (!body.is_object() || !body.contains("text") || !body["text"].is_string()) {
      return fail(res, 400, "bad_request", "the body is {\"text\": FBD, \"layout\": LAYOUT or null}");
    }
    const std::string text = body["text"].get<std::string>();
    DiagnosticList diags;
    auto d = editor::from_text(text, &diags);
    if (!d) {
      json out = {{"ok", false},
                  {"error", {{"code", "syntax"}, {"message", diags.render(body.value("file", "program.fbd"), text)}}},
                  {"diagnostics", editor::diagnostics_json(diags)}};
      return reply(res, 422, out);
    }
    if (body.contains("layout") && !body["layout"].is_null()) {
      if (auto l = editor::apply_layout(*d, body["layout"]); !l) return fail(res, 400, "bad_layout", l.error());
    }
    editor::auto_layout(*d);
    reply(res, 200, json{{"ok", true}, {"diagram", editor::diagram_json(*d)}});
  });
  // A request's {"diagram": D}, or the 400 already answered.
  auto diagram_of = [](const httplib::Request& req, httplib::Response& res, json* body) -> std::optional<editor::Diagram> {
    *body = json::parse(req.body, nullptr, false);
    if (!body->is_object() || !body->contains("diagram")) {
      fail(res, 400, "bad_request", "the body is {\"diagram\": D}");
      return std::nullopt;
    }
    auto d = editor::diagram_from_json((*body)["diagram"]);
    if (!d) {
      fail(res, 400, "bad_diagram", d.error());
      return std::nullopt;
    }
    return std::move(d).value();
  };
  http_->Post("/api/fbd/to-text", [this, diagram_of](const httplib::Request& req, httplib::Response& res) {
    if (guard(req, res, Role::kViewer, true, nullptr) != 0) return;
    json body;
    auto d = diagram_of(req, res, &body);
    if (!d) return;
    editor::auto_layout(*d);
    reply(res, 200, json{{"ok", true}, {"text", editor::to_text(*d)}, {"layout", editor::layout_json(*d)}});
  });
  http_->Post("/api/fbd/check", [this, diagram_of](const httplib::Request& req, httplib::Response& res) {
    if (guard(req, res, Role::kViewer, true, nullptr) != 0) return;
    json body;
    auto d = diagram_of(req, res, &body);
    if (!d) return;
    json out = editor::check_json(editor::check(*d, body.value("file", "diagram.fbd")));
    out["ok"] = true;
    reply(res, 200, out);
  });

  // The diagram against a plant model of `rtplc sim`, in virtual time, in
  // this process (never in the runtime): the plot rows, figures and CSV.
  http_->Post("/api/fbd/simulate", [this, diagram_of](const httplib::Request& req, httplib::Response& res) {
    if (guard(req, res, Role::kViewer, true, nullptr) != 0) return;
    json body;
    auto d = diagram_of(req, res, &body);
    if (!d) return;
    auto out = editor::simulate(*d, body.value("simulation", json::object()));
    if (!out) return fail(res, 400, "bad_simulation", out.error());
    (*out)["ok"] = true;
    reply(res, 200, *out);
  });

  // An SFC chart or a PLCopen project as the editor shows it, read-only.
  http_->Post("/api/view", [this](const httplib::Request& req, httplib::Response& res) {
    if (guard(req, res, Role::kViewer, true, nullptr) != 0) return;
    const json body = json::parse(req.body, nullptr, false);
    if (!body.is_object() || !body.contains("text") || !body["text"].is_string()) {
      return fail(res, 400, "bad_request", "the body is {\"text\": SFC or PLCopen XML, \"file\"?: NAME}");
    }
    const std::string text = body["text"].get<std::string>();
    const std::string file = body.value("file", std::string("program"));
    if (lang::plcopen::is_plcopen_source(text)) {
      auto v = editor::plcopen_view(text, file);
      if (!v) return fail(res, 422, "syntax", v.error());
      (*v)["ok"] = true;
      (*v)["kind"] = "plcopen";
      return reply(res, 200, *v);
    }
    auto chart = chart_json(text);
    if (!chart) return fail(res, 422, "syntax", file + ": " + chart.error());
    (*chart)["ok"] = true;
    (*chart)["kind"] = "sfc";
    reply(res, 200, *chart);
  });

  // The workspace (`--workspace DIR`): the .fbd files the editor lists, opens
  // and saves. Saving writes a program onto the box: an engineer's.
  auto no_workspace = [](httplib::Response& res) {
    fail(res, 404, "no_workspace", "this console has no workspace: start it with rtplc web --workspace DIR");
  };
  http_->Get("/api/workspace", [this, no_workspace](const httplib::Request& req, httplib::Response& res) {
    if (guard(req, res, Role::kViewer, false, nullptr) != 0) return;
    if (!workspace_) return no_workspace(res);
    auto files = workspace_->list();
    if (!files) return fail(res, 500, "workspace", files.error());
    json list = json::array();
    for (const auto& f : *files) {
      list.push_back({{"name", f.name}, {"bytes", f.bytes}, {"mtime_s", f.mtime_s}, {"has_layout", f.has_layout}});
    }
    reply(res, 200, json{{"ok", true}, {"dir", workspace_->dir()}, {"files", list}});
  });
  http_->Get("/api/workspace/file", [this, no_workspace](const httplib::Request& req, httplib::Response& res) {
    if (guard(req, res, Role::kViewer, false, nullptr) != 0) return;
    if (!workspace_) return no_workspace(res);
    auto f = workspace_->load(req.get_param_value("name"));
    if (!f) return fail(res, 404, "not_found", f.error());
    reply(res, 200, json{{"ok", true}, {"name", req.get_param_value("name")}, {"text", f->text},
                         {"layout", f->layout ? *f->layout : json(nullptr)}});
  });
  http_->Post("/api/workspace/save", [this, no_workspace](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kEngineer, true, &s) != 0) return;
    if (!workspace_) return no_workspace(res);
    const json body = json::parse(req.body, nullptr, false);
    if (!body.is_object() || !body.contains("name") || !body["name"].is_string() || !body.contains("text") ||
        !body["text"].is_string()) {
      return fail(res, 400, "bad_request", "the body is {\"name\": \"NAME.fbd\", \"text\": FBD, \"layout\": LAYOUT}");
    }
    const json* layout = body.contains("layout") && body["layout"].is_object() ? &body["layout"] : nullptr;
    const std::string name = body["name"].get<std::string>();
    if (auto r = workspace_->save(name, body["text"].get<std::string>(), layout); !r) {
      return fail(res, 409, "refused", r.error());
    }
    reply(res, 200, json{{"ok", true}, {"name", name}, {"saved_by", s.user}});
  });

  // Every channel with its description and current value, from the image.
  http_->Get("/api/channels", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kViewer, false, &s) != 0) return;
    auto img = io::ProcessImage::attach(opt_.runtime_name);
    if (!img) return fail(res, 502, "unreachable", img.error());
    const std::string text = sched::monitor_json(*img, img->liveness(), req.get_param_value("filter"));
    res.set_content(text, "application/json");
  });

  // The tasks' latency histograms, as `rtplc stats --hist` writes them: per
  // task and series, the non-empty buckets [lower bound ns, count].
  http_->Get("/api/jitter", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kViewer, false, &s) != 0) return;
    auto img = io::ProcessImage::attach(opt_.runtime_name);
    if (!img) return fail(res, 502, "unreachable", img.error());
    json tasks = json::array();
    for (const sched::TaskStatsView& v : sched::read_task_stats(*img)) {
      auto series = [](const sched::StatsSnapshot& snap) {
        json buckets = json::array();
        for (uint32_t b = 0; b < sched::LatencyHistogram::kBuckets; ++b) {
          if (snap.buckets[b] != 0) buckets.push_back({sched::LatencyHistogram::bucket_lower(b), snap.buckets[b]});
        }
        return json{{"count", snap.count}, {"min_ns", snap.min_ns}, {"p50_ns", snap.p50_ns}, {"p99_ns", snap.p99_ns},
                    {"p99_9_ns", snap.p999_ns}, {"max_ns", snap.max_ns}, {"buckets", buckets}};
      };
      tasks.push_back({{"name", v.name}, {"period_ns", v.period_ns}, {"policy", v.policy}, {"priority", v.priority},
                       {"wake", series(v.wake)}, {"exec", series(v.exec)}});
    }
    reply(res, 200, json{{"ok", true}, {"alive", img->liveness().alive}, {"tasks", tasks}});
  });

  // Trends: a trace of up to 8 channels of one task, every cycle, drained
  // from the task's trace ring in the image (nothing lost unsaid, nothing
  // interpolated). POST starts it (the runtime's `trace`, an engineer's), the
  // stream sends the new records every 100 ms and renews the lease; the trace
  // ends when the stream does or on POST /api/trend/stop.
  http_->Post("/api/trend", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kEngineer, true, &s) != 0) return;
    const json body = json::parse(req.body, nullptr, false);
    if (!body.is_object() || !body.contains("labels") || !body["labels"].is_array()) {
      return fail(res, 400, "bad_request", "the body is {\"labels\": [LABEL, ...]}");
    }
    auto answer = ask(s, "trace", {{"labels", body["labels"]}}, "", 10000);
    if (!answer) return fail(res, 502, "unreachable", answer.error());
    if (!answer->value("ok", false)) return reply(res, status_of((*answer)["error"].value("code", "refused")), *answer);
    const json& r = (*answer)["result"];
    Trend t;
    t.token = r.value("token", "");
    t.task_index = r.value("task_index", uint32_t{0});
    t.first_record = r.value("first_record", uint64_t{0});
    t.n = static_cast<uint32_t>(r["columns"].size());
    t.session = cookie_value(req, kCookie);
    const std::string id = random_token();
    {
      std::lock_guard lock(mu_);
      trends_[id] = t;
    }
    reply(res, 200, json{{"ok", true}, {"id", id}, {"task", r.value("task", "")}, {"period_ns", r.value("period_ns", 0)},
                         {"columns", r["columns"]}});
  });

  http_->Post("/api/trend/stop", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kEngineer, true, &s) != 0) return;
    const json body = json::parse(req.body, nullptr, false);
    const std::string id = body.is_object() && body.contains("id") && body["id"].is_string() ? body["id"].get<std::string>() : "";
    Trend t;
    {
      std::lock_guard lock(mu_);
      auto it = trends_.find(id);
      if (it == trends_.end() || it->second.session != cookie_value(req, kCookie)) {
        return fail(res, 404, "not_found", "no trend " + id + " of this session");
      }
      t = it->second;
      trends_.erase(it);
    }
    (void)ask(s, "trace_end", {{"token", t.token}}, "", 3000);
    reply(res, 200, json{{"ok", true}});
  });

  http_->Get("/api/trend/stream", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kEngineer, false, &s) != 0) return;
    const std::string id = req.get_param_value("id");
    Trend t;
    {
      std::lock_guard lock(mu_);
      auto it = trends_.find(id);
      if (it == trends_.end() || it->second.session != cookie_value(req, kCookie)) {
        return fail(res, 404, "not_found", "no trend " + id + " of this session (POST /api/trend starts one)");
      }
      t = it->second;
    }
    auto img = io::ProcessImage::attach(opt_.runtime_name);
    if (!img) return fail(res, 502, "unreachable", img.error());
    auto image = std::make_shared<io::ProcessImage>(std::move(img).value());
    const io::TraceBlock* block = image->trace_block(t.task_index);
    if (block == nullptr) return fail(res, 502, "unreachable", "the runtime's image has no trace ring for that task");
    auto reader = std::make_shared<io::TraceReader>(block, t.first_record, t.n);
    auto state = std::make_shared<TrendStream>();
    state->next_renew_ns = kernel_rt::monotonic_now_ns() + 1'000'000'000;
    res.set_header("X-Accel-Buffering", "no");
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, s, t, id, image, reader, state](size_t, httplib::DataSink& sink) {
          {
            std::unique_lock lock(snap_mu_);
            snap_cv_.wait_for(lock, std::chrono::milliseconds(100), [this] { return quit_.load(); });
          }
          if (quit_.load()) return false;
          {
            std::lock_guard lock(mu_);
            if (trends_.find(id) == trends_.end()) {
              const std::string end = "event: ended\ndata: {\"why\": \"stopped\"}\n\n";
              sink.write(end.data(), end.size());
              return false;
            }
          }
          json out = {{"samples", json::array()}};
          const int64_t now = kernel_rt::monotonic_now_ns();
          if (now >= state->next_renew_ns) {
            state->next_renew_ns = now + 1'000'000'000;
            auto k = ask(s, "trace_keep", {{"token", t.token}}, "", 2000);
            if (!k || !k->value("ok", false)) {
              const std::string why = !k ? k.error() : sched::refusal_message(*k, "the runtime ended the trace");
              const std::string end = "event: ended\ndata: " + json{{"why", why}}.dump() + "\n\n";
              sink.write(end.data(), end.size());
              return false;
            }
          }
          state->batch.clear();
          reader->drain(state->batch);
          for (const io::TraceSample& x : state->batch) {
            if (!state->started) {
              state->started = true;
              state->t0 = x.release_ns;
            }
            json row = json::array({static_cast<double>(x.release_ns - state->t0) / 1e9, x.cycle, x.record});
            for (uint32_t k = 0; k < t.n; ++k) row.push_back(std::isfinite(x.values[k]) ? json(x.values[k]) : json(nullptr));
            out["samples"].push_back(std::move(row));
          }
          out["lost"] = reader->lost();
          const std::string line = "data: " + out.dump() + "\n\n";
          return sink.write(line.data(), line.size());
        },
        [this, s, t, id](bool) {
          // The stream ended (the browser left, or the trace ended): so does the trace.
          bool mine = false;
          {
            std::lock_guard lock(mu_);
            mine = trends_.erase(id) > 0;
          }
          if (mine) (void)ask(s, "trace_end", {{"token", t.token}}, "", 3000);
        });
  });

  // The live stream: server-sent events, one `data:` line per snapshot with
  // the subscribed channels (all when `channels` is empty).
  http_->Get("/api/live", [this](const httplib::Request& req, httplib::Response& res) {
    Session s;
    if (guard(req, res, Role::kViewer, false, &s) != 0) return;
    // `channels=A,B`: those only; `channels=` (empty): none, the frames then
    // carry the runtime's state alone; no `channels`: all.
    const bool all = !req.has_param("channels");
    std::vector<std::string> wanted;
    const std::string list = req.get_param_value("channels");
    for (size_t at = 0; at < list.size();) {
      size_t end = list.find(',', at);
      if (end == std::string::npos) end = list.size();
      if (end > at) wanted.push_back(list.substr(at, end - at));
      at = end + 1;
    }
    std::sort(wanted.begin(), wanted.end());
    const std::string token = cookie_value(req, kCookie);
    res.set_header("X-Accel-Buffering", "no");
    res.set_chunked_content_provider(
        "text/event-stream", [this, all, wanted, token, last = uint64_t{0}](size_t, httplib::DataSink& sink) mutable {
          std::shared_ptr<const Snapshot> snap;
          {
            std::unique_lock lock(snap_mu_);
            snap_cv_.wait_for(lock, std::chrono::seconds(1), [&] { return quit_.load() || (snap_ && snap_->seq != last); });
            if (quit_.load()) return false;
            snap = snap_;
          }
          {
            std::lock_guard lock(mu_);
            if (sessions_.find(token) == sessions_.end()) return false;  // logged out
          }
          if (!snap || snap->seq == last) return sink.write(": idle\n\n", 9);  // keeps proxies and the browser patient
          // Changes only to a client that has the previous snapshot.
          const bool changes = !snap->key && last != 0 && last + 1 == snap->seq;
          last = snap->seq;
          size_t n = 0;
          const std::string own = all ? std::string() : live_event(*snap, &wanted, changes, &n);
          if (!all && changes && n == 0) return true;  // none of its channels changed: nothing to send
          const std::string& line = all ? (changes ? snap->all_changes : snap->all) : own;
          return sink.write(line.data(), line.size());
        });
  });

  http_->set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (res.status == 404 && req.path.rfind("/api/", 0) == 0) fail(res, 404, "not_found", "no route " + req.path);
  });
}

void WebConsole::sample_loop() {
  std::unique_ptr<io::ProcessImage> img;
  uint64_t seq = 0;
  const auto period_ns = static_cast<int64_t>(1e9 / std::max(0.5, opt_.sample_hz));
  constexpr int64_t kKeyEveryNs = 1'000'000'000;
  int64_t next = kernel_rt::monotonic_now_ns();
  int64_t last_attach_ns = 0, last_key_ns = 0;
  std::shared_ptr<const Snapshot> prev;
  while (!quit_.load()) {
    auto snap = std::make_shared<Snapshot>();
    snap->runtime = opt_.runtime_name;
    snap->taken_ns = kernel_rt::monotonic_now_ns();
    io::Liveness live;
    if (img) live = img->liveness();
    // A runtime that restarted has a new image: attach again while ours is dead.
    bool attached = false;
    if ((!img || !live.alive) && snap->taken_ns - last_attach_ns > 1'000'000'000) {
      last_attach_ns = snap->taken_ns;
      if (auto a = io::ProcessImage::attach(opt_.runtime_name); a.ok()) {
        img = std::make_unique<io::ProcessImage>(std::move(a).value());
        live = img->liveness();
        attached = true;
      }
    }
    if (img) {
      snap->alive = live.alive;
      snap->values.reserve(img->channel_count());
      for (uint32_t c = 0; c < img->channel_count(); ++c) {
        const io::ChannelValue v = img->read_channel(c);
        Snapshot::Value out;
        out.label = img->channel(c).label;
        out.value = v.value;
        out.quality = sched::shown_quality(*img, c, v, live);
        out.age_s = v.timestamp_ns != 0 ? io::age_s(v.timestamp_ns) : -1;
        out.forced = v.forced;
        snap->values.push_back(std::move(out));
      }
    }
    // What changed since the previous snapshot: value (bit for bit, so a NaN
    // that stays NaN is no change), status, force. Anything else (another
    // image, the runtime's death) makes this a key snapshot.
    bool any = false;
    snap->key = attached || !prev || prev->alive != snap->alive || prev->values.size() != snap->values.size() ||
                snap->taken_ns - last_key_ns >= kKeyEveryNs;
    for (size_t i = 0; !snap->key && i < snap->values.size(); ++i) {
      Snapshot::Value& v = snap->values[i];
      const Snapshot::Value& was = prev->values[i];
      if (v.label != was.label) {
        snap->key = true;
        break;
      }
      v.changed = std::memcmp(&v.value, &was.value, sizeof v.value) != 0 || std::strcmp(v.quality, was.quality) != 0 ||
                  v.forced != was.forced;
      any = any || v.changed;
    }
    if (snap->key || any) {
      if (snap->key) {
        last_key_ns = snap->taken_ns;
        for (Snapshot::Value& v : snap->values) v.changed = true;
      }
      snap->seq = ++seq;
      snap->all = live_event(*snap, nullptr, false);
      snap->all_changes = snap->key ? snap->all : live_event(*snap, nullptr, true);
      prev = snap;
      {
        std::lock_guard lock(snap_mu_);
        snap_ = std::move(snap);
      }
      snap_cv_.notify_all();
    }
    next += period_ns;
    const int64_t now = kernel_rt::monotonic_now_ns();
    if (next < now) next = now;  // behind (suspended, overloaded): start again from now, no burst
    std::unique_lock lock(snap_mu_);
    snap_cv_.wait_for(lock, std::chrono::nanoseconds(next - now), [this] { return quit_.load(); });
  }
}

}  // namespace rtplc::web
