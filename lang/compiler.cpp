// Checked program -> TaskImage (spec fbd-language.md "The compiled form").
//
// Scheduling. Textual order is the semantics; the image may run blocks in any
// order that keeps every data dependence of textual order:
//   - block i reads block j with j < i (this cycle's value): j before i;
//   - block i reads block j with j > i (last cycle's value):  i before j.
// Within those constraints we list-schedule, always taking every ready block of
// the opcode with most ready blocks, so replicated loops become long runs of one
// opcode (dispatch is paid per run). Value slots are then numbered in schedule
// order, so the operands of a run sit next to each other in memory.
#include "lang/compiler.h"

#include "blocks/string_ops.h"

#include "common/files.h"
#include "common/text.h"

#include <cstring>
#include <span>
#include <vector>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

#include "lang/front_end.h"
#include "lang/program_checks.h"

namespace rtplc::lang {
namespace {

// Blocks [first, end) of one region in list-schedule order, appended to `order`.
// `edges` (from, to) are the region's ordering constraints.
void list_schedule(const CheckedProgram& prog, uint32_t first, uint32_t end,
                   std::vector<std::pair<uint32_t, uint32_t>>& edges, std::vector<uint32_t>& order) {
  const uint32_t n = end - first;
  // Edges in CSR form, over local indices.
  std::vector<uint32_t> indeg(n, 0), count(n + 1, 0);
  for (auto& e : edges) {
    e.first -= first;
    e.second -= first;
    ++count[e.first + 1];
    ++indeg[e.second];
  }
  for (uint32_t i = 0; i < n; ++i) count[i + 1] += count[i];
  std::vector<uint32_t> succ(edges.size());
  {
    std::vector<uint32_t> fill(count.begin(), count.end() - 1);
    for (auto& e : edges) succ[fill[e.first]++] = e.second;
  }
  auto op_of = [&](uint32_t local) { return static_cast<uint8_t>(prog.blocks[first + local].op); };
  std::vector<std::vector<uint32_t>> ready(kOpCount);
  for (uint32_t i = 0; i < n; ++i) {
    if (indeg[i] == 0) ready[op_of(i)].push_back(i);
  }
  for (;;) {
    // The opcode with most ready blocks; ties go to the earliest in the text.
    int best = -1;
    for (int op = 0; op < kOpCount; ++op) {
      const auto& r = ready[static_cast<size_t>(op)];
      if (r.empty()) continue;
      if (best < 0) {
        best = op;
        continue;
      }
      const auto& rb = ready[static_cast<size_t>(best)];
      if (r.size() > rb.size() ||
          (r.size() == rb.size() && *std::min_element(r.begin(), r.end()) <
                                        *std::min_element(rb.begin(), rb.end()))) {
        best = op;
      }
    }
    if (best < 0) break;
    std::vector<uint32_t> batch_now;
    batch_now.swap(ready[static_cast<size_t>(best)]);
    std::sort(batch_now.begin(), batch_now.end());
    for (uint32_t i : batch_now) {
      order.push_back(first + i);
      for (uint32_t e = count[i]; e < count[i + 1]; ++e) {
        const uint32_t s = succ[e];
        if (--indeg[s] == 0) ready[op_of(s)].push_back(s);
      }
    }
  }
  // textual order is a topological order of these edges, so every block is placed
}

struct Schedule {
  std::vector<uint32_t> order;      // schedule position -> block index
  std::vector<uint8_t> run_starts;  // per position: a run must start here (a region's first)
  // Per block index: where execution continues when a branch targets it (the
  // schedule position its region starts at; n for the end). Set for leaders.
  std::vector<uint32_t> entry;
};

// Control flow cuts the program into regions: straight-line stretches that
// execution enters only at their first block and leaves only after their last
// (a branch is a region of its own; a branch target starts one). Regions keep
// their textual order, so every data dependence between two of them holds;
// inside a region blocks are list-scheduled, and a set of a variable stays
// after the blocks before it that read the variable and before those after it.
// Without control flow the whole program is one region. With it, constants
// (no inputs, no state) run first, before any branch: a front end shares one
// constant block among all its readers, and a constant placed in code a
// branch skips would never be written.
Schedule schedule(const CheckedProgram& prog, bool batch) {
  const auto n = static_cast<uint32_t>(prog.blocks.size());
  Schedule out;
  out.order.reserve(n);
  out.run_starts.assign(n, 0);
  out.entry.assign(n + 1, n);
  std::vector<uint8_t> leader(n + 1, 0);
  leader[0] = 1;
  bool flow = false;
  for (uint32_t i = 0; i < n; ++i) {
    const FlatBlock& b = prog.blocks[i];
    if (!op_is_branch(b.op)) continue;
    flow = true;
    leader[i] = 1;
    leader[i + 1] = 1;
    if (b.target < n) leader[b.target] = 1;
  }
  auto hoisted = [&](uint32_t i) {
    // (constants are shared: the first use may sit in a loop that runs no
    // iteration, so they run before any branch; a string literal too)
    return flow && (prog.blocks[i].op == Op::ConstA || prog.blocks[i].op == Op::ConstD || prog.blocks[i].op == Op::SConst);
  };
  if (flow) {
    for (uint32_t i = 0; i < n; ++i) {
      if (hoisted(i)) out.order.push_back(i);
    }
    if (!out.order.empty()) out.run_starts[0] = 1;
  }
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  std::vector<uint32_t> members;
  for (uint32_t first = 0; first < n;) {
    uint32_t end = first + 1;
    while (end < n && !leader[end]) ++end;
    // A region whose blocks were all hoisted is empty: entering it is
    // entering the next one, whose start is this same position.
    out.entry[first] = static_cast<uint32_t>(out.order.size());
    members.clear();
    bool indexed = false;  // a pick or put reads or writes through its table
    for (uint32_t i = first; i < end; ++i) {
      if (!hoisted(i)) members.push_back(i);
      indexed = indexed || prog.blocks[i].op == Op::Pick || prog.blocks[i].op == Op::Put;
    }
    if (members.empty()) {
      first = end;
      continue;
    }
    out.run_starts[out.order.size()] = 1;
    if (!batch || members.size() == 1 || members.size() != end - first || indexed) {
      // (a region that lost a constant keeps text order: its blocks are few;
      // so does one with a pick or put, whose table edges the scheduler
      // does not model)
      for (uint32_t i : members) out.order.push_back(i);
      first = end;
      continue;
    }
    edges.clear();
    std::map<uint32_t, std::vector<uint32_t>> sets;  // var block -> its sets here, in order
    for (uint32_t i = first; i < end; ++i) {
      const FlatBlock& b = prog.blocks[i];
      for (uint32_t k = 0; k < b.n_in; ++k) {
        const uint32_t j = b.in[k];
        if (j < first || j >= end || j == i) continue;
        if (j < i) edges.emplace_back(j, i);
        else edges.emplace_back(i, j);
      }
      if (b.op == Op::Set || b.op == Op::SSet) sets[b.target].push_back(i);
    }
    if (!sets.empty()) {
      for (uint32_t i = first; i < end; ++i) {
        const FlatBlock& b = prog.blocks[i];
        for (uint32_t k = 0; k < b.n_in; ++k) {
          auto it = sets.find(b.in[k]);
          if (it == sets.end()) continue;
          for (uint32_t s : it->second) {
            if (s < i) edges.emplace_back(s, i);
            else if (s > i) edges.emplace_back(i, s);
          }
        }
      }
      for (const auto& [var, list] : sets) {
        for (size_t k = 1; k < list.size(); ++k) edges.emplace_back(list[k - 1], list[k]);
      }
    }
    list_schedule(prog, first, end, edges, out.order);
    first = end;
  }
  return out;
}

// An sconst's character codes: its label's bytes, or for a WSTRING (params
// {1}) the label's UTF-8 as UTF-16 code units.
std::vector<double> sconst_units(const FlatBlock& b) {
  std::vector<double> out;
  if (!b.params.empty() && b.params[0] == 1) {
    for (uint16_t u : utf16_units(b.label)) out.push_back(u);
  } else {
    for (char c : b.label) out.push_back(static_cast<double>(static_cast<unsigned char>(c)));
  }
  return out;
}

std::string channel_id(const FlatBlock& b) {
  // Identity of an input channel for de-duplication (two blocks reading one channel).
  return std::string(io_group_name(b.spec->io)) + static_cast<char>(b.spec->device_kind ? b.spec->device_kind : '-') +
         (b.spec->signature == Signature::kSetpoint ? "S" : "I") + std::to_string(b.p) + "." +
         std::to_string(b.d) + "." + std::to_string(b.c);
}

// Marks a run affine when its operands form plain arrays (see kRunAffine), so
// the executor can drop the per-element index loads. Runs whose output range
// overlaps an input range (a block reading its own output) stay indexed: the
// affine loops assume the arrays do not alias.
void mark_affine(Run& run, const ImageBuilder& ib) {
  const Op op = run.op;
  if (op == Op::Dely || run.end - run.begin < 4) return;
  const Instr& first = ib.code[run.begin];
  const uint32_t n = run.end - run.begin, n_in = op_is_load(op) ? 1 : op_input_count(op);
  const uint32_t np = op_param_count(op), ns = op_state_size(op, nullptr);
  bool uniform = np > 0;
  for (uint32_t j = 0; j < n; ++j) {
    const Instr& in = ib.code[run.begin + j];
    if (in.out != first.out + j || in.state != first.state + j * ns ||
        in.param != first.param + j * np) {
      return;
    }
    for (uint32_t k = 0; k < n_in; ++k) {
      if (in.in[k] != first.in[k] + j) return;
    }
    for (uint32_t k = 0; k < np && uniform; ++k) {
      uniform = ib.params[in.param + k] == ib.params[first.param + k];
    }
  }
  // Loads and stores move between the value arena and an I/O buffer: their
  // operands are in different arrays and cannot overlap.
  const bool same_array = !op_is_load(op) && !op_is_store(op);
  for (uint32_t k = 0; k < n_in && same_array; ++k) {
    const uint32_t a = first.in[k], o = first.out;
    if (a < o + n && o < a + n) return;  // [a, a+n) and [o, o+n) overlap
  }
  if (op_is_load(op) && first.in[0] + n > ib.n_io_in) return;
  run.flags = static_cast<uint8_t>(kRunAffine | (uniform ? kRunUniformParams : 0));
  run.out = first.out;
  for (uint32_t k = 0; k < 3; ++k) run.in[k] = first.in[k];
  run.param = first.param;
  run.state = first.state;
}

}  // namespace

Result<TaskImage> build_image(const CheckedProgram& prog, const CompileOptions& opt,
                              uint64_t source_hash) {
  const double dt = opt.period_override.value_or(prog.period);
  if (!(dt >= 1e-5 && dt <= 3600)) return make_error("task period out of range");
  const auto n = static_cast<uint32_t>(prog.blocks.size());
  const Schedule plan = schedule(prog, opt.batch);
  const std::vector<uint32_t>& order = plan.order;
  std::vector<uint32_t> sched_of(n);
  for (uint32_t s = 0; s < n; ++s) sched_of[order[s]] = s;

  ImageBuilder ib;
  ib.dt = dt;
  ib.period_ns = std::llround(dt * 1e9);
  ib.source_hash = source_hash;
  ib.name = ib.add_string(opt.name.empty() ? "program" : opt.name);

  // Value slots in schedule order.
  std::vector<uint32_t> slot(n, 0);
  for (uint32_t s = 0; s < n; ++s) {
    const FlatBlock& b = prog.blocks[order[s]];
    if (!op_writes_value(b.op)) continue;
    slot[order[s]] = ib.n_values;
    // A string takes its length and cap characters (ops.h, "Strings").
    const double cap = b.op == Op::SConst ? static_cast<double>(sconst_units(b).size()) : b.params.empty() ? 0 : b.params[0];
    ib.n_values += op_value_width(b.op, &cap);
  }
  // I/O buffer indices in schedule order, so a run of loads or stores copies
  // between contiguous ranges. (Bindings, and so CSV columns, stay in textual
  // order; nothing outside the image depends on these indices.)
  std::vector<uint32_t> io_index(n, 0);
  std::map<std::string, uint32_t> in_channels;
  for (uint32_t s = 0; s < n; ++s) {
    const uint32_t i = order[s];
    const FlatBlock& b = prog.blocks[i];
    if (op_is_load(b.op)) {
      // `good` reads the quality of its input block's channel: a slot of its own.
      const std::string id = b.spec->reads_quality ? "Q" + channel_id(prog.blocks[b.in[0]]) : channel_id(b);
      auto [it, fresh] = in_channels.emplace(id, ib.n_io_in);
      if (fresh) ++ib.n_io_in;
      io_index[i] = it->second;
    } else if (op_is_store(b.op)) {
      io_index[i] = ib.n_io_out++;
    }
  }

  if (!opt.output_layout.empty()) {
    // Keep the running layout: a known channel keeps its index, a new one goes
    // after all of them. Indices left unused by removed channels stay holes.
    std::map<std::string, uint32_t> fixed;
    for (uint32_t k = 0; k < opt.output_layout.size(); ++k) fixed.emplace(opt.output_layout[k], k);
    uint32_t next = static_cast<uint32_t>(opt.output_layout.size());
    for (uint32_t s = 0; s < n; ++s) {
      const uint32_t i = order[s];
      const FlatBlock& b = prog.blocks[i];
      if (!op_is_store(b.op)) continue;
      Binding probe{};
      probe.dir = BindingDir::kOutput;
      probe.group = b.spec->io;
      probe.device = b.spec->device_kind;
      probe.p = b.p;
      probe.d = b.d;
      probe.c = b.c;
      auto it = fixed.find(binding_key(probe));
      io_index[i] = it != fixed.end() ? it->second : next++;
    }
    ib.n_io_out = next;
  }

  ib.code.reserve(n);
  ib.blocks.reserve(n);
  for (uint32_t s = 0; s < n; ++s) {
    const uint32_t i = order[s];
    const FlatBlock& b = prog.blocks[i];
    Instr in{};
    in.op = b.op;
    in.n_in = static_cast<uint8_t>(op_input_count(b.op));
    if (op_is_load(b.op)) {
      in.in[0] = io_index[i];
      in.out = slot[i];
    } else if (b.op == Op::Set || b.op == Op::SSet || b.op == Op::Put || op_is_branch(b.op)) {
      for (uint32_t k = 0; k < b.n_in; ++k) {
        in.in[k] = slot[b.in[k]];
        if (b.delayed[k]) in.flags = static_cast<uint16_t>(in.flags | (kInstrDelayed0 << k));
      }
      in.out = b.op == Op::Set || b.op == Op::SSet ? slot[b.target] : 0;  // a branch's run index: set below
    } else {
      for (uint32_t k = 0; k < b.n_in; ++k) {
        in.in[k] = slot[b.in[k]];
        if (b.delayed[k]) in.flags = static_cast<uint16_t>(in.flags | (kInstrDelayed0 << k));
      }
      in.out = op_is_store(b.op) ? io_index[i] : slot[i];
    }
    in.param = static_cast<uint32_t>(ib.params.size());
    const uint32_t np = op_param_count(b.op);
    if (b.op == Op::Pick || b.op == Op::Put) {
      // n, lo, then the slot of each table entry (a put's: its var's).
      ib.params.push_back(static_cast<double>(b.table.size()));
      ib.params.push_back(b.params.empty() ? 0.0 : b.params[0]);
      for (uint32_t t : b.table) ib.params.push_back(static_cast<double>(slot[t]));
    } else if (b.op == Op::SConst) {
      // Its length, then its character codes.
      const std::vector<double> units = sconst_units(b);
      ib.params.push_back(static_cast<double>(units.size()));
      ib.params.insert(ib.params.end(), units.begin(), units.end());
    } else {
      ib.params.resize(ib.params.size() + np);
      prepare_params(b.op, b.params, dt, ib.params.data() + in.param);
    }
    in.state = ib.n_state;
    ib.n_state += op_state_size(b.op, np ? ib.params.data() + in.param : nullptr);
    ib.code.push_back(in);

    BlockInfo bi{};
    bi.key = fnv1a64(b.name);
    bi.name = ib.add_string(b.name);
    bi.block = ib.add_string(b.written);
    bi.line = b.pos.line;
    bi.col = b.pos.col;
    bi.call_line = b.call_line;
    bi.text_index = i;
    bi.raw_param = static_cast<uint32_t>(ib.raw_params.size());
    bi.raw_count = static_cast<uint32_t>(b.params.size());
    ib.raw_params.insert(ib.raw_params.end(), b.params.begin(), b.params.end());
    ib.blocks.push_back(bi);

    if (ib.runs.empty() || ib.runs.back().op != b.op || plan.run_starts[s] != 0) {
      Run run{};
      run.op = b.op;
      run.begin = s;
      run.end = s + 1;
      ib.runs.push_back(run);
    } else {
      ib.runs.back().end = s + 1;
    }
  }
  for (Run& run : ib.runs) {
    if (!op_is_branch(run.op) && run.op != Op::Set && run.op != Op::Var && !op_is_string(run.op)) mark_affine(run, ib);
  }
  // Branch targets: the run that starts where the target's region starts (a
  // run begins at every region's first position), or the end.
  {
    std::vector<uint32_t> run_of_pos(n + 1, static_cast<uint32_t>(ib.runs.size()));
    for (uint32_t r = 0; r < ib.runs.size(); ++r) {
      for (uint32_t s = ib.runs[r].begin; s < ib.runs[r].end; ++s) run_of_pos[s] = r;
    }
    for (uint32_t s = 0; s < n; ++s) {
      const FlatBlock& b = prog.blocks[order[s]];
      if (!op_is_branch(b.op)) continue;
      ib.code[s].out = run_of_pos[plan.entry[std::min(b.target, n)]];
    }
  }

  for (uint32_t i = 0; i < n; ++i) {
    const FlatBlock& b = prog.blocks[i];
    // A `good` block binds the channel of the input block it reads, in that
    // block's terms (its kind is the channel's; the block's result is digital).
    const bool quality = b.spec->reads_quality;
    const FlatBlock& ch = quality ? prog.blocks[b.in[0]] : b;
    if (!quality && b.spec->io == IoGroup::kNone) continue;
    Binding bd{};
    bd.dir = quality                                     ? BindingDir::kQuality
             : b.spec->signature == Signature::kDeviceOut ? BindingDir::kOutput
             : b.spec->signature == Signature::kSetpoint  ? BindingDir::kSetpoint
                                                          : BindingDir::kInput;
    bd.group = ch.spec->io;
    bd.kind = ch.spec->out_kind;
    bd.device = ch.spec->device_kind;
    bd.p = ch.p;
    bd.d = ch.d;
    bd.c = ch.c;
    bd.io_index = io_index[i];
    bd.instr = sched_of[i];
    bd.label = ib.add_string(ch.label);
    bd.line = b.pos.line;
    bd.init = quality ? 0 : b.init;
    bd.flags = ch.hmi ? kBindingHmi : 0;
    ib.bindings.push_back(bd);
  }
  return ib.finish();
}

std::optional<EditorSemantics> parse_editor_semantics(std::string_view text) {
  if (text == "auto") return EditorSemantics::kFromHeader;
  if (text == "matiec") return EditorSemantics::kMatiec;
  if (text == "codesys") return EditorSemantics::kCodesys;
  return std::nullopt;
}

std::optional<std::string> read_text_file(const std::string& path, std::string* error) {
  Result<std::string> text = read_file_bounded(path, kMaxSourceBytes);
  if (!text) {
    if (error) *error = text.error();
    return std::nullopt;
  }
  return std::move(text).value();
}

namespace {

// Every language ends in the same checks and the same image builder.
CompileResult compile_as(std::string_view source, const CompileOptions& options, const FrontEnd& language) {
  CompileResult r;
  // Guard the compiler's own memory against absurd input; real programs are KBs.
  if (source.size() > kMaxSourceBytes) {
    r.diags.error(SourcePos{}, "source larger than 64 MiB");
    return r;
  }
  if (!options.entry.empty() && !language.has_entries) {
    std::string with_entries;  // "PLCopen XML"
    for (const FrontEnd* f : front_ends()) {
      if (f->has_entries) with_entries += (with_entries.empty() ? "" : " or ") + std::string(f->name);
    }
    r.diags.error(SourcePos{}, "an entry ('" + options.entry + "': --entry, or a task's program_instance) chooses a "
                               "task or program of a " + with_entries + " project; this file is one " +
                               language.name + " program, so leave the entry out");
    return r;
  }
  r.program = language.read(source, options, r.diags);
  if (r.diags.has_errors()) return r;
  switch (language.checks) {
    case FrontEnd::Checks::kAll:
      check_flat_program(r.program, r.diags);
      break;
    case FrontEnd::Checks::kAllButUnusedWarnings: {
      // Blocks the front end generated (a variable's end-of-cycle copy nobody
      // reads) are not the author's doing: "computed but never used" is for
      // languages where every block is written by hand.
      DiagnosticList checks;
      check_flat_program(r.program, checks);
      for (const Diagnostic& d : checks.items()) {
        if (d.severity == Severity::kError) r.diags.error(d.pos, d.message, d.length);
        else if (d.message.find("is computed but never used") == std::string::npos)
          r.diags.warning(d.pos, d.message, d.length);
      }
      break;
    }
    case FrontEnd::Checks::kRunByFrontEnd:
      break;
  }
  if (r.diags.has_errors()) return r;
  Result<TaskImage> img = build_image(r.program, options, fnv1a64(source));
  if (!img) {
    r.diags.error(SourcePos{}, img.error());
    return r;
  }
  r.image = std::move(img).value();
  return r;
}

}  // namespace

bool is_task_image(std::string_view source) {
  return source.size() >= sizeof kImageMagic && std::memcmp(source.data(), kImageMagic, sizeof kImageMagic) == 0;
}

namespace {

// A compiled task image (`rtplc compile -o F.img`) where a program is expected:
// verified as the runtime verifies every image, never trusted because of its
// magic. Its parameters were prepared for the period it was compiled with, so
// it runs at that period only.
CompileResult load_task_image(std::string_view bytes, const CompileOptions& options) {
  CompileResult r;
  std::vector<uint64_t> aligned((bytes.size() + 7) / 8);
  std::memcpy(aligned.data(), bytes.data(), bytes.size());
  const std::span<const std::byte> span(reinterpret_cast<const std::byte*>(aligned.data()), bytes.size());
  if (bytes.size() > sizeof(ImageHeader)) {
    ImageHeader h;
    std::memcpy(&h, bytes.data(), sizeof h);
    if (h.version == kImageVersion && h.body_check != image_body_check(span)) {
      r.diags.error(SourcePos{}, "the task image is damaged: its check value does not match its contents "
                                 "(changed after it was compiled); compile its source again");
      return r;
    }
  }
  Result<TaskImage> img = TaskImage::from_bytes(span);
  if (!img) {
    r.diags.error(SourcePos{}, "not a valid task image: " + img.error() + " (compile its source again)");
    return r;
  }
  const double dt = img->period_s();
  if (options.period_override && std::fabs(*options.period_override - dt) > 1e-9 * dt) {
    r.diags.error(SourcePos{}, "this task image was compiled for a period of " + format_number(dt) +
                                   " s and its parameters are prepared for it; it cannot run every " +
                                   format_number(*options.period_override) +
                                   " s: compile the source with --period " + format_number(*options.period_override));
    return r;
  }
  if (!options.entry.empty()) {
    r.diags.error(SourcePos{}, "an entry ('" + options.entry + "') chooses a program of a PLCopen project; a task "
                               "image is one program already");
    return r;
  }
  r.program.period = dt;
  r.program.period_from_stime = true;
  r.program.period_source = "the image";
  r.image = std::move(img).value();
  return r;
}

}  // namespace

CompileResult compile_source(std::string_view source, const CompileOptions& options) {
  if (is_task_image(source)) return load_task_image(source, options);
  return compile_as(source, options, front_end_for({}, source));
}

CompileResult compile_file(const std::string& path, const CompileOptions& options) {
  std::string err;
  std::optional<std::string> text = read_text_file(path, &err);
  if (!text) {
    CompileResult r;
    r.diags.error(SourcePos{}, err);
    return r;
  }
  CompileOptions o = options;
  if (o.name.empty()) {
    size_t slash = path.find_last_of('/');
    o.name = slash == std::string::npos ? path : path.substr(slash + 1);
  }
  auto ends_with = [&](const char* ext) {
    const size_t n = std::char_traits<char>::length(ext);
    return path.size() > n && path.compare(path.size() - n, n, ext) == 0;
  };
  if (is_task_image(*text)) return load_task_image(*text, o);
  // A Petri net is analysed, not compiled: say so instead of a cascade of
  // FBD errors about XML.
  if (ends_with(".pnml") || text->substr(0, 4096).find("<pnml") != std::string::npos) {
    CompileResult r;
    r.diags.error(SourcePos{}, "this is a Petri net (PNML), not a program; `rtplc analyze " + path +
                                   "` analyses it, and an SFC program (.sfc) is what a task runs");
    return r;
  }
  // A file whose extension a language registered is that language even when
  // its header is missing (a .sfc file without its SFC line: the SFC parser
  // then says what it expected); any other is recognised by its text.
  return compile_as(*text, o, front_end_for(path, *text));
}

}  // namespace rtplc::lang
