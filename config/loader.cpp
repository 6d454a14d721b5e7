// The runtime configuration loader (spec runtime.md, "Configuration"): YAML
// text -> RuntimeConfig, every key checked against config/schema.cpp, every
// problem a diagnostic with its file:line:col. It collects all the problems it
// can in one pass, never throws and never reads the FBD programs (the runtime
// compiles them); at most it checks that they exist.
#include <cctype>
#include <algorithm>
#include <map>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include <yaml-cpp/eventhandler.h>

#include "common/files.h"
#include "config/config.h"
#include "config/driver_kinds.h"
#include "config/schema.h"
#include "config/yaml_reader.h"

namespace rtplc::config {
namespace {

namespace fs = std::filesystem;

// A config is a few hundred lines; anything far larger is a mistake (a log
// or a binary passed by accident) and not worth parsing.
constexpr size_t kMaxConfigBytes = size_t{1} << 20;

SourcePos or_else(SourcePos p, SourcePos fallback) {
  return p.line ? p : fallback;
}

std::string line_of(SourcePos p) {
  return "line " + std::to_string(p.line);
}

// Caret width of the plain or quoted scalar at `p`, for checks made after
// parsing, when only the position was kept.
uint32_t token_width(std::string_view source, SourcePos p) {
  std::string_view line = source_line(source, p.line);
  if (p.col == 0 || p.col > line.size()) return 1;
  line.remove_prefix(p.col - 1);
  size_t n = 0;
  if (line[0] == '"' || line[0] == '\'') {
    const size_t close = line.find(line[0], 1);
    n = close == std::string_view::npos ? line.size() : close + 1;
  } else {
    while (n < line.size() && line[n] != ',' && line[n] != '}' && line[n] != ']' &&
           line[n] != ' ' && line[n] != '\t' && line[n] != '#') {
      ++n;
    }
  }
  return static_cast<uint32_t>(std::max<size_t>(n, 1));
}

// operators: {alice: operator, "1002": viewer, group:plant: engineer}
void parse_operators(YamlReader& r, const Field& field, RuntimeConfig& cfg) {
  cfg.operators_pos = field.pos;
  const YAML::Node& map = field.value;
  if (!map.IsDefined() || map.IsNull()) return;
  if (!map.IsMap()) {
    r.error(field, "'operators' expects a map such as {alice: operator, group:plant: viewer}, got " +
                       YamlReader::describe_node(map));
    return;
  }
  auto name_ok = [](const std::string& w) {
    if (w.empty() || w.size() > 32) return false;
    for (char c : w) {
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
    }
    return true;
  };
  for (auto it = map.begin(); it != map.end(); ++it) {
    const SourcePos kp = or_else(YamlReader::pos(it->first), field.pos);
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : std::string();
    OperatorGrant g;
    g.pos = kp;
    g.group = key.rfind("group:", 0) == 0;
    g.who = g.group ? key.substr(6) : key;
    if (!name_ok(g.who)) {
      r.error(kp, "an operator is a user name, a uid or group:NAME, got " + YamlReader::describe_node(it->first),
              YamlReader::width(it->first));
      continue;
    }
    const YAML::Node& v = it->second;
    const SourcePos vp = or_else(YamlReader::pos(v), kp);
    const auto role = v.IsScalar() ? parse_role(v.Scalar()) : std::nullopt;
    if (!role) {
      r.error(vp, "the role of '" + key + "' expects viewer, operator, engineer or admin, got " +
                      YamlReader::describe_node(v),
              YamlReader::width(v));
      continue;
    }
    g.role = *role;
    for (const OperatorGrant& o : cfg.operators) {
      if (o.group == g.group && o.who == g.who) {
        r.error(kp, "operator '" + key + "' is given twice", YamlReader::width(it->first));
        r.note(o.pos, "first given here", static_cast<uint32_t>(key.size()));
      }
    }
    cfg.operators.push_back(std::move(g));
  }
}

// runtime: ...
void parse_runtime(YamlReader& r, const Field& section, RuntimeConfig& cfg) {
  const SectionSpec& s = runtime_section();
  Fields f = r.fields(section.value, section.pos, s.noun, {s.keys});
  if (const Field* x = f.get("name")) {
    cfg.name_pos = x->pos;
    if (auto v = r.name(*x)) cfg.name = *v;
  }
  if (const Field* x = f.get("socket")) {
    cfg.socket_pos = x->pos;
    if (auto v = r.path(*x)) cfg.socket_path = *v;
  }
  if (const Field* x = f.get("retain_file")) {
    cfg.retain_pos = x->pos;
    if (auto v = r.path(*x)) cfg.retain_path = *v;
  }
  if (const Field* x = f.get("programs")) {
    cfg.programs_pos = x->pos;
    if (auto v = r.choice(*x)) cfg.programs_from_config = *v == "config";
  }
  if (const Field* x = f.get("monitor_group")) {
    cfg.monitor_group_pos = x->pos;
    if (auto v = r.text(*x)) cfg.monitor_group = *v;
  }
  if (const Field* x = f.get("operators")) parse_operators(r, *x, cfg);
  if (const Field* x = f.get("priority_band")) {
    cfg.band_pos = x->pos;
    if (auto v = r.integer_pair(*x)) {
      cfg.band_lo = static_cast<int>(v->first);
      cfg.band_hi = static_cast<int>(v->second);
    }
  }
  if (const Field* x = f.get("cpu_dma_latency")) {
    if (auto v = r.boolean(*x)) cfg.cpu_dma_latency = *v;
  }
  if (const Field* x = f.get("lock_memory")) {
    if (auto v = r.boolean(*x)) cfg.lock_memory = *v;
  }
  if (const Field* x = f.get("retain_every")) {
    if (auto v = r.duration(*x)) cfg.retain_every_s = *v;
  }
}

// retain: all | none | [BLOCK, ...]
void parse_retain(YamlReader& r, const Field& field, TaskConfig& t) {
  t.retain_pos = field.pos;
  const YAML::Node& v = field.value;
  auto expects = [&] {
    r.error(field, "'retain' expects " + describe_type(*field.spec) + ", got " + YamlReader::describe_node(v));
  };
  if (v.IsScalar()) {
    if (v.Scalar() == "all" || v.Scalar() == "none") {
      t.retain_all = v.Scalar() == "all";
      return;
    }
    expects();
    return;
  }
  if (!v.IsSequence()) {
    expects();
    return;
  }
  t.retain_all = false;
  std::unordered_map<std::string, SourcePos> seen;
  for (const YAML::Node& n : v) {
    const SourcePos np = or_else(YamlReader::pos(n), field.pos);
    const bool word = n.IsScalar() && !n.Scalar().empty() &&
                      n.Scalar().find_first_of(" \t\n#") == std::string::npos;
    if (!word) {
      r.error(np, "a retained block is named as in its program (such as F10), got " + YamlReader::describe_node(n),
              YamlReader::width(n));
      continue;
    }
    auto [first, fresh] = seen.emplace(n.Scalar(), np);
    if (!fresh) {
      r.error(np, "block '" + n.Scalar() + "' is listed twice", YamlReader::width(n));
      r.note(first->second, "first listed here", static_cast<uint32_t>(n.Scalar().size()));
      continue;
    }
    t.retain_blocks.push_back(n.Scalar());
  }
}

// A map keyed by channel label ({LABEL: ..., ...}): checks the map, each key
// (a valid label, given once) and hands each entry to `each(label, key_pos,
// value)`. `what` names an entry in the errors ("safe output", "set-point").
template <class Each>
void for_each_labelled(YamlReader& r, const Field& field, const char* key, const char* what,
                       Each&& each) {
  const YAML::Node& map = field.value;
  if (!map.IsDefined() || map.IsNull()) return;
  if (!map.IsMap()) {
    r.error(field, std::string("'") + key + "' expects " + describe_type(*field.spec) +
                       ", got " + YamlReader::describe_node(map));
    return;
  }
  std::unordered_map<std::string, SourcePos> seen;
  for (auto it = map.begin(); it != map.end(); ++it) {
    const YAML::Node k = it->first;
    const SourcePos kp = or_else(YamlReader::pos(k), field.pos);
    if (!k.IsScalar() || !is_valid_label(k.Scalar())) {
      r.error(kp,
              std::string("a ") + what +
                  " is named by its channel label (1 to 31 letters, digits, '_', '-' or '.'), "
                  "got " +
                  YamlReader::describe_node(k),
              YamlReader::width(k));
      continue;
    }
    const std::string& label = k.Scalar();
    // A map, not a scan: the list is as long as the file makes it.
    auto [first, fresh] = seen.emplace(label, kp);
    if (!fresh) {
      r.error(kp, std::string(what) + " '" + label + "' is given twice", YamlReader::width(k));
      r.note(first->second, "first given here", static_cast<uint32_t>(label.size()));
      continue;
    }
    each(label, kp, it->second);
  }
}

// safe_outputs: {LABEL: number, ...}
void parse_safe_outputs(YamlReader& r, const Field& field, TaskConfig& t) {
  for_each_labelled(r, field, "safe_outputs", "safe output",
                    [&](const std::string& label, SourcePos kp, const YAML::Node& v) {
                      auto x = r.real(v, kp, "safe output '" + label + "'");
                      if (x) t.safe_outputs.push_back(SafeOutput{label, *x, kp});
                    });
}

// on_bad: {LABEL: hold|safe|send, ...}
void parse_on_bad(YamlReader& r, const Field& field, TaskConfig& t) {
  for_each_labelled(r, field, "on_bad", "output", [&](const std::string& label, SourcePos kp, const YAML::Node& v) {
    const SourcePos vp = or_else(YamlReader::pos(v), kp);
    const std::string text = v.IsScalar() ? v.Scalar() : std::string();
    for (OnBad p : {OnBad::kHold, OnBad::kSafe, OnBad::kSend}) {
      if (text == on_bad_name(p)) {
        t.on_bad.push_back(OnBadPolicy{label, p, kp});
        return;
      }
    }
    r.error(vp, "on_bad of '" + label + "' expects hold, safe or send, got " + YamlReader::describe_node(v),
            YamlReader::width(v));
  });
}

// setpoints: {LABEL: {min: number, max: number}, ...}, and ranges: the same
// for a task's inputs and outputs (`what` is "set-point" or "channel").
void parse_limit_map(YamlReader& r, const Field& field, const char* key, const std::string& what,
                     std::vector<SetpointLimits>& into) {
  for_each_labelled(r, field, key, what.c_str(), [&](const std::string& label,
                                                      SourcePos kp, const YAML::Node& v) {
    const SourcePos vp = or_else(YamlReader::pos(v), kp);
    if (!v.IsMap()) {
      r.error(vp, what + " '" + label + "' expects {min: number, max: number}, got " +
                      YamlReader::describe_node(v),
              YamlReader::width(v));
      return;
    }
    SetpointLimits lim{label, std::nullopt, std::nullopt, kp};
    bool ok = true;
    SourcePos max_pos = vp;
    for (auto b = v.begin(); b != v.end(); ++b) {
      const SourcePos bp = or_else(YamlReader::pos(b->first), vp);
      const std::string bound = b->first.IsScalar() ? b->first.Scalar() : std::string();
      if (bound != "min" && bound != "max") {
        r.error(bp, what + " '" + label + "' takes 'min' and 'max', got " +
                        YamlReader::describe_node(b->first),
                YamlReader::width(b->first));
        ok = false;
        continue;
      }
      auto x = r.real(b->second, bp, "'" + bound + "' of " + what + " '" + label + "'");
      if (!x) {
        ok = false;
        continue;
      }
      (bound == "min" ? lim.min : lim.max) = *x;
      if (bound == "max") max_pos = or_else(YamlReader::pos(b->second), bp);
    }
    if (ok && lim.min && lim.max && *lim.min > *lim.max) {
      r.error(max_pos, what + " '" + label + "': max " + v["max"].Scalar() + " is below min " +
                           v["min"].Scalar());
      ok = false;
    }
    if (ok) into.push_back(std::move(lim));
  });
}

// - program: ...
void parse_task(YamlReader& r, const YAML::Node& node, SourcePos list_pos, RuntimeConfig& cfg) {
  TaskConfig t;
  t.pos = or_else(YamlReader::pos(node), list_pos);
  t.name_pos = t.program_pos = t.period_pos = t.priority_pos = t.cpu_pos = t.overrun_pos =
      t.watchdog_pos = t.pos;
  if (node.IsScalar()) {
    // The likeliest slip: "- loop1.fbd" for "- program: loop1.fbd".
    const std::string& word = node.Scalar();
    r.error(t.pos,
            "a task must be a map such as '- program: " +
                (word.size() <= 40 ? word : std::string("FILE.fbd")) + "', got " +
                YamlReader::describe_node(node),
            YamlReader::width(node));
    return;
  }
  const SectionSpec& s = task_section();
  Fields f = r.fields(node, t.pos, s.noun, {s.keys});
  if (!f.is_map()) return;

  std::string raw_program;
  if (const Field* x = f.get("program")) {
    t.program_pos = t.name_pos = x->pos;
    if (auto v = r.path(*x)) {
      t.program = *v;
      raw_program = x->value.Scalar();
    }
  }
  if (const Field* x = f.get("name")) {
    t.name_pos = x->pos;
    if (auto v = r.name(*x)) t.name = *v;
  } else if (!t.program.empty()) {
    const std::string stem = fs::path(raw_program).stem().string();
    if (is_valid_name(stem)) {
      t.name = stem;
    } else {
      r.error(t.program_pos,
              "this task needs a 'name': the program's file name '" + stem +
                  "' is not a valid task name (1 to 31 letters, digits, '_' or '-')");
    }
  }
  if (const Field* x = f.get("program_instance")) {
    if (auto v = r.name(*x)) t.program_instance = *v;
  }
  if (const Field* x = f.get("semantics")) {
    if (auto v = r.choice(*x)) t.semantics = *v;
  }
  if (const Field* x = f.get("period")) {
    t.period_pos = x->pos;
    t.period_s = r.duration(*x);
  }
  if (const Field* x = f.get("priority")) {
    t.priority_pos = x->pos;
    if (auto v = r.integer(*x)) t.priority = static_cast<int>(*v);
  }
  if (const Field* x = f.get("cpu")) {
    t.cpu_pos = x->pos;
    if (auto v = r.integer(*x)) t.cpu = static_cast<unsigned>(*v);
  }
  if (const Field* x = f.get("overrun")) {
    t.overrun_pos = x->pos;
    if (auto v = r.choice(*x))
      t.overrun = *v == "stop" ? OverrunPolicy::kStop : OverrunPolicy::kSkip;
  }
  t.watchdog = t.overrun == OverrunPolicy::kStop ? kDefaultStopWatchdog : 0;
  if (const Field* x = f.get("watchdog")) {
    t.watchdog_pos = x->pos;
    if (auto v = r.integer(*x)) {
      t.watchdog = static_cast<uint32_t>(*v);
      if (t.watchdog == 0 && t.overrun == OverrunPolicy::kStop) {
        r.error(*x,
                "'overrun: stop' with 'watchdog: 0' would never stop the task; use a "
                "watchdog of 1 or more, or 'overrun: skip'");
        r.note(t.overrun_pos, "the policy is set here");
      }
    }
  }
  if (const Field* x = f.get("loop_budget")) {
    t.loop_budget_pos = x->pos;
    if (auto v = r.integer(*x)) t.loop_budget = static_cast<uint64_t>(*v);
  }
  if (const Field* x = f.get("native")) {
    if (auto v = r.boolean(*x)) t.native = *v;
  }
  t.retain_pos = t.pos;
  if (const Field* x = f.get("retain")) parse_retain(r, *x, t);
  if (const Field* x = f.get("on_bad")) parse_on_bad(r, *x, t);
  if (const Field* x = f.get("safe_outputs")) {
    parse_safe_outputs(r, *x, t);
    const bool used_on_bad = std::any_of(t.on_bad.begin(), t.on_bad.end(),
                                         [](const OnBadPolicy& p) { return p.policy == OnBad::kSafe; });
    if (t.watchdog == 0 && !t.safe_outputs.empty() && !used_on_bad) {
      r.warning(x->key_pos,
                "these safe outputs apply only if a loop of the program runs past its loop_budget: "
                "with watchdog 0 an overrun never stops the task, and no output is 'on_bad: safe'; "
                "set 'watchdog' or 'overrun: stop' for them to cover overruns too",
                YamlReader::width(x->key));
    }
  }
  if (const Field* x = f.get("setpoints")) parse_limit_map(r, *x, "setpoints", "set-point", t.setpoint_limits);
  if (const Field* x = f.get("ranges")) parse_limit_map(r, *x, "ranges", "channel", t.channel_ranges);
  cfg.tasks.push_back(std::move(t));
}

// The value of key `key` in `map` when it is a plain scalar, else "".
std::string scalar_at(const YAML::Node& map, std::string_view key) {
  if (!map.IsMap()) return {};
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (it->first.IsScalar() && it->first.Scalar() == key && it->second.IsScalar()) {
      return it->second.Scalar();
    }
  }
  return {};
}

// - kind: ...
void parse_driver(YamlReader& r, const YAML::Node& node, SourcePos list_pos, RuntimeConfig& cfg) {
  DriverConfig d;
  d.pos = or_else(YamlReader::pos(node), list_pos);
  d.kind_pos = d.name_pos = d.period_pos = d.priority_pos = d.cpu_pos = d.pos;
  // The kind decides which keys are allowed, so it is looked up before the
  // keys are checked; while it is unknown, only the kind is blamed.
  const DriverKind* kind = find_driver_kind(scalar_at(node, "kind"));
  const SectionSpec& common = driver_section();
  Fields f = kind ? r.fields(node, d.pos, kind->keys->noun, {common.keys, kind->keys->keys})
                  : r.fields(node, d.pos, common.noun, {common.keys}, false);
  if (!f.is_map()) return;
  if (const Field* x = f.get("kind")) {
    d.kind_pos = x->pos;
    if (auto v = r.text(*x)) {
      if (kind) {
        d.kind = kind->kind;
      } else {
        std::string msg = "unknown driver kind '" + *v + "'; known kinds: " + known_driver_kinds();
        r.error(*x, std::move(msg));
      }
    }
  }
  if (const Field* x = f.get("name")) {
    d.name_pos = x->pos;
    if (auto v = r.name(*x)) d.name = *v;
  } else {
    d.name = d.kind;
    d.name_pos = d.kind_pos;
  }
  if (const Field* x = f.get("period")) {
    d.period_pos = x->pos;
    if (auto v = r.duration(*x)) d.period_s = *v;
  }
  if (const Field* x = f.get("priority")) {
    d.priority_pos = x->pos;
    if (auto v = r.integer(*x)) d.priority = static_cast<int>(*v);
  }
  if (const Field* x = f.get("cpu")) {
    d.cpu_pos = x->pos;
    if (auto v = r.integer(*x)) d.cpu = static_cast<unsigned>(*v);
  }
  if (const Field* x = f.get("max_age")) {
    d.max_age_pos = x->pos;
    if (auto v = r.duration(*x)) d.max_age_s = *v;
  }
  if (kind) kind->parse(r, f, d);
  cfg.drivers.push_back(std::move(d));
}

// What can only be judged with the whole file read: names, the band, shared
// channels, files on disk.
void cross_check(YamlReader& r, std::string_view source, RuntimeConfig& cfg,
                 const LoadOptions& options) {
  auto w = [&](SourcePos p) { return token_width(source, p); };
  for (size_t i = 0; i < cfg.tasks.size(); ++i) {
    const TaskConfig& t = cfg.tasks[i];
    for (size_t j = 0; j < i && !t.name.empty(); ++j) {
      const TaskConfig& first = cfg.tasks[j];
      if (first.name != t.name) continue;
      const bool stem =
          t.name_pos.line == t.program_pos.line && t.name_pos.col == t.program_pos.col;
      r.error(t.name_pos,
              "task name '" + t.name + "' is already used by the task at " +
                  line_of(first.name_pos) + (stem ? "; give this task its own 'name'" : ""),
              w(t.name_pos));
      r.note(first.name_pos, "first used here", w(first.name_pos));
      break;
    }
    if (t.priority && (*t.priority < cfg.band_lo || *t.priority > cfg.band_hi)) {
      r.error(t.priority_pos,
              "priority " + std::to_string(*t.priority) + " is outside the task band [" +
                  std::to_string(cfg.band_lo) + ", " + std::to_string(cfg.band_hi) +
                  "] (runtime: priority_band)",
              w(t.priority_pos));
      if (cfg.band_pos.line) r.note(cfg.band_pos, "the band is set here");
    }
  }
  for (size_t i = 0; i < cfg.drivers.size(); ++i) {
    const DriverConfig& d = cfg.drivers[i];
    for (size_t j = 0; j < i && !d.name.empty(); ++j) {
      const DriverConfig& first = cfg.drivers[j];
      if (first.name != d.name) continue;
      const bool from_kind = d.name_pos.line == d.kind_pos.line && d.name_pos.col == d.kind_pos.col;
      r.error(d.name_pos,
              "driver name '" + d.name + "' is already used by the driver at " +
                  line_of(first.name_pos) + (from_kind ? "; give this driver its own 'name'" : ""),
              w(d.name_pos));
      r.note(first.name_pos, "first used here", w(first.name_pos));
      break;
    }
    if (d.priority && *d.priority <= cfg.band_hi) {
      r.warning(d.priority_pos,
                "driver '" + d.name + "' at priority " + std::to_string(*d.priority) +
                    " is not above the task band [" + std::to_string(cfg.band_lo) + ", " +
                    std::to_string(cfg.band_hi) + "]; tasks can delay its I/O",
                w(d.priority_pos));
    }
  }
  // One input channel has one source: two drivers (or two plants of one)
  // providing it would race.
  std::map<std::string, SourcePos> provided;
  for (const DriverConfig& d : cfg.drivers) {
    const DriverKind* kind = find_driver_kind(d.kind);
    if (kind == nullptr || kind->claims == nullptr) continue;
    for (const ChannelClaim& c : kind->claims(d).provides) {
      auto [it, fresh] = provided.emplace(c.key, c.pos);
      if (fresh) continue;
      r.error(c.pos,
              "input channel " + c.key + " is already provided at " + line_of(it->second) +
                  "; each input channel has one source",
              w(c.pos));
      r.note(it->second, "first provided here", w(it->second));
    }
  }
  if (options.check_program_files) {
    for (const TaskConfig& t : cfg.tasks) {
      if (t.program.empty()) continue;
      std::error_code ec;
      const fs::file_status st = fs::status(t.program, ec);
      if (!fs::exists(st)) {
        r.error(t.program_pos, "program file not found: " + t.program, w(t.program_pos));
      } else if (!fs::is_regular_file(st)) {
        r.error(t.program_pos, "program is not a regular file: " + t.program, w(t.program_pos));
      }
    }
  }
}

// Records where each document starts; ignores everything else.
class DocumentStarts final : public YAML::EventHandler {
 public:
  YAML::Mark last;
  void OnDocumentStart(const YAML::Mark& mark) override { last = mark; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

SourcePos to_pos(const YAML::Mark& m) {
  if (m.line < 0 || m.column < 0) return {1, 1};
  return {static_cast<uint32_t>(m.line) + 1, static_cast<uint32_t>(m.column) + 1};
}

// A config is one document. YAML::LoadAll is not used to find out: on some
// malformed text yaml-cpp 0.7 returns empty documents at the same place
// forever, and LoadAll collects them until memory runs out. Two steps of the
// parser are enough, and a step that does not move is a syntax error.
void check_single_document(const std::string& text, YamlReader& r) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentStarts starts;
  if (!parser.HandleNextDocument(starts)) return;
  const YAML::Mark first = starts.last;
  if (!parser.HandleNextDocument(starts)) return;
  if (starts.last.pos == first.pos) {
    r.error(to_pos(starts.last), "YAML syntax error: the text here cannot be parsed");
  } else {
    r.error(to_pos(starts.last), "a config file holds one YAML document; a second one starts here");
  }
}

void parse_document(const std::string& yaml, const std::string& base_dir,
                    const LoadOptions& options, LoadResult& res) {
  // yaml-cpp reads from a stream; the text may hold NULs, which it treats as data.
  std::istringstream in(yaml);
  const YAML::Node root = YAML::Load(in);
  YamlReader r(res.diags, base_dir);
  check_single_document(yaml, r);
  if (!root.IsDefined() || root.IsNull()) {
    if (!res.diags.has_errors()) {
      r.error({1, 1}, "the config is empty; it needs at least a 'tasks:' list");
    }
    return;
  }
  if (!root.IsMap()) {
    r.error(or_else(YamlReader::pos(root), {1, 1}),
            "the config must be a map with a 'tasks:' list, got " + YamlReader::describe_node(root),
            YamlReader::width(root));
    return;
  }
  RuntimeConfig cfg;
  cfg.file = res.file;
  cfg.base_dir = base_dir;
  const SectionSpec& top = top_section();
  Fields f = r.fields(root, {1, 1}, top.noun, {top.keys});
  if (const Field* x = f.get("runtime")) parse_runtime(r, *x, cfg);
  if (const Field* x = f.get("tasks")) {
    if (auto items = r.list(*x)) {
      for (const YAML::Node& n : *items) parse_task(r, n, x->pos, cfg);
    }
  }
  if (const Field* x = f.get("drivers")) {
    if (auto items = r.list(*x)) {
      for (const YAML::Node& n : *items) parse_driver(r, n, x->pos, cfg);
    }
  }
  cross_check(r, yaml, cfg, options);
  if (!res.diags.has_errors()) res.config = std::move(cfg);
}

}  // namespace

const char* to_string(OverrunPolicy p) {
  return p == OverrunPolicy::kStop ? "stop" : "skip";
}

const TaskConfig* RuntimeConfig::find_task(std::string_view task_name) const {
  for (const TaskConfig& t : tasks) {
    if (t.name == task_name) return &t;
  }
  return nullptr;
}

const DriverConfig* RuntimeConfig::find_driver(std::string_view driver_name) const {
  for (const DriverConfig& d : drivers) {
    if (d.name == driver_name) return &d;
  }
  return nullptr;
}

LoadResult parse_config(std::string_view yaml, const std::string& file_name,
                        const std::string& base_dir, const LoadOptions& options) {
  LoadResult res;
  res.file = file_name;
  res.source = std::string(yaml);
  try {
    parse_document(res.source, base_dir, options, res);
  } catch (const YAML::ParserException& e) {
    // yaml-cpp stops at the first syntax error; its mark is 0-based.
    res.diags.error(to_pos(e.mark), "YAML syntax error: " + e.msg);
  } catch (const std::exception& e) {
    // Nothing in the loader should throw past yaml-cpp's parse; if something
    // does, the user still gets a diagnostic instead of a crash.
    res.diags.error({}, std::string("cannot read the config: ") + e.what());
  } catch (...) {
    res.diags.error({}, "cannot read the config: unexpected failure");
  }
  if (res.diags.has_errors()) res.config.reset();
  return res;
}

LoadResult load_config(const std::string& path, const LoadOptions& options) {
  LoadResult res;
  res.file = path;
  try {
    std::error_code ec;
    const fs::path p(path);
    Result<std::string> text = read_file_bounded(path, kMaxConfigBytes);
    if (!text) {
      const std::string why = file_error_reason(path, text.error());
      res.diags.error({}, is_missing_file_error(text.error()) ? std::string("config file not found")
                          : why.rfind("is ", 0) == 0       ? "the config " + why
                                                           : "the config file: " + why);
      return res;
    }
    fs::path abs = fs::absolute(p, ec);
    const std::string base = (ec ? p : abs).parent_path().lexically_normal().string();
    return parse_config(*text, path, base, options);
  } catch (const std::exception& e) {
    res.diags.error({}, std::string("cannot read the config file: ") + e.what());
    return res;
  }
}

const char* on_bad_name(OnBad p) {
  switch (p) {
    case OnBad::kSafe:
      return "safe";
    case OnBad::kSend:
      return "send";
    case OnBad::kHold:
      break;
  }
  return "hold";
}

}  // namespace rtplc::config
