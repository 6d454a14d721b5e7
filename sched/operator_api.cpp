// The operator API (see operator_api.h): authorisation, the ops, the audit.
#include "sched/operator_api.h"

#include "common/diagnostic.h"

#include <grp.h>
#include <pwd.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

#include "common/text.h"
#include "kernel_rt/clock.h"
#include "sched/runtime.h"
#include "sched/stats_source.h"

namespace rtplc::sched {
namespace {

using nlohmann::json;

struct OpSpec {
  const char* op;
  Role role;
  bool write;  // audited
};

constexpr OpSpec kOps[] = {
    {"ping", Role::kViewer, false},       {"whoami", Role::kViewer, false},
    {"status", Role::kViewer, false},     {"values", Role::kViewer, false},
    {"stats", Role::kViewer, false},      {"audit", Role::kViewer, false},
    {"set", Role::kOperator, true},       {"force", Role::kEngineer, true},
    {"unforce", Role::kEngineer, true},   {"unforce_all", Role::kEngineer, true},
    {"swap", Role::kEngineer, true},      {"rollback", Role::kEngineer, true},
    {"trace", Role::kEngineer, true},     {"trace_keep", Role::kEngineer, false},
    {"trace_end", Role::kEngineer, false}, {"stop", Role::kAdmin, true},
    {"swap_check", Role::kEngineer, false}, {"program", Role::kViewer, false},
    {"watch", Role::kViewer, false},
};

const OpSpec* spec_of(std::string_view op) {
  for (const OpSpec& s : kOps) {
    if (op == s.op) return &s;
  }
  return nullptr;
}

std::string op_list() {
  std::string out;
  for (const OpSpec& s : kOps) out += (out.empty() ? "" : ", ") + std::string(s.op);
  return out;
}

// Typed argument readers: a missing or mistyped argument is a bad_request
// naming it, never an exception.
const json* arg(const json& args, const char* name) {
  if (!args.is_object()) return nullptr;
  const auto it = args.find(name);
  return it == args.end() ? nullptr : &*it;
}

Result<std::string> text_arg(const json& args, const char* name) {
  const json* v = arg(args, name);
  if (v == nullptr || !v->is_string() || v->get_ref<const std::string&>().empty()) {
    return make_error(std::string("'") + name + "' must be a non-empty string");
  }
  return v->get<std::string>();
}

// A number, or the text the operator typed (refused with its own words).
Result<double> number_arg(const json& args, const char* name, const char* refusal) {
  const json* v = arg(args, name);
  if (v != nullptr && v->is_number()) return v->get<double>();
  if (v != nullptr && v->is_string()) {
    const std::string& w = v->get_ref<const std::string&>();
    char* end = nullptr;
    const double d = std::strtod(w.c_str(), &end);
    if (end != w.c_str() && *end == '\0') return d;  // "nan", "inf": the op refuses them with its reason
    return make_error(std::string(refusal) + "'" + w + "' is not a number");
  }
  return make_error(std::string("'") + name + "' must be a number");
}

Result<std::vector<std::string>> list_arg(const json& args, const char* name, bool required) {
  std::vector<std::string> out;
  const json* v = arg(args, name);
  if (v == nullptr && !required) return out;
  if (v == nullptr || !v->is_array()) return make_error(std::string("'") + name + "' must be a list of strings");
  for (const json& e : *v) {
    if (!e.is_string()) return make_error(std::string("'") + name + "' must be a list of strings");
    out.push_back(e.get<std::string>());
  }
  if (required && out.empty()) return make_error(std::string("'") + name + "' must name at least one");
  return out;
}

// Answer lines joined for one log line: "a; b".
std::string one_line(const std::string& text) {
  std::string out;
  size_t from = 0;
  while (from < text.size()) {
    size_t nl = text.find('\n', from);
    if (nl == std::string::npos) nl = text.size();
    if (nl > from) out += (out.empty() ? "" : "; ") + text.substr(from, nl - from);
    from = nl + 1;
  }
  return out;
}

ApiAnswer from(Result<std::string> r, json fields = json::object()) {
  return r ? ApiAnswer::success(*r, std::move(fields)) : ApiAnswer::failure("refused", r.error());
}

// JSON the runtime made itself, as an object (an empty object if it ever were not JSON).
json parsed(const std::string& text) {
  json j = json::parse(text, nullptr, false);
  return j.is_discarded() ? json::object() : j;
}

// The trace header (trace_ops.cpp: "trace TOKEN", "task NAME INDEX PERIOD_NS
// FIRST_RECORD", one "column LABEL DIR KIND" per channel) as typed fields.
json trace_fields(const std::string& text) {
  json f = {{"columns", json::array()}};
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream w(line);
    std::string what;
    w >> what;
    if (what == "trace") {
      std::string token;
      w >> token;
      f["token"] = token;
    } else if (what == "task") {
      std::string name;
      uint64_t index = 0, first = 0;
      int64_t period = 0;
      w >> name >> index >> period >> first;
      f["task"] = name;
      f["task_index"] = index;
      f["period_ns"] = period;
      f["first_record"] = first;
    } else if (what == "column") {
      std::string label, dir, kind;
      w >> label >> dir >> kind;
      f["columns"].push_back({{"label", label}, {"dir", dir}, {"kind", kind}});
    }
  }
  return f;
}

}  // namespace

ApiAnswer ApiAnswer::success(std::string text, json fields) {
  ApiAnswer a;
  a.ok = true;
  a.result = fields.is_object() ? std::move(fields) : json::object();
  a.result["text"] = std::move(text);
  return a;
}

ApiAnswer ApiAnswer::failure(std::string code, std::string message) {
  ApiAnswer a;
  a.code = std::move(code);
  a.message = std::move(message);
  return a;
}

json ApiAnswer::to_json(const std::string& op) const {
  json j = {{"v", kApiVersion}, {"ok", ok}, {"op", op}};
  if (ok) j["result"] = result;
  else j["error"] = {{"code", code}, {"message", message}};
  return j;
}

std::optional<Role> role_needed(std::string_view op) {
  const OpSpec* s = spec_of(op);
  return s ? std::optional<Role>(s->role) : std::nullopt;
}

OperatorApi::OperatorApi(Runtime& rt) : rt_(rt) {
  // Beside the state file in the runtime's checked state folder: NAME.audit.
  std::string path = rt_.state_path();
  if (path.size() > 6 && path.compare(path.size() - 6, 6, ".state") == 0) path.resize(path.size() - 6);
  audit_ = AuditLog(path + ".audit");
}

std::string OperatorApi::name_of_uid(uint32_t uid) {
  std::string out = "uid " + std::to_string(uid);
  passwd pw{};
  passwd* found = nullptr;
  char buf[4096];
  if (getpwuid_r(uid, &pw, buf, sizeof buf, &found) == 0 && found != nullptr) out += std::string(" (") + pw.pw_name + ")";
  return out;
}

Role OperatorApi::role_of_uid(uint32_t uid, uint32_t gid) const {
  if (uid == 0 || uid == geteuid()) return Role::kAdmin;
  Role best = Role::kNone;
  auto take = [&best](Role r) {
    if (!role_allows(best, r)) best = r;
  };
  bool wants_groups = false;
  for (const Runtime::Grant& g : rt_.grants()) {
    if (!g.group && g.id == uid) take(g.role);
    if (g.group && g.id == gid) take(g.role);
    wants_groups |= g.group;
  }
  if (!wants_groups) return best;
  // Every group the user is a member of, as the system says now.
  passwd pw{};
  passwd* found = nullptr;
  char buf[4096];
  if (getpwuid_r(uid, &pw, buf, sizeof buf, &found) != 0 || found == nullptr) return best;
  int n = 64;
  std::vector<gid_t> groups(static_cast<size_t>(n));
  if (getgrouplist(pw.pw_name, static_cast<gid_t>(gid), groups.data(), &n) < 0) {
    groups.resize(static_cast<size_t>(n));
    if (getgrouplist(pw.pw_name, static_cast<gid_t>(gid), groups.data(), &n) < 0) return best;
  }
  groups.resize(static_cast<size_t>(n));
  for (const Runtime::Grant& g : rt_.grants()) {
    if (!g.group) continue;
    for (gid_t member : groups) {
      if (member == g.id) take(g.role);
    }
  }
  return best;
}

ApiAnswer OperatorApi::call(const Caller& caller, const json& request, const std::string& payload) {
  if (!request.is_object()) return ApiAnswer::failure("bad_request", "a request is a JSON object {\"op\": ..., \"args\": {...}}");
  const json* op_field = arg(request, "op");
  if (op_field == nullptr || !op_field->is_string()) {
    return ApiAnswer::failure("bad_request", "the request names no \"op\" (one of " + op_list() + ")");
  }
  const std::string op = op_field->get<std::string>();
  const OpSpec* spec = spec_of(op);
  if (spec == nullptr) return ApiAnswer::failure("unknown_op", "unknown op '" + op + "' (one of " + op_list() + ")");
  // A front end that runs as the runtime's owner (the web console) asks on
  // behalf of the user it authenticated: {"as": {"via": "web", "user": "alice",
  // "role": "operator"}}. Only an admin peer may; the role is the lower of both.
  Caller eff = caller;
  if (const json* as = arg(request, "as")) {
    if (!role_allows(caller.role, Role::kAdmin)) {
      ApiAnswer a = ApiAnswer::failure("forbidden", caller.who + " may not ask on behalf of another user");
      record(caller, op, op + " (on behalf of another user)", a);
      return a;
    }
    const json* user = arg(*as, "user");
    const json* role = arg(*as, "role");
    const json* via = arg(*as, "via");
    auto printable = [](const json* v) {
      if (v == nullptr || !v->is_string()) return false;
      const std::string& t = v->get_ref<const std::string&>();
      if (t.empty() || t.size() > 64) return false;
      for (char c : t) {
        if (static_cast<unsigned char>(c) <= ' ' || c == 0x7f) return false;
      }
      return true;
    };
    Role claimed = Role::kNone;
    if (role != nullptr && role->is_string()) claimed = parse_role(role->get<std::string>()).value_or(Role::kNone);
    if (!printable(user) || !printable(via) || claimed == Role::kNone) {
      return ApiAnswer::failure("bad_request", "\"as\" takes {\"via\": NAME, \"user\": NAME, \"role\": ROLE}");
    }
    eff.who = via->get<std::string>() + " " + user->get<std::string>();
    eff.role = role_allows(caller.role, claimed) ? claimed : caller.role;
  }
  const json* args_field = arg(request, "args");
  const json args = args_field != nullptr ? *args_field : json::object();
  if (!args.is_object()) return ApiAnswer::failure("bad_request", "\"args\" must be an object");
  std::string asked = op;
  for (const auto& [k, v] : args.items()) {
    asked += " " + k + "=";
    if (v.is_string()) asked += v.get<std::string>();
    else if (v.is_number()) asked += format_number(v.get<double>());
    else asked += v.dump(-1, ' ', false, json::error_handler_t::replace);
  }
  if (op == "swap") asked += " (" + std::to_string(payload.size()) + " bytes of source)";
  ApiAnswer a;
  if (!role_allows(eff.role, spec->role)) {
    a = ApiAnswer::failure("forbidden", eff.who + " is " + (eff.role == Role::kNone ? "not an operator" : std::string("a ") + role_name(eff.role)) +
                                             " of runtime " + rt_.name() + "; '" + op + "' needs the role " +
                                             role_name(spec->role) + " (runtime.operators in its config)");
  } else {
    a = run(eff, op, args, payload);
  }
  if (spec->write || a.code == "forbidden") record(eff, op, asked, a);
  return a;
}

ApiAnswer OperatorApi::set_point(const Caller& caller, const std::string& label, double value, bool durable) {
  ApiAnswer a;
  if (!role_allows(caller.role, Role::kOperator)) {
    a = ApiAnswer::failure("forbidden", caller.who + " may not set set-points");
  } else {
    double was = 0;
    auto r = rt_.set_value(label, value, durable, &was);
    a = r ? ApiAnswer::success(*r, {{"label", label}, {"value", value}, {"was", was}})
          : ApiAnswer::failure("refused", r.error());
  }
  record(caller, "set", "set label=" + label + " value=" + format_number(value), a, false);
  return a;
}

// One line per write, accepted or refused: when, who, what was asked, what
// came of it (set and force say the value before: "SP = 60 (was 50)").
void OperatorApi::record(const Caller& caller, const std::string& op, const std::string& asked, const ApiAnswer& a,
                         bool tell) {
  std::string said = one_line(a.ok ? a.result.value("text", std::string()) : a.message);
  if (said.size() > 400) said = said.substr(0, 400) + "...";
  const std::string line = format_utc(kernel_rt::realtime_now_ns()) + " " + caller.who + " [" +
                           role_name(caller.role) + "] " + asked + (a.ok ? ": " : ": refused: ") + said;
  Result<void> r;
  {
    std::lock_guard lock(audit_mu_);
    if (!audit_.path().empty()) r = audit_.append(line);
  }
  if (!tell) return;  // another thread: the log is the control thread's
  if (!r) say(true, r.error());
  if (op == "set" && a.ok) say(false, "set " + said + " by " + caller.who);
  if (a.code == "forbidden") say(true, "refused " + asked + ": " + a.message);
}

ApiAnswer OperatorApi::run(const Caller& caller, const std::string& op, const json& args, const std::string& payload) {
  const std::string who = " by " + caller.who + " at " + format_utc(kernel_rt::realtime_now_ns());
  auto bad = [](const std::string& why) { return ApiAnswer::failure("bad_request", why); };
  if (op == "ping") {
    return ApiAnswer::success("pong " + rt_.name(), {{"name", rt_.name()}, {"api", kApiVersion}});
  }
  if (op == "whoami") {
    return ApiAnswer::success(caller.who + ": " + role_name(caller.role) + " of runtime " + rt_.name(),
                              {{"who", caller.who}, {"uid", caller.uid}, {"role", role_name(caller.role)}});
  }
  if (op == "status") return ApiAnswer::success(rt_.status(), {{"status", parsed(rt_.status_json())}});
  if (op == "values" || op == "stats") {
    std::string filter;
    if (const json* f = arg(args, "filter")) {
      if (!f->is_string()) return bad("'filter' must be a string");
      filter = f->get<std::string>();
    }
    io::ProcessImage& img = rt_.image();
    const std::string text = op == "values" ? monitor_json(img, img.liveness(), filter) : stats_json(img);
    return ApiAnswer::success(text, {{op == "values" ? "monitor" : "stats", parsed(text)}});
  }
  if (op == "audit") {
    size_t n = 50;
    if (const json* v = arg(args, "lines")) {
      if (!v->is_number_integer() || v->get<int64_t>() < 1 || v->get<int64_t>() > 100000) {
        return bad("audit takes a number of lines, 1 to 100000");
      }
      n = static_cast<size_t>(v->get<int64_t>());
    }
    Result<std::vector<std::string>> lines = make_error("no audit trail");
    {
      std::lock_guard lock(audit_mu_);
      lines = audit_.tail(n);
    }
    if (!lines) return ApiAnswer::failure("refused", lines.error());
    std::string body;
    for (const std::string& l : *lines) body += l + "\n";
    return ApiAnswer::success(body.empty() ? "no action recorded yet in " + audit_.path() + "\n" : body,
                              {{"lines", *lines}});
  }
  if (op == "set") {
    auto label = text_arg(args, "label");
    if (!label) return bad(label.error());
    auto v = number_arg(args, "value", "");
    if (!v) return bad(v.error());
    double was = 0;
    auto r = rt_.set_value(*label, *v, true, &was);
    return from(std::move(r), {{"label", *label}, {"value", *v}, {"was", was}});
  }
  if (op == "force") {
    auto label = text_arg(args, "label");
    if (!label) return bad(label.error());
    auto v = number_arg(args, "value", "not forced: ");
    if (!v) return bad(v.error());
    auto r = rt_.force(*label, *v, caller.uid);
    say(true, "FORCE " + *label + " = " + format_number(*v) + who + (r ? ": " + *r : ": refused: " + r.error()));
    return from(std::move(r), {{"label", *label}, {"value", *v}});
  }
  if (op == "unforce") {
    auto label = text_arg(args, "label");
    if (!label) return bad(label.error());
    auto r = rt_.unforce(*label);
    if (r) say(true, "UNFORCE " + *label + who + ": " + *r);
    return from(std::move(r), {{"label", *label}});
  }
  if (op == "unforce_all") {
    auto r = rt_.unforce_all();
    if (r) say(true, "UNFORCE --all" + who + ": " + one_line(*r));
    return from(std::move(r));
  }
  if (op == "swap" || op == "swap_check") {
    auto task = text_arg(args, "task");
    if (!task) return bad(task.error());
    auto name = text_arg(args, "name");
    if (!name) return bad(name.error());
    auto drop = list_arg(args, "drop_outputs", false);
    if (!drop) return bad(drop.error());
    if (op == "swap_check") return from(rt_.swap_check(*task, payload, *name, *drop), {{"task", *task}});
    auto r = rt_.swap(*task, payload, *name, *drop);
    if (r) {
      // One log line per swap: its first two answer lines (compiled, installed).
      say(false, "swap of " + *task + who + ": " + one_line(r->substr(0, r->find('\n', r->find('\n') + 1))));
    } else {
      say(true, "swap of " + *task + who + " refused: " + r.error().substr(0, r.error().find('\n')));
    }
    return from(std::move(r), {{"task", *task}});
  }
  if (op == "watch") {
    auto task = text_arg(args, "task");
    if (!task) return bad(task.error());
    auto w = rt_.watch(*task);
    if (!w) return ApiAnswer::failure("refused", w.error());
    json blocks = json::array();
    for (const auto& b : w->blocks) {
      // A STRING's value is its text (docs/api.md, "watch"), a byte that is not
      // UTF-8 written \xNN so the answer stays JSON.
      json value = b.text ? json(escape_for_terminal(*b.text, true)) : json(b.value);
      blocks.push_back({{"name", b.name}, {"kind", b.kind}, {"value", value}, {"quality", quality_name(b.quality)}});
    }
    return ApiAnswer::success("task " + *task + ": " + std::to_string(w->blocks.size()) + " block outputs" +
                                  (w->pending ? " (the first watch snapshot is on its way)" : ""),
                              {{"task", *task}, {"pending", w->pending}, {"cycle", w->cycle}, {"age_s", w->age_s},
                               {"program", w->program}, {"blocks", blocks}});
  }
  if (op == "program") {
    auto task = text_arg(args, "task");
    if (!task) return bad(task.error());
    const json* h = arg(args, "hash");
    if (h != nullptr && !h->is_string()) return bad("\"hash\" is a program hash (16 hex digits)");
    auto r = rt_.program_info(*task, h ? h->get<std::string>() : std::string());
    if (!r) return ApiAnswer::failure("refused", r.error());
    json versions = json::array();
    for (const ProgramVersion& v : r->history) {
      versions.push_back({{"hash", v.hash}, {"time", format_utc(v.realtime_ns)}, {"origin", v.origin}});
    }
    const std::string hash = h ? h->get<std::string>() : r->hash;
    return ApiAnswer::success("task " + *task + ": program " + hash + " (" + std::to_string(r->source.size()) + " bytes)",
                              {{"task", *task}, {"file", r->file}, {"origin", r->origin}, {"running", r->hash},
                               {"hash", hash.empty() ? r->hash : hash}, {"history", versions}, {"source", r->source}});
  }
  if (op == "rollback") {
    auto task = text_arg(args, "task");
    if (!task) return bad(task.error());
    auto drop = list_arg(args, "drop_outputs", false);
    if (!drop) return bad(drop.error());
    auto r = rt_.rollback(*task, *drop);
    if (r) say(false, "rollback of " + *task + who + ": " + r->substr(0, r->find('\n')));
    return from(std::move(r), {{"task", *task}});
  }
  if (op == "trace") {
    auto labels = list_arg(args, "labels", true);
    if (!labels) return bad(labels.error());
    auto r = rt_.trace_start(*labels);
    if (!r) return from(std::move(r));
    std::string list;
    for (size_t i = 0; i < labels->size(); ++i) list += (i ? ", " : "") + (*labels)[i];
    say(false, r->substr(0, r->find('\n')) + " started: " + list);
    return ApiAnswer::success(*r, trace_fields(*r));
  }
  if (op == "trace_keep" || op == "trace_end") {
    auto token = text_arg(args, "token");
    if (!token) return bad(token.error());
    auto r = op == "trace_keep" ? rt_.trace_keep(*token) : rt_.trace_end(*token);
    if (r && op == "trace_end") say(false, "trace " + *token + " ended by its reader");
    return from(std::move(r));
  }
  if (op == "stop") {
    say(false, "stop requested" + who);
    stop_requested_.store(true, std::memory_order_release);
    return ApiAnswer::success("stopping runtime " + rt_.name());
  }
  return ApiAnswer::failure("unknown_op", "unknown op '" + op + "'");
}

}  // namespace rtplc::sched
