// FBD argument binding: one primitive call as written -> one FlatBlock (spec
// fbd-language.md, "Blocks and ids", "Devices and labels", "Macros": P<n>).
//
// This is where FBD syntax meets the registry: inputs are F/D ids (M/N inside a
// macro) whose letter fixes their kind, parameters are literals or P<n>, I/O
// blocks take pN/dN/cN and a label. Each problem is reported at the argument it
// concerns. The rules themselves (arity, parameter bounds, address ranges,
// labels) are the language-neutral ones of lang/program_checks.h.
#include <algorithm>
#include <string>

#include "lang/fbd_scope.h"
#include "lang/program_checks.h"

namespace rtplc::lang::fbd {
namespace {

// Accepts an input reference into slot `slot` of the block being built.
bool input_arg(const Arg& a, const ArgumentContext& ctx, Kind want, const char* input_name,
               const char* block, uint32_t slot, FlatBlock& b) {
  DiagnosticList& diags = ctx.diags;
  if (a.kind != Arg::Kind::kRef || !is_value_letter(a.ref.letter)) {
    std::string found = a.kind == Arg::Kind::kNumber   ? "a number"
                        : a.kind == Arg::Kind::kString ? "a string"
                        : a.kind == Arg::Kind::kDevice ? "a device address"
                                                       : "parameter " + a.ref.text();
    diags.error(
        a.pos,
        std::string("input '") + input_name + "' of " + block + " must be the id of a block" +
            (a.kind == Arg::Kind::kNumber ? " (a constant input comes from a set-point block, asp)"
                                          : "") +
            ", found " + found,
        a.length);
    return false;
  }
  const Scope& s = ctx.scope;
  const char l = a.ref.letter;
  if (s.top && (l == 'M' || l == 'N')) {
    diags.error(a.pos, a.ref.text() + " is a macro-internal name; the program body uses F and D",
                a.length);
    return false;
  }
  if (!s.top && (l == 'F' || l == 'D')) {
    diags.error(
        a.pos,
        a.ref.text() +
            ": a macro cannot see the program's blocks; pass the value in as an input (M/N)",
        a.length);
    return false;
  }
  if (letter_kind(l) != want) {
    diags.error(a.pos,
                std::string(want == Kind::kAnalog ? "analog" : "digital") + " input '" +
                    input_name + "' of " + block + " needs " +
                    (s.top ? top_letter(want) : macro_letter(want)) + "<n>, but " + a.ref.text() +
                    " is " + (want == Kind::kAnalog ? "digital" : "analog"),
                a.length);
    return false;
  }
  ctx.staged.push_back(PendingInput{0, slot, ctx.scope_index, a.ref});
  b.in_pos[slot] = a.pos;
  return true;
}

bool compute_args(const Call& c, const ArgumentContext& ctx, FlatBlock& b) {
  const BlockSpec& sp = *b.spec;
  // Inputs come first, then parameters; for and/or the input count varies.
  size_t n_refs = 0;
  while (n_refs < c.args.size() && c.args[n_refs].kind == Arg::Kind::kRef &&
         is_value_letter(c.args[n_refs].ref.letter)) {
    ++n_refs;
  }
  size_t n_in = std::clamp<size_t>(n_refs, sp.min_inputs, sp.max_inputs);
  if (sp.min_inputs != sp.max_inputs && n_refs < sp.min_inputs) n_in = sp.min_inputs;
  size_t required = 0;
  for (uint8_t k = 0; k < sp.param_count; ++k) {
    if (!sp.params[k].optional) required = k + 1u;
  }
  const size_t min_args = sp.min_inputs + required;
  const size_t max_args = sp.max_inputs + sp.param_count;
  if (c.args.size() < min_args || c.args.size() > max_args) {
    ctx.diags.error(c.name_pos, arity_message(sp, c.args.size()), c.name_length);
    return false;
  }
  bool ok = true;
  b.n_in = static_cast<uint32_t>(n_in);
  for (size_t k = 0; k < n_in; ++k) {
    if (k >= c.args.size()) break;
    // `good` takes an input block of either kind; the flat checks see which block it is.
    const Kind want = sp.reads_quality && c.args[k].kind == Arg::Kind::kRef && is_value_letter(c.args[k].ref.letter)
                          ? letter_kind(c.args[k].ref.letter)
                          : sp.input_kind[k];
    ok &= input_arg(c.args[k], ctx, want, sp.input_names[k], sp.name, static_cast<uint32_t>(k), b);
  }
  const size_t n_params_given = c.args.size() - n_in;
  if (n_params_given < required) {
    ctx.diags.error(c.name_pos, arity_message(sp, c.args.size()), c.name_length);
    return false;
  }
  bool all_known = true;
  for (uint8_t k = 0; k < sp.param_count; ++k) {
    double v = sp.params[k].default_value;
    if (k < n_params_given) {
      bool known = true;
      ok &= bind_parameter(c.args[n_in + k], ctx, sp.params[k], sp.name, v, known);
      all_known &= known;
    }
    b.params.push_back(v);
  }
  if (ok && all_known) {
    if (std::string e = parameter_relation_error(sp, b.params); !e.empty()) {
      ctx.diags.error(c.args[n_in].pos, e, c.args[n_in].length);
      ok = false;
    }
  }
  return ok;
}

bool device(const Arg& a, char letter, uint32_t& out, const char* block, DiagnosticList& diags) {
  if (a.kind != Arg::Kind::kDevice || a.device != letter) {
    const char* what = letter == 'p' ? "processor" : letter == 'd' ? "module" : "channel";
    diags.error(a.pos,
                std::string(block) + " expects the " + what + " address here, like " + letter + "0",
                a.length);
    return false;
  }
  if (std::string e = device_range_error(letter, a.device_no); !e.empty()) {
    diags.error(a.pos, e, a.length);
    return false;
  }
  out = a.device_no;
  return true;
}

bool label_arg(const Call& c, size_t idx, FlatBlock& b, DiagnosticList& diags) {
  if (idx >= c.args.size()) {
    b.label = default_label(b);
    return true;
  }
  const Arg& a = c.args[idx];
  if (a.kind != Arg::Kind::kString) {
    diags.error(a.pos, std::string(b.spec->name) + " expects a \"label\" as its last argument",
                a.length);
    return false;
  }
  if (std::string e = label_error(a.text); !e.empty()) {
    diags.error(a.pos, e, a.length);
    return false;
  }
  b.label = a.text;
  return true;
}

bool io_arity(const Call& c, const FlatBlock& b, size_t min, DiagnosticList& diags) {
  if (c.args.size() < min || c.args.size() > min + 1) {
    diags.error(c.name_pos,
                std::string(b.spec->name) + " takes " + io_form(*b.spec) + ", found " +
                    std::to_string(c.args.size()) + " arguments",
                c.name_length);
    return false;
  }
  return true;
}

bool device_in_args(const Call& c, FlatBlock& b, DiagnosticList& diags) {
  const char* n = b.spec->name;
  if (!io_arity(c, b, 3, diags)) return false;
  uint32_t p = 0, d = 0;
  bool ok = device(c.args[0], 'p', p, n, diags) & device(c.args[1], 'd', d, n, diags) &
            device(c.args[2], 'c', b.c, n, diags);
  b.p = static_cast<uint16_t>(p);
  b.d = static_cast<uint16_t>(d);
  return ok && label_arg(c, 3, b, diags);
}

bool setpoint_args(const Call& c, FlatBlock& b, DiagnosticList& diags) {
  const char* n = b.spec->name;
  if (!io_arity(c, b, 3, diags)) return false;
  uint32_t d = 0;
  bool ok = device(c.args[0], 'd', d, n, diags) & device(c.args[1], 'c', b.c, n, diags);
  b.d = static_cast<uint16_t>(d);
  const Arg& init = c.args[2];
  if (init.kind != Arg::Kind::kNumber) {
    diags.error(init.pos, std::string(n) + " expects its initial value here", init.length);
    ok = false;
  } else if (!setpoint_init_ok(*b.spec, init.number)) {
    diags.error(init.pos, kSetpointInitMessage, init.length);
    ok = false;
  } else {
    b.init = init.number;
  }
  return ok && label_arg(c, 3, b, diags);
}

bool device_out_args(const Call& c, const ArgumentContext& ctx, FlatBlock& b) {
  const char* n = b.spec->name;
  if (!io_arity(c, b, 4, ctx.diags)) return false;
  b.n_in = 1;
  uint32_t p = 0, d = 0;
  bool ok = input_arg(c.args[0], ctx, b.spec->input_kind[0], "value", n, 0, b);
  ok &= device(c.args[1], 'p', p, n, ctx.diags) & device(c.args[2], 'd', d, n, ctx.diags) &
        device(c.args[3], 'c', b.c, n, ctx.diags);
  b.p = static_cast<uint16_t>(p);
  b.d = static_cast<uint16_t>(d);
  return ok && label_arg(c, 4, b, ctx.diags);
}

}  // namespace

bool bind_call_arguments(const Call& c, const ArgumentContext& ctx, FlatBlock& b) {
  switch (b.spec->signature) {
    case Signature::kCompute:
      return compute_args(c, ctx, b);
    case Signature::kDeviceIn:
      return device_in_args(c, b, ctx.diags);
    case Signature::kSetpoint:
      return setpoint_args(c, b, ctx.diags);
    case Signature::kDeviceOut:
      return device_out_args(c, ctx, b);
  }
  return false;
}

bool bind_parameter(const Arg& a, const ArgumentContext& ctx, const ParamSpec& ps,
                    const char* block, double& out, bool& known) {
  DiagnosticList& diags = ctx.diags;
  known = true;
  if (a.kind == Arg::Kind::kRef && a.ref.letter == 'P') {
    const Scope& s = ctx.scope;
    if (s.top) {
      diags.error(
          a.pos,
          a.ref.text() + ": P<n> names a macro parameter and exists only inside a macro definition",
          a.length);
      return false;
    }
    auto it = s.params.find(a.ref.number);
    if (it == s.params.end()) {
      diags.error(a.pos, a.ref.text() + " is not a parameter of MACRO " + s.macro, a.length);
      return false;
    }
    known = it->second.known;
    out = it->second.value;
  } else if (a.kind == Arg::Kind::kNumber) {
    out = a.number;
  } else {
    diags.error(a.pos,
                std::string("parameter '") + ps.name + "' (" + ps.meaning + ") of " + block +
                    " must be a number" +
                    (a.kind == Arg::Kind::kRef ? ", not a block id: parameters are constants" : ""),
                a.length);
    return false;
  }
  if (!known) return true;
  if (std::string e = parameter_error(ps, block, out); !e.empty()) {
    diags.error(a.pos, e, a.length);
    return false;
  }
  return true;
}

}  // namespace rtplc::lang::fbd
