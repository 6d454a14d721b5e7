// The runtime's control channel (spec runtime.md, "Hot swap": local only, a Unix
// socket — loading code is the most privileged act in a PLC). It carries the
// operator API (operator_api.h; docs/api.md), one request per connection:
//   frame     RTPLC-API 1 JSON_BYTES PAYLOAD_BYTES\n<JSON><PAYLOAD>
// both ways: "1" is the API version, the JSON a request {"op", "args"} or an
// answer {"v", "ok", "op", "result" | "error"}, the payload the source of a
// swap (bytes as they are, no escaping; 0 otherwise). A frame of another
// version is answered with the error code "version" and the version spoken.
//
// The server takes each client's uid and gid from the socket (SO_PEERCRED)
// when it connects and asks the API for its role: the owner and root are admin,
// others what `runtime.operators` grants. Without grants the socket is 0600 in
// a 0700 folder; with grants it is 0666 in a 0711 folder (others may reach it
// by name, not list or change the folder), and the role decides each request.
//
// The server's thread is the runtime's control thread: every Runtime method runs
// on it, one request at a time, so nothing on the control side needs a lock. Its
// poll loop also frees retired programs and watches the tasks for watchdog stops.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "common/result.h"
#include "kernel_rt/rt_thread.h"
#include "sched/operator_api.h"

namespace rtplc::sched {

class Runtime;

class ControlServer {
 public:
  // `log` receives one line per event worth telling the operator (swaps, set-points,
  // watchdog stops); called on the control thread. `error` also marks the lines
  // that must be logged even by a quiet runtime: every force and unforce
  // ("FORCE ...", "UNFORCE ...", with the peer's uid and the UTC time).
  using Log = std::function<void(bool error, const std::string& line)>;

  ControlServer(Runtime& rt, Log log);
  ~ControlServer();
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  // Creates the socket (and its folder, mode 0700) and starts the thread.
  Result<void> start(const std::string& path);
  void stop();
  // True once a client asked the runtime to stop.
  bool stop_requested() const { return api_.stop_requested(); }

 private:
  enum class RequestState { kIncomplete, kComplete, kBad };
  void run();
  // A request that has arrived whole is executed and its framed answer set.
  RequestState parse_request(const std::string& in, std::string& response, const Caller& caller);
  void watch_tasks();

  Runtime& rt_;
  Log log_;
  OperatorApi& api_;  // the runtime's
  std::string path_;
  int listen_fd_ = -1;
  kernel_rt::RtThread thread_;
  std::atomic<bool> quit_{false};
  std::vector<uint8_t> last_state_;
};

// The control socket of runtime `name`: `socket_override` when given, else the
// path the runtime published in its process image (attach() refuses an image
// owned by anyone but root or us, so the path is trusted), else the default.
std::string control_socket_of(const std::string& name, const std::string& socket_override);

// How long a client waits for a swap's or a rollback's answer: the runtime may
// be compiling native code (blocks/native.h, at most kNativeCompileTimeoutS).
inline constexpr int kSwapAnswerMs = 360'000;

// Client side. Sends one request and returns the runtime's answer object
// (ok or not); an error only when no whole answer came (the socket is not
// there, the runtime died mid-answer, the time ran out).
Result<nlohmann::json> api_request(const std::string& socket_path, const nlohmann::json& request,
                                   const std::string& payload = "", int timeout_ms = 30000);

// The rtplc commands' words as a typed request: "set SP 42", "force L V",
// "unforce L", "unforce_all", "swap TASK NAME BYTES [drop=A,B]" (payload: the
// source), "rollback TASK [drop=A,B]", "trace L...", "trace-keep TOKEN",
// "trace-end TOKEN", "audit [N]", "status [json]", "ping", "whoami", "stop".
// Returns the answer's text ("status json": the status object as JSON text);
// a refusal becomes an error carrying its message.
Result<std::string> control_request(const std::string& socket_path, const std::string& line,
                                    const std::string& payload = "", int timeout_ms = 30000);
// The message of a refusal (`{"ok": false, "error": {"message": ...}}`), or
// `fallback` when the answer carries none.
std::string refusal_message(const nlohmann::json& answer, const std::string& fallback);
// The same words as the request object (what control_request sends).
Result<nlohmann::json> request_of_words(const std::string& line);

}  // namespace rtplc::sched
