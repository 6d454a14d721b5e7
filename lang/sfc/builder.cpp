// SFC chart -> flat blocks (see builder.h; docs/sfc.md, "How an SFC runs").
//
// One cycle, in block order:
//   1. sfc.zero (constant 0) and sfc.first (1 in the task's first cycle only:
//      not of sfc.one, which runs last, so it reads last cycle's 1 afterwards);
//   2. INPUT and SIGNAL blocks, in the order written;
//   3. step.S.prev = the step flag of the previous cycle (a delayed reference);
//   4. transitions: tr.T = all source steps' prev AND condition AND no earlier
//      transition (text order) from a shared source step fires;
//   5. steps: step.S = (prev AND NOT any leaving transition) OR any entering one
//      (OR sfc.first for an initial step), then its flag's ddo;
//   6. actions, per output: the R uses' OR first, then the N, P/P1, P0, L
//      and D terms, the SD, DS and SL ones (each with its own reset-dominant
//      latch) and one reset-dominant S latch, OR-ed into out.O, then the
//      output block;
//   7. sfc.one = NOT sfc.zero.
// So evolution reads only last cycle's step flags (every step lasts at least a
// cycle, SFC semantics), and actions see this cycle's. A host may ask for
// CODESYS's order instead (HostLink::actions_first): after 2., last cycle's
// `prev` (step.S.prev2, for the P/P0 edges), `prev` (with sfc.first for an
// initial step), the actions from `prev`; then 4., 5. and 7.: the actions run
// for the steps active at the start of the cycle, the new flags take effect
// in the next one. Hot swap matches blocks
// by name and opcode: every step's flag is the `or` block named step.S, so an
// edited chart keeps its active steps by name, and each timer is named after
// its step, qualifier and output.
#include "lang/sfc/builder.h"

#include <algorithm>
#include <array>
#include <unordered_map>

#include "blocks/registry.h"
#include "lang/sfc/lexer.h"
#include "lang/sfc/parser.h"

namespace rtplc::lang::sfc {
namespace {

class Builder {
 public:
  Builder(const Chart& c, const ChartIndex& ix, DiagnosticList& d, const HostLink* host)
      : c_(c), ix_(ix), d_(d), host_(host), actions_first_(host != nullptr && host->actions_first) {}

  CheckedProgram run() {
    p_.period = c_.has_stime ? c_.period : kDefaultPeriod;
    p_.period_from_stime = c_.has_stime;
    p_.stime_pos = c_.stime_pos;
    emit("and", "sfc.zero", c_.pos, {"sfc.zero", "sfc.zero"});
    emit("not", "sfc.first", c_.pos, {"sfc.one"});
    // In a host a transition may fire in the first cycle (the initial steps
    // are active before it): TRUE must be 1 there too, and sfc.one (made
    // last) reads 0 then.
    if (host_ != nullptr) emit("not", "sfc.true", c_.pos, {"sfc.zero"});
    for (const Signal& s : c_.signals) {
      if (s.role != Signal::Role::kOutput && s.role != Signal::Role::kHost) signal_block(s);
    }
    if (actions_first_) {
      // Last cycle's `prev`, for the P and P0 edges of the actions run from
      // `prev` (a reference to the later block: the previous cycle's value).
      for (const Step& st : c_.steps) emit("or", prev2(st.name), st.pos, {prev(st.name), prev(st.name)});
      // The steps active now: last cycle's new flags, and the initial steps
      // in the first cycle (their actions run then, their transitions too).
      for (const Step& st : c_.steps) {
        emit("or", prev(st.name), st.pos, {flag(st.name), st.initial ? "sfc.first" : flag(st.name)});
      }
      for (const Signal& s : c_.signals) {
        if (s.role == Signal::Role::kOutput) output(s);
      }
      actions_end_ = p_.blocks.size();
    } else {
      // In a host (MatIEC's order) the initial steps are active before the
      // first cycle, so their transitions may fire in it, as a MatIEC chart's
      // do; a .sfc chart enters them in the first cycle instead.
      for (const Step& st : c_.steps) {
        emit("or", prev(st.name), st.pos,
             {flag(st.name), st.initial && host_ != nullptr ? "sfc.first" : flag(st.name)});
      }
    }
    for (size_t i = 0; i < c_.transitions.size(); ++i) transition(i);
    for (size_t s = 0; s < c_.steps.size(); ++s) step(s);
    if (host_ == nullptr) {
      for (size_t s = 0; s < c_.steps.size(); ++s) step_output(s);
    }
    if (!actions_first_) {
      for (const Signal& s : c_.signals) {
        if (s.role == Signal::Role::kOutput) output(s);
      }
    }
    emit("not", "sfc.one", c_.pos, {"sfc.zero"});
    resolve();
    if (host_ != nullptr) {
      for (FlatBlock& b : p_.blocks) {
        if (!b.name.empty()) b.name = host_->prefix + b.name;
      }
    }
    return std::move(p_);
  }

  static std::string flag(const std::string& step) { return "step." + step; }
  size_t actions_end() const { return actions_end_; }

 private:
  static std::string prev(const std::string& step) { return "step." + step + ".prev"; }
  static std::string prev2(const std::string& step) { return "step." + step + ".prev2"; }
  // A block that is 1 whenever something reads it.
  std::string one() const { return host_ != nullptr ? "sfc.true" : "sfc.one"; }
  // What an action reads: whether its step is active when the actions run,
  // and whether it was when they last ran (its P and P0 edges).
  std::string active(const std::string& step) const { return actions_first_ ? prev(step) : flag(step); }
  std::string was_active(const std::string& step) const { return actions_first_ ? prev2(step) : prev(step); }

  // Appends a block; its inputs are names, resolved once every block exists
  // (a reference to a later block is legal and reads last cycle's value).
  FlatBlock& emit(const char* written, std::string name, SourcePos pos,
                  std::vector<std::string> ins, std::vector<double> params = {}) {
    FlatBlock b;
    b.written = written;
    b.name = std::move(name);
    b.pos = pos;
    b.call_line = 0;  // top level: --explain lists it at its construct's line
    b.n_in = static_cast<uint32_t>(ins.size());
    for (uint32_t k = 0; k < b.n_in && k < 3; ++k) b.in_pos[k] = pos;
    b.params = std::move(params);
    p_.blocks.push_back(std::move(b));
    refs_.push_back(std::move(ins));
    return p_.blocks.back();
  }

  // OR/AND of any number of inputs, as a chain of 3-input gates; the last gate
  // is named `name` (one input is doubled: the block must exist under its name).
  std::string reduce(const char* op, std::vector<std::string> ins, const std::string& name,
                     SourcePos pos) {
    uint32_t part = 0;
    while (ins.size() > 3) {
      std::string partial = name + "." + std::to_string(++part);
      emit(op, partial, pos, {ins[0], ins[1], ins[2]});
      ins.erase(ins.begin(), ins.begin() + 3);
      ins.insert(ins.begin(), partial);
    }
    if (ins.size() == 1) ins.push_back(ins[0]);
    emit(op, name, pos, ins);
    return name;
  }

  // The block a condition or SIGNAL argument names.
  std::string reference(const std::string& name, bool in_condition) {
    const std::string step = step_of_flag(name);
    if (!step.empty()) return in_condition ? prev(step) : flag(step);
    auto it = ix_.signals.find(name);
    if (it != ix_.signals.end() && c_.signals[it->second].role == Signal::Role::kOutput)
      return "out." + name;
    return name;
  }

  bool device_word(const Arg& a, char letter, uint32_t* out) {
    bool ok = a.type == Arg::Type::kName && a.text.size() >= 2 && a.text.size() <= 7 &&
              a.text[0] == letter;
    uint32_t v = 0;
    for (size_t k = 1; ok && k < a.text.size(); ++k) {
      ok = a.text[k] >= '0' && a.text[k] <= '9';
      v = v * 10 + static_cast<uint32_t>(a.text[k] - '0');
    }
    if (!ok) {
      d_.error(a.pos, std::string("expected a device address such as ") + letter + "0");
      return false;
    }
    *out = v;
    return true;
  }

  // Device arguments of an I/O block: (p, d, c[, "label"]) or, for a
  // set-point, (d, c, init[, "label"]). An output's value is not written: the
  // chart's actions drive it.
  void device_args(const Call& k, const BlockSpec& spec, FlatBlock& b) {
    const bool setpoint = spec.signature == Signature::kSetpoint;
    const size_t want = 3;
    const std::vector<Arg>& a = k.args;
    const char* form = setpoint ? "(d, c, init, \"label\")" : "(p, d, c, \"label\")";
    if (a.size() < want || a.size() > want + 1 ||
        (a.size() == want + 1 && a[want].type != Arg::Type::kString)) {
      d_.error(k.pos, k.block + " takes " + k.block + form + " here (the label may be left out)",
               static_cast<uint32_t>(k.block.size()));
      return;
    }
    uint32_t v = 0;
    if (setpoint) {
      if (device_word(a[0], 'd', &v)) b.d = static_cast<uint16_t>(std::min<uint32_t>(v, 65535));
      if (device_word(a[1], 'c', &v)) b.c = v;
      if (a[2].type != Arg::Type::kNumber)
        d_.error(a[2].pos, "expected the set-point's initial value");
      b.init = a[2].number;
    } else {
      if (device_word(a[0], 'p', &v)) b.p = static_cast<uint16_t>(std::min<uint32_t>(v, 65535));
      if (device_word(a[1], 'd', &v)) b.d = static_cast<uint16_t>(std::min<uint32_t>(v, 65535));
      if (device_word(a[2], 'c', &v)) b.c = v;
    }
    if (a.size() == want + 1) b.label = a[want].text;
  }

  // INPUT name = ddi(p, d, c, "label")  or  SIGNAL name = block(inputs..., params...)
  void signal_block(const Signal& s) {
    const Call& k = *s.call;
    const BlockSpec* spec = find_block(k.block);
    if (spec == nullptr) {  // check_flat_program says "unknown block" with a hint
      emit(k.block.c_str(), s.name, k.pos, {});
      return;
    }
    const bool is_input = spec->group == BlockGroup::kInput;
    if (s.role == Signal::Role::kInput && !is_input) {
      d_.error(k.pos,
               "INPUT takes an input or set-point block (ddi, prx, erd, dsp, ...); " + k.block +
                   " is not one (compute it with SIGNAL)",
               static_cast<uint32_t>(k.block.size()));
      return;
    }
    if (s.role == Signal::Role::kSignal && spec->signature != Signature::kCompute) {
      d_.error(k.pos,
               std::string("SIGNAL takes a compute block (and, or, time, cnt, ...); ") + k.block +
                   (is_input ? " reads a channel: declare it with INPUT" : " writes a channel"),
               static_cast<uint32_t>(k.block.size()));
      return;
    }
    if (is_input) {
      FlatBlock& b = emit(k.block.c_str(), s.name, s.pos, {});
      device_args(k, *spec, b);
      return;
    }
    std::vector<std::string> ins;
    std::vector<SourcePos> at;
    std::vector<double> params;
    for (const Arg& a : k.args) {
      if (a.type == Arg::Type::kName) {
        if (!params.empty()) {
          d_.error(a.pos, "inputs come before parameters: '" + a.text + "' follows a number");
          return;
        }
        const std::string step = step_of_flag(a.text);
        if (step.empty() ? !ix_.signals.count(a.text) : !ix_.steps.count(step)) {
          std::vector<std::string> names;
          for (const Signal& x : c_.signals) names.push_back(x.name);
          d_.error(a.pos, "unknown signal '" + a.text + "'" + closest_name(a.text, names),
                   static_cast<uint32_t>(a.text.size()));
          return;
        }
        ins.push_back(reference(a.text, false));
        at.push_back(a.pos);
      } else if (a.type == Arg::Type::kNumber) {
        params.push_back(a.number);
      } else {
        d_.error(a.pos, k.block + " takes no label");
        return;
      }
    }
    if (ins.size() > 3) {
      d_.error(k.pos, k.block + " takes at most 3 inputs, found " + std::to_string(ins.size()));
      return;
    }
    FlatBlock& b = emit(k.block.c_str(), s.name, s.pos, ins, params);
    for (size_t j = 0; j < at.size(); ++j) b.in_pos[j] = at[j];
  }

  // A condition as gates; returns the name of the block holding its value.
  std::string condition(const Expr& e, const std::string& base, uint32_t& counter) {
    switch (e.op) {
      case Expr::Op::kTrue:
        return one();
      case Expr::Op::kFalse:
        return "sfc.zero";
      case Expr::Op::kName:
        return reference(e.name, true);
      case Expr::Op::kNot: {
        const std::string in = condition(e.kids[0], base, counter);
        const std::string name = base + ".c" + std::to_string(++counter);
        emit("not", name, e.pos, {in});
        return name;
      }
      case Expr::Op::kAnd:
      case Expr::Op::kOr: {
        std::vector<std::string> ins;
        for (const Expr& k : e.kids) ins.push_back(condition(k, base, counter));
        const std::string name = base + ".c" + std::to_string(++counter);
        return reduce(e.op == Expr::Op::kAnd ? "and" : "or", ins, name, e.pos);
      }
    }
    return "sfc.zero";
  }

  void transition(size_t i) {
    const Transition& t = c_.transitions[i];
    const std::string name = "tr." + t.name;
    uint32_t counter = 0;
    std::vector<std::string> ins;
    for (const NameRef& r : t.from) ins.push_back(prev(r.name));
    ins.push_back(condition(t.condition, name, counter));
    // Selection divergence: of the transitions leaving one step, the first
    // written wins (IEC 61131-3's default priority), so one token never becomes two.
    std::vector<std::string> earlier;
    for (size_t j = 0; j < i; ++j) {
      const Transition& u = c_.transitions[j];
      const bool shares = std::any_of(t.from.begin(), t.from.end(), [&](const NameRef& a) {
        return std::any_of(u.from.begin(), u.from.end(),
                           [&](const NameRef& b) { return a.name == b.name; });
      });
      if (shares) earlier.push_back("tr." + u.name);
    }
    if (!earlier.empty()) {
      const std::string blocked = reduce("or", earlier, name + ".blocked", t.pos);
      emit("not", name + ".free", t.pos, {blocked});
      ins.push_back(name + ".free");
    }
    reduce("and", ins, name, t.pos);
  }

  void step(size_t s) {
    const Step& st = c_.steps[s];
    std::string go = one();
    if (!ix_.leaving[s].empty()) {
      std::vector<std::string> leave;
      for (size_t t : ix_.leaving[s]) leave.push_back("tr." + c_.transitions[t].name);
      const std::string l =
          leave.size() == 1 ? leave[0] : reduce("or", leave, flag(st.name) + ".leave", st.pos);
      go = flag(st.name) + ".go";
      emit("not", go, st.pos, {l});
    }
    emit("and", flag(st.name) + ".stay", st.pos, {prev(st.name), go});
    std::vector<std::string> enter = {flag(st.name) + ".stay"};
    if (st.initial && host_ == nullptr) enter.push_back("sfc.first");  // in a host: in `prev` already
    for (size_t t : ix_.entering[s]) enter.push_back("tr." + c_.transitions[t].name);
    if (enter.size() == 1)
      enter.push_back("sfc.zero");  // the flag stays an `or` (hot swap matches the opcode)
    reduce("or", enter, flag(st.name), st.pos);
  }

  void step_output(size_t s) {
    const Step& st = c_.steps[s];
    FlatBlock& b = emit("ddo", "", st.pos, {flag(st.name)});
    b.p = kStepFlagProcessor;
    b.d = static_cast<uint16_t>(std::min<uint32_t>(c_.steps_module, 65535));
    b.c = static_cast<uint32_t>(s);
    b.label = c_.name + "." + st.name;
    if (b.label.size() > 31) {
      d_.error(st.pos,
               "the step flag's label '" + b.label +
                   "' is longer than 31 characters: shorten the "
                   "program or step name",
               static_cast<uint32_t>(st.name.size()));
    }
  }

  // Reset-dominant latch `name` = (set OR last cycle's name) AND clear; the
  // self-reference is to a later block, so it reads the previous cycle.
  void latch(const std::string& name, const std::string& set, const std::string& clear,
             SourcePos pos, std::string keep = {}) {
    if (keep.empty()) keep = name + ".keep";
    emit("or", keep, pos, {set, name});
    emit("and", name, pos, {keep, clear});
  }

  void output(const Signal& o) {
    const std::string out = "out." + o.name;
    std::vector<std::string> terms, sets, resets;
    bool stored = false;  // S, SD, DS or SL: latches, cleared by this output's R
    for (const Step& st : c_.steps) {
      for (const Action& a : st.actions) {
        if (a.target != o.name) continue;
        if (a.qualifier == "R") resets.push_back(active(st.name));
        stored = stored || a.qualifier == "S" || a.qualifier == "SD" || a.qualifier == "DS" ||
                 a.qualifier == "SL";
      }
    }
    // The reset first, so every latch below reads this cycle's.
    const std::string reset =
        resets.empty() ? "sfc.zero" : reduce("or", resets, out + ".reset", o.pos);
    if (!resets.empty() || stored) emit("not", out + ".clear", o.pos, {reset});
    bool delayed_stored = false;  // SD, DS or SL: their own latches
    for (const Step& st : c_.steps) {
      for (const Action& a : st.actions) {
        if (a.target != o.name) continue;
        const std::string base = "act." + st.name + "." + a.qualifier + "." + o.name;
        const std::string x = active(st.name);
        const double secs = a.seconds.value_or(0);
        // The qualifier's on-delay: `time` for a constant duration, a TON
        // on the host's signal for one given by a variable.
        auto delay = [&](const std::string& name, const std::string& in) {
          if (a.time_signal.empty()) emit("time", name, a.pos, {in}, {secs});
          else emit("ton", name, a.pos, {in, a.time_signal});
        };
        const std::string& q = a.qualifier;
        if (q == "N") {
          terms.push_back(x);
        } else if (q == "S") {
          sets.push_back(x);
        } else if (q == "P" || q == "P1") {  // the step's rising edge: active now, not last cycle
          emit("not", base + ".n", a.pos, {was_active(st.name)});
          emit("and", base, a.pos, {x, base + ".n"});
          terms.push_back(base);
        } else if (q == "P0") {  // the falling edge: active last cycle, not now
          emit("not", base + ".n", a.pos, {x});
          emit("and", base, a.pos, {was_active(st.name), base + ".n"});
          terms.push_back(base);
        } else if (q == "L") {  // active and the time not yet elapsed
          delay(base + ".t", x);
          emit("not", base + ".n", a.pos, {base + ".t"});
          emit("and", base, a.pos, {x, base + ".n"});
          terms.push_back(base);
        } else if (q == "D") {  // active and the time elapsed
          delay(base, x);
          terms.push_back(base);
        } else if (q == "SD") {  // stored from the step, then delayed: time(latch)
          delayed_stored = true;
          latch(base + ".latch", x, out + ".clear", a.pos);
          delay(base, base + ".latch");
          terms.push_back(base);
        } else if (q == "DS") {  // delayed while the step lasts, then stored: latch(time)
          delayed_stored = true;
          delay(base + ".t", x);
          latch(base, base + ".t", out + ".clear", a.pos);
          terms.push_back(base);
        } else if (q == "SL") {  // stored from the step, limited: latch AND NOT time(latch)
          delayed_stored = true;
          latch(base + ".latch", x, out + ".clear", a.pos);
          delay(base + ".t", base + ".latch");
          emit("not", base + ".n", a.pos, {base + ".t"});
          emit("and", base, a.pos, {base + ".latch", base + ".n"});
          terms.push_back(base);
        }
      }
    }
    // The S latch; an output with only R uses keeps it too (always 0), so it
    // counts as driven.
    if (!sets.empty() || (!resets.empty() && !delayed_stored)) {
      const std::string set = sets.empty() ? "sfc.zero" : reduce("or", sets, out + ".set", o.pos);
      latch(out + ".latch", set, out + ".clear", o.pos, out + ".keep");
      terms.push_back(out + ".latch");
    }
    if (terms.empty()) {
      d_.warning(o.pos, "no action drives output " + o.name + ": it stays 0",
                 static_cast<uint32_t>(o.name.size()));
      terms.push_back("sfc.zero");
    }
    reduce("or", terms, out, o.pos);
    if (!o.call) return;  // an internal flag
    const BlockSpec* spec = find_block(o.call->block);
    if (spec == nullptr) {
      emit(o.call->block.c_str(), "", o.call->pos, {out});
      return;
    }
    if (spec->group != BlockGroup::kOutput || spec->input_kind[0] != Kind::kDigital) {
      d_.error(o.call->pos,
               "OUTPUT takes a digital output block (ddo, pwy, twd, ewd, ...); " + o.call->block +
                   " is not one",
               static_cast<uint32_t>(o.call->block.size()));
      return;
    }
    FlatBlock& b = emit(o.call->block.c_str(), "", o.pos, {out});
    device_args(*o.call, *spec, b);
  }

  // Names -> indices. Every generated name exists by construction; user names
  // were checked by check_chart, so a miss here is reported, never dereferenced.
  // In a host's program a chart block's index moves by first_index, and a
  // name the chart does not make is a host block (a kHost signal).
  void resolve() {
    const uint32_t base = host_ != nullptr ? host_->first_index : 0;
    std::unordered_map<std::string, uint32_t> by_name;
    for (uint32_t i = 0; i < p_.blocks.size(); ++i) {
      if (!p_.blocks[i].name.empty()) by_name.emplace(p_.blocks[i].name, i);
    }
    for (size_t i = 0; i < p_.blocks.size(); ++i) {
      FlatBlock& b = p_.blocks[i];
      for (uint32_t k = 0; k < b.n_in && k < 3; ++k) {
        auto it = by_name.find(refs_[i][k]);
        if (it != by_name.end()) {
          b.in[k] = base + it->second;
          continue;
        }
        std::optional<uint32_t> outside;
        if (host_ != nullptr && host_->resolve) outside = host_->resolve(refs_[i][k]);
        if (outside) {
          b.in[k] = *outside;
        } else {
          d_.error(b.in_pos[k], "'" + refs_[i][k] + "' is not defined");
          b.in[k] = 0;
        }
      }
    }
  }

  const Chart& c_;
  const ChartIndex& ix_;
  DiagnosticList& d_;
  const HostLink* host_;
  bool actions_first_ = false;
  size_t actions_end_ = 0;
  CheckedProgram p_;
  std::vector<std::vector<std::string>> refs_;
};

}  // namespace

std::string step_flag_block(const HostLink& host, const std::string& step) {
  return host.prefix + Builder::flag(step);
}

std::string action_flag_block(const HostLink& host, const std::string& output) {
  return host.prefix + "out." + output;
}

CheckedProgram build_flat_program(const Chart& chart, const ChartIndex& index,
                                  DiagnosticList& diags, const HostLink* host, size_t* actions_end) {
  Builder b(chart, index, diags, host);
  CheckedProgram p = b.run();
  if (actions_end != nullptr) *actions_end = b.actions_end();
  return p;
}

Chart parse_chart(std::string_view source, DiagnosticList& diags, ChartIndex* index, bool* ok) {
  const size_t before = diags.error_count();
  std::vector<Token> toks = tokenize(source, diags);
  Chart chart = parse(toks, diags);
  *index = check_chart(chart, diags);
  *ok = diags.error_count() == before;
  return chart;
}

CheckedProgram compile_to_flat(std::string_view source, DiagnosticList& diags) {
  ChartIndex index;
  bool ok = false;
  Chart chart = parse_chart(source, diags, &index, &ok);
  if (!ok) return {};
  return build_flat_program(chart, index, diags);
}

}  // namespace rtplc::lang::sfc
