// `rtplc web`: the operator's console in the browser (docs/web.md).
//
// Its own process, below every task: it reads the runtime's process image
// read-only (values, for the live stream and the channel table) and does
// everything else as a client of the operator API over the control socket
// (sched/operator_api.h), on behalf of the user who logged in ("as": web
// NAME, their role). So neither a crash of this process nor any browser can
// change a task's timing or do what the user's role does not allow: the
// runtime checks the role again.
//
// HTTP by cpp-httplib (Debian's libcpp-httplib, with OpenSSL for TLS): one
// small library, a thread per connection, server-sent events for the live
// stream (a WebSocket's two-way channel is not needed: writes are POSTs).
// Loopback only unless TLS is given; every state-changing route is a POST
// with the session's CSRF token in X-CSRF-Token and no foreign Origin.
//
// Live values: one sampler thread reads the image at `sample_hz` (20 Hz) and
// publishes a snapshot with a sequence number when a value, status or force
// changed, and a key snapshot every second whatever happened. Each stream's
// thread waits for the next sequence: a client that had the previous one gets
// the changes only (a delta frame), any other (new, or slow and so behind) the
// whole set (a full frame), so a slow client skips snapshots, never queues
// them, and still ends up with every current value. A key frame refreshes the
// ages and keeps a quiet plant's console from looking stale.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.h"
#include "editor/workspace.h"
#include "io/trace_ring.h"
#include "common/role.h"
#include "kernel_rt/rt_thread.h"
#include "web/users.h"

namespace httplib {
class Server;
struct Request;
struct Response;
}  // namespace httplib

namespace rtplc::web {

// What one trend stream keeps between its frames.
struct TrendStream {
  std::vector<io::TraceSample> batch;
  bool started = false;
  int64_t t0 = 0;
  int64_t next_renew_ns = 0;
};

struct WebOptions {
  std::string runtime_name = "rtplc";
  std::string socket;  // the runtime's control socket; "" = found by name
  std::string host = "127.0.0.1";
  int port = 8480;  // 0 = any free port (tests)
  std::string tls_cert, tls_key;
  std::string users_path;  // "" = default_users_path(runtime_name)
  int link_minutes = 10;   // the one-time login link's life
  double sample_hz = 20;   // how often the image is read for the live stream
  int session_idle_minutes = 60;
  std::string workspace;  // the editor's folder of .fbd files; "" = none (upload/download only)
};

// Whether `host` is a loopback address (127.0.0.0/8, ::1, localhost).
bool is_loopback(const std::string& host);

class WebConsole {
 public:
  explicit WebConsole(WebOptions opt);
  ~WebConsole();
  WebConsole(const WebConsole&) = delete;
  WebConsole& operator=(const WebConsole&) = delete;

  // Binds the listening socket (refuses a non-loopback address without TLS)
  // and starts the sampler; the console serves once run() is called.
  Result<void> start();
  // Serves until stop() (from a signal handler's thread or another thread).
  void run();
  void stop();
  int port() const { return port_; }
  // "http://127.0.0.1:8480/login?token=...": opens an admin session once,
  // within link_minutes. A new call makes a new link (the old one stays valid
  // until used or expired).
  std::string login_link();

 private:
  struct Session {
    std::string user;
    Role role = Role::kNone;
    std::string csrf;
    int64_t last_used_ns = 0;
  };
  // A trend a session started: the runtime's trace and where its ring starts.
  struct Trend {
    std::string token;
    uint32_t task_index = 0;
    uint64_t first_record = 0;
    uint32_t n = 0;
    std::string session;  // only the session that started it may stream or stop it
  };
  struct Snapshot {
    uint64_t seq = 0;
    bool alive = false;
    std::string runtime;
    int64_t taken_ns = 0;
    bool key = false;  // every client gets it whole
    struct Value {
      std::string label;
      double value = 0;
      const char* quality = "bad";
      double age_s = -1;
      bool forced = false;
      bool changed = true;  // since the previous snapshot
    };
    std::vector<Value> values;
    // The events of every channel, whole and changes only, rendered once for
    // all the clients that want them all (most do): 20 browsers cost one
    // rendering, not 20.
    std::string all, all_changes;
  };
  // The live stream's event for `snap`: its channels in `wanted` (sorted; all
  // when null); with `changes_only` just those that changed since the previous
  // one. `count` gets how many channels it carries.
  static std::string live_event(const Snapshot& snap, const std::vector<std::string>* wanted, bool changes_only,
                                size_t* count = nullptr);

  void routes();
  // Asks the runtime `op` on behalf of the session's user.
  Result<nlohmann::json> ask(const Session& s, const std::string& op, const nlohmann::json& args,
                             const std::string& payload, int timeout_ms);
  // The session a request carries, or null; `why` gets the HTTP status to answer.
  const Session* session_of(const httplib::Request& req, std::string* token = nullptr);
  // 0 when the request may go on, else the status already written to `res`.
  int guard(const httplib::Request& req, httplib::Response& res, Role need, bool state_changing, Session* out);
  void api(const httplib::Request& req, httplib::Response& res, const std::string& op, Role need);
  void sample_loop();
  std::string origin() const;
  std::string origin_of(const httplib::Request& req) const;
  bool login_throttled(const std::string& addr, bool failed_now);

  WebOptions opt_;
  UserFile users_;
  std::unique_ptr<httplib::Server> http_;
  int port_ = 0;
  std::string socket_;
  std::mutex mu_;  // sessions_, link_tokens_, failures_
  std::map<std::string, Session> sessions_;
  std::map<std::string, int64_t> link_tokens_;  // token -> expiry (monotonic ns)
  std::map<std::string, std::vector<int64_t>> failures_;
  std::map<std::string, Trend> trends_;  // by id
  std::mutex snap_mu_;
  std::condition_variable snap_cv_;
  std::shared_ptr<const Snapshot> snap_;
  std::atomic<bool> quit_{false};
  kernel_rt::RtThread sampler_;
  std::optional<editor::Workspace> workspace_;
};

}  // namespace rtplc::web
