// The language-neutral checks of a flat program (spec fbd-language.md: "Blocks
// and ids", "Execution order and delays", "Devices and labels", "Errors").
//
// A flat program has no scopes, no macros and no letters: a block is its
// registry entry, a unique name and inputs that are indices of other blocks, so
// an input's kind is the kind of the block it reads. The FBD front end decides
// kinds earlier, by the letter of each id, and reports them where they are
// written; it shares the block rules below and the whole-program phases.
#include "lang/program_checks.h"

#include "blocks/string_ops.h"

#include <cctype>
#include <cmath>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "common/capacities.h"
#include "common/text.h"
#include "lang/iec/iec_functions.h"

namespace rtplc::lang {
namespace {

const char* kind_word(Kind k) {
  return k == Kind::kAnalog ? "analog" : k == Kind::kDigital ? "digital" : "string";
}

std::string line_note(const FlatBlock& b) {
  return " (line " + std::to_string(b.pos.line) + ")";
}

// The identity of a channel for the one-writer and one-label rules.
std::string channel_key(const FlatBlock& b) {
  std::string g = io_group_name(b.spec->io);
  if (b.spec->device_kind != 0) g += std::string(1, b.spec->device_kind);
  return g + " " + device_text(b);
}

// Per-block checks of a flat program, in block order; each block stops at its
// first error so one mistake is reported once.
class FlatBlockChecks {
 public:
  FlatBlockChecks(CheckedProgram& p, DiagnosticList& d) : p_(p), diags_(d) {}

  void run() {
    // Specs first: an input may read a block further down the list.
    for (size_t i = 0; i < p_.blocks.size(); ++i) {
      FlatBlock& b = p_.blocks[i];
      if (b.spec == nullptr) b.spec = find_block(b.written);
      if (b.written.empty() && b.spec != nullptr) b.written = b.spec->name;
    }
    for (FlatBlock& b : p_.blocks) check(b);
  }

 private:
  void check(FlatBlock& b) {
    if (b.spec == nullptr) {
      diags_.error(b.pos, "unknown block '" + b.written + "'" + unknown_block_hint(b.written));
      return;
    }
    if (arity(b) && inputs(b) && parameters(b) && io_fields(b) && naming(b)) {
      b.op = block_op(*b.spec, b.n_in);
    }
  }

  bool arity(const FlatBlock& b) {
    const BlockSpec& sp = *b.spec;
    if (sp.signature == Signature::kCompute) {
      size_t required = 0;
      for (uint8_t k = 0; k < sp.param_count; ++k) {
        if (!sp.params[k].optional) required = k + 1u;
      }
      if (b.n_in < sp.min_inputs || b.n_in > sp.max_inputs || b.params.size() < required ||
          b.params.size() > sp.param_count) {
        diags_.error(b.pos, arity_message(sp, b.n_in + b.params.size()));
        return false;
      }
      return true;
    }
    const uint32_t want = sp.signature == Signature::kDeviceOut ? 1u : 0u;
    if (b.n_in != want || !b.params.empty()) {
      diags_.error(b.pos, std::string(sp.name) + " takes " + io_form(sp) + ": " +
                              std::to_string(want) + " input" + (want == 1 ? "" : "s") +
                              " and no parameters, found " + std::to_string(b.n_in) +
                              " inputs and " + std::to_string(b.params.size()) + " parameters");
      return false;
    }
    return true;
  }

  bool inputs(const FlatBlock& b) {
    const BlockSpec& sp = *b.spec;
    bool ok = true;
    for (uint32_t k = 0; k < b.n_in; ++k) {
      const char* input = sp.signature == Signature::kDeviceOut ? "value" : sp.input_names[k];
      const std::string what = std::string("input '") + input + "' of " + sp.name;
      const SourcePos at = b.in_pos[k].line != 0 ? b.in_pos[k] : b.pos;
      if (b.in[k] >= p_.blocks.size()) {
        diags_.error(at, what + " reads block #" + std::to_string(b.in[k]) + ", which does not " +
                             "exist (the program has " + std::to_string(p_.blocks.size()) +
                             " blocks)");
        ok = false;
        continue;
      }
      const FlatBlock& src = p_.blocks[b.in[k]];
      if (src.spec == nullptr) continue;  // reported as an unknown block
      if (!src.spec->has_output) {
        diags_.error(at, what + " reads " + src.written + line_note(src) +
                             ", an output block, which has no result");
        ok = false;
        continue;
      }
      if (sp.reads_quality) continue;  // either kind; check_quality_inputs() checks the rest
      if (src.spec->out_kind != sp.input_kind[k]) {
        diags_.error(at, std::string(kind_word(sp.input_kind[k])) + " " + what + " needs " +
                             (sp.input_kind[k] == Kind::kAnalog ? "an analog" : sp.input_kind[k] == Kind::kDigital ? "a digital" : "a string") +
                             " value, but " + src.name + " (" + src.written + ") is " +
                             kind_word(src.spec->out_kind));
        ok = false;
      }
    }
    return ok;
  }

  bool parameters(FlatBlock& b) {
    const BlockSpec& sp = *b.spec;
    bool ok = true;
    for (uint8_t k = 0; k < sp.param_count; ++k) {
      if (k >= b.params.size()) {
        b.params.push_back(sp.params[k].default_value);
        continue;
      }
      if (std::string e = parameter_error(sp.params[k], sp.name, b.params[k]); !e.empty()) {
        diags_.error(b.pos, e);
        ok = false;
      }
    }
    if (ok) {
      if (std::string e = parameter_relation_error(sp, b.params); !e.empty()) {
        diags_.error(b.pos, e);
        ok = false;
      }
    }
    return ok;
  }

  bool io_fields(FlatBlock& b) {
    const BlockSpec& sp = *b.spec;
    if (sp.io == IoGroup::kNone) return true;
    bool ok = true;
    const bool has_processor = sp.signature != Signature::kSetpoint;
    for (const auto& [letter, number] :
         {std::pair<char, uint32_t>{'p', has_processor ? b.p : 0u}, {'d', b.d}, {'c', b.c}}) {
      if (std::string e = device_range_error(letter, number); !e.empty()) {
        diags_.error(b.pos, std::string(sp.name) + ": " + e);
        ok = false;
      }
    }
    if (sp.signature == Signature::kSetpoint && !setpoint_init_ok(sp, b.init)) {
      diags_.error(b.pos, kSetpointInitMessage);
      ok = false;
    }
    if (!ok) return false;
    if (b.label.empty()) {
      b.label = default_label(b);
    } else if (std::string e = label_error(b.label); !e.empty()) {
      diags_.error(b.pos, e);
      return false;
    }
    return true;
  }

  bool naming(FlatBlock& b) {
    const BlockSpec& sp = *b.spec;
    if (b.name.empty()) {
      if (sp.has_output) {
        diags_.error(b.pos, std::string(sp.name) + " needs a name for its result");
        return false;
      }
      b.name = std::string(sp.name) + "@" + device_text(b);
      return true;
    }
    auto [it, fresh] = names_.emplace(b.name, b.pos.line);
    if (!fresh) {
      diags_.error(b.pos, duplicate_name_message(b.name, " is already defined", it->second));
      return false;
    }
    return true;
  }

  CheckedProgram& p_;
  DiagnosticList& diags_;
  std::unordered_map<std::string, uint32_t> names_;
};

}  // namespace

void check_flat_program(CheckedProgram& p, DiagnosticList& diags) {
  const size_t errors_before = diags.error_count();
  FlatBlockChecks(p, diags).run();
  // The program rules read every block's spec and inputs; they mean nothing on
  // a list that failed the block checks.
  if (diags.error_count() == errors_before) {
    mark_delayed_inputs(p);
    check_flow(p, diags);
    check_io_channels(p, diags);
    check_quality_inputs(p, diags);
    warn_unused_results(p, diags);
  }
  check_program_size(p, diags);
}

void check_quality_inputs(const CheckedProgram& p, DiagnosticList& diags) {
  for (const FlatBlock& b : p.blocks) {
    if (b.spec == nullptr || !b.spec->reads_quality || b.n_in != 1 || b.in[0] >= p.blocks.size()) continue;
    const FlatBlock& src = p.blocks[b.in[0]];
    if (src.spec == nullptr || src.spec->signature == Signature::kDeviceIn) continue;
    const SourcePos at = b.in_pos[0].line != 0 ? b.in_pos[0] : b.pos;
    diags.error(at, std::string(b.spec->name) + " reads the quality of an input block (dai, ddi, prr, era, ...), but " +
                        src.name + " is " + src.written +
                        (src.spec->signature == Signature::kSetpoint ? ", a set-point, which is always good"
                                                                     : ", which reads no channel"));
  }
}

void check_flow(const CheckedProgram& p, DiagnosticList& diags) {
  const auto n = static_cast<uint32_t>(p.blocks.size());
  for (uint32_t i = 0; i < n; ++i) {
    const FlatBlock& b = p.blocks[i];
    if (b.spec == nullptr || b.spec->signature != Signature::kCompute) continue;
    const Op op = b.op;
    if (op == Op::Set) {
      const FlatBlock* v = b.target < n ? &p.blocks[b.target] : nullptr;
      if (v == nullptr || v->op != Op::Var || v->spec == nullptr || v->spec->out_kind != b.spec->input_kind[0]) {
        diags.error(b.pos, std::string(b.spec->name) + " " + b.name + " must write a " +
                               (b.spec->input_kind[0] == Kind::kDigital ? "dvar" : "var") + " block");
      }
    } else if (op == Op::SSet) {
      const FlatBlock* v = b.target < n ? &p.blocks[b.target] : nullptr;
      if (v == nullptr || v->op != Op::SVar || v->params.empty() || b.params.empty() || v->params[0] != b.params[0]) {
        diags.error(b.pos, "sset " + b.name + " must write an svar block of its length");
      }
    } else if (const size_t units = b.params.empty() || b.params[0] == 0 ? b.label.size() : utf16_units(b.label).size();
               op == Op::SConst && units > kMaxStringLength) {
      diags.error(b.pos, "a string of " + std::to_string(units) + " characters: at most " +
                             std::to_string(kMaxStringLength));
    } else if (op == Op::Pick || op == Op::Put) {
      const bool put = op == Op::Put;
      const Kind kind = put ? b.spec->input_kind[1] : b.spec->out_kind;
      bool ok = !b.table.empty() && b.table.size() <= kMaxPickTable;
      for (uint32_t t : b.table) {
        const FlatBlock* e = t < n ? &p.blocks[t] : nullptr;
        ok = ok && e != nullptr && e->spec != nullptr && e->spec->has_output && e->spec->out_kind == kind &&
             (!put || e->op == Op::Var);
      }
      if (!ok) {
        diags.error(b.pos, std::string(b.spec->name) + " " + b.name + " needs a table of 1 to " +
                               std::to_string(kMaxPickTable) + (put ? " var blocks" : " blocks") + " of its kind");
      }
    } else if (op_is_branch(op)) {
      const bool ok = op == Op::Loop ? b.target <= i : b.target > i && b.target <= n;
      if (!ok) {
        diags.error(b.pos, std::string(b.spec->name) + " " + b.name + " jumps to block #" +
                               std::to_string(b.target) + ", outside " +
                               (op == Op::Loop ? "the blocks before it" : "the blocks after it"));
      }
    }
  }
}

void mark_delayed_inputs(CheckedProgram& p) {
  for (uint32_t i = 0; i < p.blocks.size(); ++i) {
    FlatBlock& b = p.blocks[i];
    for (uint32_t k = 0; k < b.n_in; ++k) b.delayed[k] = b.in[k] >= i;
  }
}

void check_io_channels(const CheckedProgram& p, DiagnosticList& diags) {
  std::map<std::string, const FlatBlock*> writers, setpoints, inputs;
  std::map<std::string, std::pair<std::string, const FlatBlock*>> labels;
  for (const FlatBlock& b : p.blocks) {
    if (b.spec == nullptr || b.spec->io == IoGroup::kNone) continue;
    std::string chan = channel_key(b);
    if (b.spec->signature == Signature::kDeviceOut) {
      auto [it, fresh] = writers.emplace(chan, &b);
      if (!fresh) {
        diags.error(b.pos, "channel " + chan + " is already written by " + it->second->written +
                               line_note(*it->second) + ": each output channel has one writer");
        continue;
      }
    } else if (b.spec->signature == Signature::kSetpoint) {
      auto [it, fresh] = setpoints.emplace(chan, &b);
      if (!fresh) {
        diags.error(b.pos, "set-point " + chan + " is already defined" + line_note(*it->second));
        continue;
      }
    } else {
      auto [it, fresh] = inputs.emplace(chan, &b);
      if (!fresh && it->second->label != b.label) {
        diags.warning(b.pos, "channel " + chan + " is read again under another label ('" + b.label +
                                 "' here, '" + it->second->label + "'" + line_note(*it->second) +
                                 ")");
      }
      if (!fresh) continue;
    }
    auto [lit, fresh_label] = labels.emplace(b.label, std::make_pair(chan, &b));
    if (!fresh_label && lit->second.first != chan) {
      diags.error(b.pos, "label \"" + b.label + "\" already names channel " + lit->second.first +
                             line_note(*lit->second.second) + "; give each channel its own label");
    } else if (!fresh_label && b.spec->signature == Signature::kDeviceOut) {
      diags.error(b.pos, "label \"" + b.label + "\" is used for both reading and writing " + chan);
    }
  }
}

void warn_unused_results(const CheckedProgram& p, DiagnosticList& diags) {
  if (diags.has_errors()) return;
  std::unordered_set<uint32_t> read;
  for (const FlatBlock& b : p.blocks) {
    for (uint32_t k = 0; k < b.n_in; ++k) read.insert(b.in[k]);
  }
  for (uint32_t i = 0; i < p.blocks.size(); ++i) {
    const FlatBlock& b = p.blocks[i];
    if (b.call_line != 0 || b.spec->signature != Signature::kCompute || !b.spec->has_output) continue;
    if (read.count(i) == 0) {
      diags.warning(b.pos, b.name + " (" + b.written + ") is computed but never used");
    }
  }
}

void check_program_size(const CheckedProgram& p, DiagnosticList& diags) {
  if (p.blocks.size() > kMaxBlocks) {
    diags.error(SourcePos{}, "the program expands to " + std::to_string(p.blocks.size()) +
                                 " blocks, more than the limit of " + std::to_string(kMaxBlocks) +
                                 " (RTPLC_MAX_BLOCKS)");
  }
}

std::string unknown_block_hint(std::string_view name) {
  // An IEC name (TON, LIMIT, INT_TO_REAL): FBD text spells it with the
  // primitives lang/iec lowers it to.
  if (const iec::IecFunction* f = iec::find_iec(name); f && find_block(std::string(name)) == nullptr)
    return "; IEC " + f->name + " is written in FBD text as " + f->lowers_to + " (rtplc blocks " + f->name +
           " shows it)";
  if (std::string hint = suggest_block(name); !hint.empty())
    return "; did you mean '" + hint + "'?";
  return " (rtplc blocks lists all " + std::to_string(all_blocks().size()) + ")";
}

std::string arity_message(const BlockSpec& sp, size_t found) {
  std::string form = std::string(sp.name) + "(";
  for (uint8_t k = 0; k < sp.max_inputs; ++k) {
    if (k) form += ", ";
    form += k >= sp.min_inputs ? std::string("[") + sp.input_names[k] + "]" : sp.input_names[k];
  }
  for (uint8_t k = 0; k < sp.param_count; ++k) {
    if (k || sp.max_inputs) form += ", ";
    form += sp.params[k].optional ? std::string("[") + sp.params[k].name + "]" : sp.params[k].name;
  }
  form += ")";
  return std::string(sp.name) + " takes " + form + ", found " + std::to_string(found) +
         " argument" + (found == 1 ? "" : "s");
}

const char* io_form(const BlockSpec& spec) {
  switch (spec.signature) {
    case Signature::kDeviceIn:
      return "(p, d, c, \"label\")";
    case Signature::kSetpoint:
      return "(d, c, init, \"label\")";
    case Signature::kDeviceOut:
      return "(value, p, d, c, \"label\")";
    case Signature::kCompute:
      break;
  }
  return "";
}

std::string parameter_error(const ParamSpec& ps, const char* block, double value) {
  std::string bound;
  if (ps.integer && value != std::floor(value)) bound = "a whole number";
  if (ps.min_exclusive ? !(value > ps.min) : !(value >= ps.min)) {
    bound = ps.min_exclusive ? "greater than " + format_number(ps.min)
                             : "at least " + format_number(ps.min);
  }
  if (!(value <= ps.max)) bound = "at most " + format_number(ps.max);
  if (bound.empty()) return {};
  return std::string("parameter '") + ps.name + "' (" + ps.meaning + ") of " + block + " must be " +
         bound + ", found " + format_number(value);
}

std::string parameter_relation_error(const BlockSpec& spec, const std::vector<double>& params) {
  if (std::string_view(spec.name) == "lim" && params.size() >= 2 && params[0] > params[1]) {
    return "lim: lower limit " + format_number(params[0]) + " is above the upper limit " +
           format_number(params[1]);
  }
  if (std::string_view(spec.name) == "pidc" && params.size() >= 5 && params[3] > params[4]) {
    return "pidc: lowest output " + format_number(params[3]) + " is above the highest output " +
           format_number(params[4]);
  }
  return {};
}

std::string device_range_error(char letter, uint32_t number) {
  const uint32_t max = letter == 'c' ? kMaxChannel : letter == 'd' ? kMaxModule : kMaxProcessor;
  if (number <= max) return {};
  return std::string(1, letter) + " number " + std::to_string(number) + " is out of range (0.." +
         std::to_string(max) + ")";
}

std::string label_error(std::string_view label) {
  if (label.empty() || label.size() > 31) return "a label must have 1 to 31 characters";
  for (char ch : label) {
    if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-' || ch == '.')) {
      return "label \"" + std::string(label) +
             "\" may only use letters, digits, '_', '-' and '.' (it names a channel on the "
             "command line and in CSV headers)";
    }
  }
  return {};
}

bool setpoint_init_ok(const BlockSpec& spec, double init) {
  return spec.out_kind != Kind::kDigital || init == 0 || init == 1;
}

std::string device_text(const FlatBlock& b) {
  if (b.spec->signature == Signature::kSetpoint) {
    return "d" + std::to_string(b.d) + ".c" + std::to_string(b.c);
  }
  return "p" + std::to_string(b.p) + ".d" + std::to_string(b.d) + ".c" + std::to_string(b.c);
}

std::string default_label(const FlatBlock& b) {
  std::string label = std::string(b.spec->name) + "_" + device_text(b);
  for (char& ch : label) {
    if (ch == '.') ch = '_';
  }
  return label;
}

std::string duplicate_name_message(const std::string& name, std::string_view what,
                                   uint32_t first_line) {
  return name + std::string(what) +
         (first_line ? " (line " + std::to_string(first_line) + ")" : "") +
         ": every block needs its own id";
}

}  // namespace rtplc::lang
