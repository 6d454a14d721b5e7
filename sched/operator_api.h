// The operator API (issue "values you can trust", item 4; docs/api.md): every
// operator action — from the CLI, the web console, a Modbus write, Sparkplug —
// is one typed request, authorised by the caller's role and audited.
//
// A request is a JSON object {"op": NAME, "args": {...}} (and, for swap, the
// program source as a byte payload beside it); the answer is
//   {"v": 1, "ok": true,  "op": NAME, "result": {..., "text": "what the CLI prints"}}
//   {"v": 1, "ok": false, "op": NAME, "error": {"code": CODE, "message": "..."}}
// with CODE one of bad_request, unknown_op, forbidden, refused, version, busy.
// A front end running as the runtime's owner (the web console) adds
// "as": {"via": "web", "user": NAME, "role": ROLE} to ask on behalf of the
// user it authenticated: the caller is then "web NAME" with the lower of the
// two roles, in the audit trail as such.
//
//   op           role      args                                  result (besides text)
//   ping         viewer    -                                     name, api
//   whoami       viewer    -                                     who, uid, role
//   status       viewer    -                                     status (rtplc status --json)
//   values       viewer    filter?                               monitor (rtplc monitor --json)
//   stats        viewer    -                                     stats (rtplc stats --json)
//   audit        viewer    lines? (1..100000, default 50)        lines
//   set          operator  label, value                          label, value, was, retained
//   force        engineer  label, value                          label, value
//   unforce      engineer  label                                 label
//   unforce_all  engineer  -                                     -
//   swap         engineer  task, name, drop_outputs?  + source   task
//   rollback     engineer  task, drop_outputs?                   task
//   trace        engineer  labels                                token, task, task_index, period_ns,
//                                                                  first_record, columns [{label, dir, kind}]
//   trace_keep   engineer  token                                 -
//   trace_end    engineer  token                                 -
//   stop         admin     -                                     -
//
// Threads: call() runs on the runtime's control thread only (every Runtime
// method does, see control.h). set_point() is the one entry any thread may use
// (the modbus-server's request threads): it takes the runtime's set-point lock
// and the audit lock, nothing else.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "common/role.h"
#include "sched/audit.h"

namespace rtplc::sched {

class Runtime;

inline constexpr int kApiVersion = 1;

// Who asks. `who` names the caller in logs and the audit trail: "uid 1000
// (alice)", "modbus-server plant 10.0.0.7:50122", later "web alice".
struct Caller {
  std::string who;
  uint32_t uid = 0;  // the kernel's word (SO_PEERCRED); the runtime's own for in-process callers
  Role role = Role::kNone;
};

struct ApiAnswer {
  bool ok = false;
  nlohmann::json result = nlohmann::json::object();  // ok: always holds "text"
  std::string code;                                  // !ok
  std::string message;                               // !ok

  static ApiAnswer success(std::string text, nlohmann::json fields = nlohmann::json::object());
  static ApiAnswer failure(std::string code, std::string message);
  // The answer as sent: {"v": 1, "ok": ..., "op": op, "result"|"error": ...}.
  nlohmann::json to_json(const std::string& op) const;
};

// The role an op needs; nullopt for an op there is none of.
std::optional<Role> role_needed(std::string_view op);

class OperatorApi {
 public:
  // `log` as ControlServer::Log: one line per event worth telling the operator;
  // `error` marks lines a quiet runtime logs too (every force and unforce).
  using Log = std::function<void(bool error, const std::string& line)>;

  // The runtime owns its API (Runtime::api()), built once its state folder is
  // checked; the audit trail is NAME.audit beside its state file.
  explicit OperatorApi(Runtime& rt);
  // Where call() tells the operator what happened (the control server sets it
  // before its thread starts; set_point() never logs, it only audits).
  void set_log(Log log) { log_ = std::move(log); }
  const AuditLog& audit() const { return audit_; }

  // Control thread only. `payload` is the swap's source (empty otherwise).
  ApiAnswer call(const Caller& caller, const nlohmann::json& request, const std::string& payload = "");
  // Any thread: the `set` op for in-process writers. `durable`: the value is on
  // disk before the answer (the CLI's promise); a Modbus write is not, and its
  // retained value reaches the disk with the next coalesced save (at most
  // about 100 ms later, and at stop).
  ApiAnswer set_point(const Caller& caller, const std::string& label, double value, bool durable);

  // The role of a local caller: admin for root and the runtime's owner, else
  // what `runtime.operators` grants the uid or one of its groups.
  Role role_of_uid(uint32_t uid, uint32_t gid) const;
  // "uid 1000 (alice)".
  static std::string name_of_uid(uint32_t uid);

  // True once a caller asked the runtime to stop.
  bool stop_requested() const { return stop_requested_.load(std::memory_order_acquire); }

 private:
  ApiAnswer run(const Caller& caller, const std::string& op, const nlohmann::json& args, const std::string& payload);
  void record(const Caller& caller, const std::string& op, const std::string& asked, const ApiAnswer& a,
              bool tell = true);
  void say(bool error, const std::string& line) const {
    if (log_) log_(error, line);
  }

  Runtime& rt_;
  Log log_;
  AuditLog audit_;
  std::mutex audit_mu_;  // set_point() appends from other threads
  std::atomic<bool> stop_requested_{false};
};

}  // namespace rtplc::sched
