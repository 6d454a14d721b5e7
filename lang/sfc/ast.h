// The syntax tree of an SFC program (docs/sfc.md, "File layout"; spec
// petri-sfc.md, "What the product does with this": steps, transitions with
// boolean conditions, actions with IEC qualifiers, and the plant model the
// analysis composes into sub-PNs). The parser fills it; the flat-block builder
// (builder.h) and the net builder (net_builder.h) read it. Every node keeps the
// position of the word that introduced it, so later stages can point at it.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/diagnostic.h"

namespace rtplc::lang::sfc {

// One argument of a block call: a name (a signal, `Step.X`, or a device address
// such as `p0`), a number or a string.
struct Arg {
  enum class Type : uint8_t { kName, kNumber, kString };
  Type type = Type::kName;
  std::string text;  // kName, kString
  double number = 0;
  SourcePos pos;
};

struct Call {
  std::string block;  // as written: "ddi", "time"
  SourcePos pos;
  std::vector<Arg> args;
};

// INPUT name = ddi(...), OUTPUT name = ddo(...) / OUTPUT name (an internal flag),
// SIGNAL name = and(...). MODEL names the places of the plant model that stand
// for the signal being true and false (for `rtplc analyze`). kHost is never
// written in a .sfc file: a value a host front end computes in its own blocks
// (a PLCopen transition condition), which the builder finds through
// HostLink::resolve (builder.h).
struct Signal {
  enum class Role : uint8_t { kInput, kOutput, kSignal, kHost };
  Role role = Role::kInput;
  std::string name;
  SourcePos pos;
  std::optional<Call> call;  // absent only for an OUTPUT flag without a channel
  std::string model_on, model_off;
  SourcePos model_pos;
};

// A transition condition. kName is a signal or `Step.X`.
struct Expr {
  enum class Op : uint8_t { kName, kTrue, kFalse, kNot, kAnd, kOr };
  Op op = Op::kTrue;
  std::string name;
  SourcePos pos;
  std::vector<Expr> kids;
};

struct Action {
  std::string qualifier;  // N S R P P1 P0 L D SD DS SL
  SourcePos pos;
  std::string target;  // an OUTPUT
  SourcePos target_pos;
  std::optional<double> seconds;  // L, D, SD, DS and SL (is_timed_qualifier)
  SourcePos time_pos;
  // A host's duration given by a variable (a PLCopen or .st chart's
  // `a(L, delay)`): the kHost signal holding it in seconds; `seconds` unset.
  std::string time_signal;
};

// The qualifiers that take a time (IEC 61131-3: L, D, SD, DS, SL).
inline bool is_timed_qualifier(const std::string& q) {
  return q == "L" || q == "D" || q == "SD" || q == "DS" || q == "SL";
}

struct NameRef {
  std::string name;
  SourcePos pos;
};

struct Step {
  std::string name;
  SourcePos pos;
  bool initial = false;
  std::vector<Action> actions;
  std::vector<NameRef> subnet;  // SUBNET: plant modules of this step's sub-PN
  SourcePos subnet_pos;
};

struct Transition {
  std::string name;
  SourcePos pos;
  std::vector<NameRef> from, to;  // several: simultaneous convergence / divergence
  Expr condition;
};

// PLANT: the devices as token loops (modules) and the events that move them.
struct PlaceDecl {
  std::string name;
  SourcePos pos;
  bool initial = false;  // written `name*`
};

struct Module {
  std::string name;
  SourcePos pos;
  bool main = false;  // a main-loop module (the paper's push button P0/P1)
  std::vector<PlaceDecl> places;
};

struct Event {
  std::string name;
  SourcePos pos;
  NameRef from, to;            // places of one module
  std::vector<NameRef> reads;  // WHILE: steps or places it needs, without consuming them
};

struct Chart {
  std::string name;
  SourcePos pos;
  double period = 0.1;
  bool has_stime = false;
  SourcePos stime_pos;
  uint32_t steps_module = 0;  // step flags are ddo channels p255.d<steps_module>.c<i>
  std::vector<Signal> signals;
  std::vector<Step> steps;
  std::vector<Transition> transitions;
  std::vector<Module> modules;
  std::vector<Event> events;
};

}  // namespace rtplc::lang::sfc
