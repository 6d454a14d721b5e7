// `rtplc check --explain`: what the compiler made of a program, for the engineer
// who wrote it — textual execution order, delayed (last-cycle) references, I/O
// bindings, sizes, and how the executor will batch the blocks.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "common/text.h"
#include "lang/compiler.h"

namespace rtplc::lang {
namespace {


std::string bytes(size_t n) {
  if (n < 10 * 1024) return std::to_string(n) + " B";
  return format_number(static_cast<double>(n) / 1024.0) + " KiB";
}

}  // namespace

std::string explain(const CompileResult& r) {
  if (!r.image) return "no image: the program has errors\n";
  const CheckedProgram& p = r.program;
  const TaskImage& img = *r.image;
  const ImageHeader& h = img.header();
  std::string out;
  auto line = [&out](const std::string& s) {
    out += s;
    out += '\n';
  };

  // text index -> schedule index
  std::vector<uint32_t> sched(p.blocks.size(), 0);
  for (uint32_t s = 0; s < img.blocks().size(); ++s) sched[img.blocks()[s].text_index] = s;

  line("Program " + std::string(img.name()) + ": " + std::to_string(p.blocks.size()) +
       " primitive blocks" +
       (p.macro_calls ? " (" + std::to_string(p.macro_calls) + " macro call" +
                            (p.macro_calls == 1 ? "" : "s") + " expanded)"
                      : "") +
       ", period " + format_number(img.period_s()) + " s" +
       (p.period_from_stime ? std::string(" (") + p.period_source + ", line " +
                                  std::to_string(p.stime_pos.line) + ")"
                            : std::string(" (default)")));
  line("");
  line("Execution order (textual; a reference to a later block or to itself reads last cycle's value):");
  // Columns as wide as their longest entry (at least the seed language's
  // widths): imported programs have long instance paths as names.
  struct Row {
    std::string id, block, ins, prm, where;
  };
  std::vector<Row> rows;
  rows.reserve(p.blocks.size());
  for (size_t i = 0; i < p.blocks.size(); ++i) {
    const FlatBlock& b = p.blocks[i];
    std::string ins;
    for (uint32_t k = 0; k < b.n_in; ++k) {
      if (k) ins += ", ";
      ins += p.blocks[b.in[k]].name;
      if (b.delayed[k]) ins += "'";
    }
    std::string prm;
    if (b.spec->signature == Signature::kCompute) {
      for (size_t k = 0; k < b.params.size(); ++k) {
        if (k) prm += ", ";
        prm += std::string(b.spec->params[k].name) + "=" + format_number(b.params[k]);
      }
      // Control flow (docs/st.md, "Loops"): where it goes, what it writes.
      if (b.op == Op::Set || b.op == Op::SSet) {
        prm = "-> " + (b.target < p.blocks.size() ? p.blocks[b.target].name : std::string("?"));
      } else if (b.op == Op::SConst) {
        // Its text, as a literal (a WSTRING's in double quotes), bytes that
        // cannot show escaped.
        const bool wide = !b.params.empty() && b.params[0] == 1;
        prm = (wide ? "\"" : "'") + escape_for_terminal(b.label) + (wide ? "\"" : "'");
      } else if (op_is_branch(b.op)) {
        prm = "-> #" + std::to_string(b.target) + (b.target >= p.blocks.size() ? " (end)" : "");
      } else if (b.op == Op::Pick || b.op == Op::Put) {
        prm += std::string(prm.empty() ? "" : ", ") + std::to_string(b.table.size()) + " elements" +
               (b.table.empty() ? "" : " from " + p.blocks[b.table[0]].name);
      }
    } else if (b.spec->signature == Signature::kSetpoint) {
      prm = "d" + std::to_string(b.d) + ".c" + std::to_string(b.c) + " init=" + format_number(b.init) +
            " \"" + b.label + "\"";
    } else {
      prm = "p" + std::to_string(b.p) + ".d" + std::to_string(b.d) + ".c" + std::to_string(b.c) +
            " \"" + b.label + "\"";
    }
    std::string where = std::to_string(b.pos.line);
    if (b.call_line) where += " (macro, called at line " + std::to_string(b.call_line) + ")";
    std::string id = b.spec->has_output ? b.name : "-";
    rows.push_back({std::move(id), b.written, std::move(ins), std::move(prm), std::move(where)});
  }
  size_t w_id = 14, w_block = 7, w_ins = 28, w_prm = 25;
  for (const Row& row : rows) {
    w_id = std::max(w_id, row.id.size() + 2);
    w_block = std::max(w_block, row.block.size() + 1);
    w_ins = std::max(w_ins, row.ins.size() + 2);
    w_prm = std::max(w_prm, row.prm.size() + 2);
  }
  line("     #  " + pad_right("id", w_id) + pad_right("block", w_block) + pad_right("inputs", w_ins) +
       pad_right("params / device", w_prm) + "line");
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& row = rows[i];
    char idx[24];
    std::snprintf(idx, sizeof idx, "%6zu", i);
    line(std::string(idx) + "  " + pad_right(row.id, w_id) + pad_right(row.block, w_block) +
         pad_right(row.ins, w_ins) + pad_right(row.prm, w_prm) + row.where);
  }
  line("  (' = delayed: reads the value from the previous cycle, 0 in the first cycle)");

  line("");
  std::vector<std::string> delayed;
  for (size_t i = 0; i < p.blocks.size(); ++i) {
    const FlatBlock& b = p.blocks[i];
    for (uint32_t k = 0; k < b.n_in; ++k) {
      if (!b.delayed[k]) continue;
      bool seen = false;  // or(x', x'): one line for the two inputs of one reference
      for (uint32_t j = 0; j < k; ++j) seen = seen || (b.delayed[j] && b.in[j] == b.in[k]);
      if (seen) continue;
      const FlatBlock& src = p.blocks[b.in[k]];
      std::string why = b.in[k] == i ? "reads its own output (a value held from cycle to cycle)"
                                     : "runs later (#" + std::to_string(b.in[k]) + ")";
      delayed.push_back("  line " + std::to_string(b.in_pos[k].line) + ":" +
                        std::to_string(b.in_pos[k].col) + "  " + (b.spec->has_output ? b.name : b.written) +
                        " reads " + src.name + ", which " + why + ": one-cycle delay");
    }
  }
  line("Delayed references: " + std::to_string(delayed.size()));
  for (const std::string& d : delayed) line(d);
  if (!p.notes.empty()) {
    line("");
    line("Front end notes: " + std::to_string(p.notes.size()));
    for (const std::string& n : p.notes) line("  " + n);
  }

  line("");
  line("I/O bindings: " + std::to_string(img.bindings().size()));
  if (!img.bindings().empty()) {
    line("  " + pad_right("dir", 9) + pad_right("group", 7) + pad_right("address", 15) + pad_right("kind", 9) +
         pad_right("label", 18) + "line");
  }
  for (const Binding& b : img.bindings()) {
    std::string dir = b.dir == BindingDir::kInput     ? "in"
                      : b.dir == BindingDir::kOutput  ? "out"
                      : b.dir == BindingDir::kQuality ? "quality"
                                                      : "setpoint";
    std::string group = io_group_name(b.group);
    if (b.device) group += std::string(1, b.device);
    std::string addr = b.dir == BindingDir::kSetpoint
                           ? "d" + std::to_string(b.d) + ".c" + std::to_string(b.c)
                           : "p" + std::to_string(b.p) + ".d" + std::to_string(b.d) + ".c" +
                                 std::to_string(b.c);
    std::string label = std::string(img.str(b.label));
    if (b.dir == BindingDir::kSetpoint) label += " =" + format_number(b.init);
    if (b.flags & kBindingHmi) label += " (HMI)";
    line("  " + pad_right(dir, 9) + pad_right(group, 7) + pad_right(addr, 15) + pad_right(kind_name(b.kind), 9) +
         pad_right(label + " ", 18) + std::to_string(b.line));
  }

  line("");
  size_t state_blocks = 0;
  for (const Instr& in : img.code()) {
    if (op_state_size(in.op, op_param_count(in.op) ? img.params().data() + in.param : nullptr)) {
      ++state_blocks;
    }
  }
  line("Sizes:");
  line("  instructions  " + std::to_string(h.n_instr) + " x 32 B in " + std::to_string(h.n_runs) +
       " runs (the executor dispatches once per run)");
  line("  values        " + std::to_string(h.n_values) + " slots, " + bytes(h.n_values * 8u));
  line("  state         " + std::to_string(h.n_state) + " doubles in " +
       std::to_string(state_blocks) + " blocks, " + bytes(h.n_state * 8u));
  line("  parameters    " + std::to_string(h.n_params) + " prepared (" +
       std::to_string(h.n_raw_params) + " as written), " + bytes(h.n_params * 8u));
  line("  I/O buffers   " + std::to_string(h.n_io_in) + " in, " + std::to_string(h.n_io_out) +
       " out");
  line("  image         " + bytes(img.bytes().size()));

  if (img.runs().size() < img.code().size()) {
    line("");
    line("Schedule (independent blocks of one kind grouped into runs; same results as textual order):");
    size_t shown = 0;
    for (const Run& run : img.runs()) {
      if (++shown > 20) {
        line("  ... " + std::to_string(img.runs().size() - 20) + " more runs");
        break;
      }
      std::string layout = (run.flags & kRunAffine) ? "  plain arrays" : "";
      if (run.flags & kRunUniformParams) layout += ", shared parameters";
      line("  " + pad_right(op_name(run.op), 7) + " x" + pad_right(std::to_string(run.end - run.begin), 7) + layout);
    }
  }
  return out;
}

}  // namespace rtplc::lang
