// The runtime's control channel (spec runtime.md, "Hot swap": local only, a Unix
// socket with mode 0600 — loading code is the most privileged act in a PLC).
//
// Any number of clients at once (an event loop; see ControlServer::run).
// Wire format, one request per connection:
//   request   VERB [ARG ...]\n            (ARGs are separated by single spaces)
//             swap TASK NAME BYTES\n<BYTES of source text>
//   response  OK\n or ERROR\n, then the body, then a line holding only "."
//             (a body line that starts with "." is sent with one more ".")
// Verbs: ping, status, set LABEL VALUE, swap, rollback TASK, stop,
//        force LABEL VALUE, unforce LABEL, unforce_all,
//        trace LABEL... (answers "trace TOKEN", "task NAME INDEX PERIOD_NS
//        FIRST_RECORD" and one "column LABEL DIR KIND" per label),
//        trace-keep TOKEN (renews the lease), trace-end TOKEN,
//        audit [N] (the last N lines of the audit trail, sched/audit.h).
// The server takes each client's uid from the socket (SO_PEERCRED) when it
// connects; forces are logged with it, and every write (set, force, unforce,
// swap, rollback, trace, stop), accepted or refused, goes to the audit trail.
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
#include "sched/audit.h"

namespace rtplc::sched {

class Runtime;

class ControlServer {
 public:
  // `log` receives one line per event worth telling the operator (swaps, set-points,
  // watchdog stops); called on the control thread. `error` also marks the lines
  // that must be logged even by a quiet runtime: every force and unforce
  // ("FORCE ...", "UNFORCE ...", with the peer's uid and the UTC time).
  using Log = std::function<void(bool error, const std::string& line)>;

  ControlServer(Runtime& rt, Log log) : rt_(rt), log_(std::move(log)) {}
  ~ControlServer();
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  // Creates the socket (and its folder, mode 0700) and starts the thread.
  Result<void> start(const std::string& path);
  void stop();
  // True once a client asked the runtime to stop.
  bool stop_requested() const { return stop_requested_.load(std::memory_order_acquire); }

 private:
  enum class RequestState { kIncomplete, kComplete, kBad };
  void run();
  // A request that has arrived whole is executed and its framed answer set.
  RequestState parse_request(const std::string& in, std::string& response, uint32_t uid);
  std::string execute(const std::vector<std::string>& words, const std::string& source, uint32_t uid);
  std::string run_verb(const std::vector<std::string>& words, const std::string& source, uint32_t uid);
  void watch_tasks();

  Runtime& rt_;
  Log log_;
  AuditLog audit_;
  std::string path_;
  int listen_fd_ = -1;
  kernel_rt::RtThread thread_;
  std::atomic<bool> quit_{false};
  std::atomic<bool> stop_requested_{false};
  std::vector<uint8_t> last_state_;
};

// The control socket of runtime `name`: `socket_override` when given, else the
// path the runtime published in its process image (attach() refuses an image
// owned by anyone but root or us, so the path is trusted), else the default.
std::string control_socket_of(const std::string& name, const std::string& socket_override);

// Client side (the rtplc commands). Sends one request and returns the body; an
// ERROR response becomes an error carrying the body.
Result<std::string> control_request(const std::string& socket_path, const std::string& line,
                                    const std::string& payload = "", int timeout_ms = 30000);

}  // namespace rtplc::sched
