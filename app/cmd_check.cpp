// `rtplc check`, `rtplc compile` and `rtplc blocks`: the compiler's front door.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>

#include "app/arguments.h"
#include "app/commands.h"
#include "blocks/native.h"
#include "blocks/registry.h"
#include "common/files.h"
#include "config/config.h"
#include "editor/diagram.h"
#include "lang/compiler.h"
#include "lang/iec/iec_functions.h"
#include "sched/runtime.h"

namespace rtplc::app {
namespace {

struct CheckArgs {
  std::string file;
  bool explain = false;
  bool werror = false;
  double period = 0;
  std::string output;
  std::string block;
  bool markdown = false;
  bool json = false;
  bool iec = false;
  bool paths = false;
  std::string entry;
  std::string semantics = "auto";
  std::string name;
  std::string native_source;
};

// Prints diagnostics; returns true when the program compiled.
bool report(const std::string& file, const lang::CompileResult& r, bool werror) {
  std::string err;
  std::optional<std::string> text = lang::read_text_file(file, &err);
  const bool color = isatty(STDERR_FILENO) != 0;
  std::string rendered = r.diags.render(file, text ? *text : std::string(), color);
  if (!rendered.empty()) std::fputs(rendered.c_str(), stderr);
  if (r.diags.has_errors()) {
    std::fprintf(stderr, "%s: %zu error%s, %zu warning%s; nothing compiled\n", file.c_str(),
                 r.diags.error_count(), r.diags.error_count() == 1 ? "" : "s",
                 r.diags.warning_count(), r.diags.warning_count() == 1 ? "" : "s");
    return false;
  }
  if (werror && r.diags.warning_count() > 0) {
    std::fprintf(stderr, "%s: warnings treated as errors (--werror)\n", file.c_str());
    return false;
  }
  return true;
}

lang::CompileOptions options_from(const CheckArgs& a) {
  lang::CompileOptions o;
  if (a.period > 0) o.period_override = a.period;
  o.entry = a.entry;
  o.semantics = *lang::parse_editor_semantics(a.semantics);
  return o;
}

bool is_config(const std::string& f) {
  auto ends = [&f](const char* e) {
    const std::string x(e);
    return f.size() > x.size() && f.compare(f.size() - x.size(), x.size(), x) == 0;
  };
  return ends(".yaml") || ends(".yml");
}

// A runtime configuration: everything `rtplc run` checks before it starts a
// thread — the YAML, every program, one writer per output, the plant wiring.
void run_check_config(const CheckArgs& a) {
  if (a.period > 0) {
    std::fprintf(stderr, "rtplc check: --period applies to one program; in %s each task's period is "
                 "its `period:` key (or its program's stime)\n", a.file.c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  config::LoadResult cfg = config::load_config(a.file);
  const bool color = isatty(STDERR_FILENO) != 0;
  if (!cfg.diags.items().empty()) std::fputs(cfg.render(color).c_str(), stderr);
  if (!cfg.ok()) {
    std::fprintf(stderr, "%s: the configuration has errors\n", a.file.c_str());
    throw CLI::RuntimeError(kExitFailure);
  }
  if (a.paths) {
    // For scripts/deploy: exactly the files the configuration needs, and where
    // it keeps its state (only what the configuration itself sets).
    for (const config::TaskConfig& t : cfg.config->tasks) std::printf("program %s\n", t.program.c_str());
    if (!cfg.config->retain_path.empty()) std::printf("retain_file %s\n", cfg.config->retain_path.c_str());
    if (!cfg.config->socket_path.empty()) std::printf("socket %s\n", cfg.config->socket_path.c_str());
    return;
  }
  sched::RuntimeOptions opt;
  opt.name_override = "check-" + std::to_string(getpid());  // never clashes with a running one
  opt.lock_memory = false;
  // What `rtplc run CONFIG [--name NAME]` would restore and boot (read only).
  opt.state_name = a.name.empty() ? cfg.config->name : a.name;
  opt.check_only = true;
  sched::LoadReport report;
  auto rt = sched::Runtime::load(*cfg.config, opt, report);
  const std::string rendered = report.render(color);
  if (!rendered.empty()) std::fputs(rendered.c_str(), stderr);
  if (!rt) {
    std::fprintf(stderr, "%s: the runtime cannot start\n", a.file.c_str());
    throw CLI::RuntimeError(kExitFailure);
  }
  std::printf("%s: OK, %zu tasks, %u channels\n", a.file.c_str(), rt->task_count(),
              rt->image().channel_count());
  for (const std::string& l : rt->describe()) std::printf("  %s\n", l.c_str());
}

void run_check(const CheckArgs& a) {
  require_program(a.file, "check", true);
  if (a.paths && !is_config(a.file)) {
    std::fprintf(stderr, "rtplc check: --paths lists a configuration's files; %s is a program\n",
                 a.file.c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  if (is_config(a.file)) {
    run_check_config(a);
    return;
  }
  if (a.explain && input_kind(a.file) == InputKind::kTaskImage) {
    std::fprintf(stderr, "rtplc check: --explain needs the program's source; the task image %s keeps only "
                 "what runs (check verifies it)\n", a.file.c_str());
    throw CLI::RuntimeError(kExitUsage);
  }
  lang::CompileResult r = lang::compile_file(a.file, options_from(a));
  if (!report(a.file, r, a.werror)) throw CLI::RuntimeError(kExitFailure);
  const ImageHeader& h = r.image->header();
  std::printf("%s: OK, %u blocks, period %g s, %u I/O bindings, image %zu bytes\n", a.file.c_str(),
              h.n_instr, h.dt, h.n_bindings, r.image->bytes().size());
  if (a.explain) {
    std::printf("\n%s", lang::explain(r).c_str());
  }
}

void run_compile(const CheckArgs& a) {
  require_program(a.file, "compile");
  std::string out = a.output;
  if (out.empty()) {
    out = a.file;
    if (out.size() > 4 && out.substr(out.size() - 4) == ".fbd") out.resize(out.size() - 4);
    out += ".img";
  }
  // Before compiling: an output that cannot be written, or that is the source
  // itself (`compile F.fbd -o F.fbd`), is refused and nothing is touched.
  require_output_path(out, "compile", a.output.empty() ? "output" : "-o", {a.file});
  lang::CompileResult r = lang::compile_file(a.file, options_from(a));
  if (!report(a.file, r, a.werror)) throw CLI::RuntimeError(kExitFailure);
  // Written beside, then renamed: a crash never leaves a half-written image.
  auto bytes = r.image->bytes();
  if (Result<void> w = write_file_atomically(
          out, std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()), 0644);
      !w) {
    std::fprintf(stderr, "rtplc compile: %s\n", w.error().c_str());
    throw CLI::RuntimeError(kExitFailure);
  }
  std::printf("%s -> %s (%zu bytes, %u blocks)\n", a.file.c_str(), out.c_str(),
              r.image->bytes().size(), r.image->header().n_instr);
  if (!a.native_source.empty()) {
    NativeStats st;
    const std::string src = native_source(*r.image, &st);
    if (Result<void> w = write_file_atomically(a.native_source, src, 0644); !w) {
      std::fprintf(stderr, "rtplc compile: %s\n", w.error().c_str());
      throw CLI::RuntimeError(kExitFailure);
    }
    std::printf("%s: the native code's C++ (%u runs compiled, %u left to the interpreter)\n",
                a.native_source.c_str(), st.native_runs, st.interpreted_runs);
  }
}

void run_blocks(const CheckArgs& a) {
  if (a.markdown) {
    std::fputs(blocks_markdown().c_str(), stdout);
    return;
  }
  if (a.json) {
    std::printf("%s\n", editor::registry_json().dump(2).c_str());
    return;
  }
  if (a.iec) {
    std::fputs(lang::iec::iec_functions_markdown().c_str(), stdout);
    return;
  }
  if (!a.block.empty()) {
    const BlockSpec* b = find_block(a.block);
    if (const lang::iec::IecFunction* f = b ? nullptr : lang::iec::find_iec(a.block)) {
      std::string ins, outs;
      for (const char* i : f->inputs) ins += (ins.empty() ? "" : ", ") + std::string(i);
      if (f->extensible) ins += ", ...";
      for (const char* o : f->outputs) outs += (outs.empty() ? "" : ", ") + std::string(o);
      std::printf("%s — IEC 61131-3 standard %s (%s) -> (%s)\n  lowers to: %s\n", f->name.c_str(),
                  f->function_block ? "function block" : "function", ins.c_str(), outs.c_str(),
                  f->lowers_to);
      return;
    }
    if (!b) {
      std::string hint = suggest_block(a.block);
      std::fprintf(stderr, "rtplc blocks: no block named '%s'%s\n", a.block.c_str(),
                   hint.empty() ? "" : ("; did you mean '" + hint + "'?").c_str());
      throw CLI::RuntimeError(kExitFailure);
    }
    std::printf("%s%s%s — %s (%s)\n", b->name, b->alias ? " / " : "", b->alias ? b->alias : "",
                b->summary, group_name(b->group));
    std::printf("  contract: %s\n", b->contract);
    if (b->state[0]) std::printf("  state:    %s\n", b->state);
    if (b->errors[0]) std::printf("  errors:   %s\n", b->errors);
    for (uint8_t k = 0; k < b->param_count; ++k) {
      std::printf("  param %s: %s%s\n", b->params[k].name, b->params[k].meaning,
                  b->params[k].optional ? " (optional)" : "");
    }
    return;
  }
  BlockGroup last = BlockGroup::kControl;
  bool first = true;
  for (const BlockSpec& b : all_blocks()) {
    if (first || b.group != last) {
      std::printf("%s%s:\n", first ? "" : "\n", group_name(b.group));
      last = b.group;
      first = false;
    }
    std::printf("  %-6s %s\n", b.name, b.summary);
  }
  std::printf("\n`rtplc blocks NAME` shows one block's contract; docs/blocks.md has them all.\n");
}

}  // namespace

void add_check_commands(CLI::App& app) {
  auto args = std::make_shared<CheckArgs>();

  CLI::App* check = app.add_subcommand(
      "check", "Check an FBD or SFC program, or a whole runtime configuration (.yaml); nothing runs.");
  check->footer(
      "Errors are shown as file:line:col with the line and a caret; every error in the file is\n"
      "listed, and the exit code is 1 if there was any. A .yaml configuration is checked the way\n"
      "`rtplc run` would: the YAML, every program, one writer per output, the plant wiring.\n"
      "Examples:\n  rtplc check examples/seed_pid.fbd --explain\n  rtplc check examples/tank.sfc --explain\n  rtplc check examples/plcopen_tank.xml --explain   (PLCopen XML, docs/plcopen.md)\n"
      "  rtplc check examples/plant.yaml");
  check->add_option("file", args->file, "control algorithm file (.fbd), SFC program (.sfc), PLCopen XML project (.xml) or runtime configuration (.yaml)")
      ->required();
  check->add_flag("--explain", args->explain,
                  "print execution order, delayed references, I/O bindings and sizes");
  check->add_flag("--werror", args->werror, "treat warnings as errors");
  check->add_flag("--paths", args->paths,
                  "configuration only: list the program files it names (\"program PATH\") and the\n"
                  "retain_file and socket it sets, one per line, without loading the runtime");
  check->add_option("--name", args->name,
                    "configuration only: preview the warm start of the runtime run under this name\n"
                    "(`rtplc run CONFIG --name NAME`): its retained values, state and saved programs")
      ->check(runtime_name());
  check->add_option("--entry", args->entry, "PLCopen XML: the task, program instance or program to check (default: the project's only one)");
  check->add_option("--semantics", args->semantics, "PLCopen XML and ST: whose behaviour where the editors differ (SFC order, TIME conversions): auto (the file header's editor: CODESYS for a CODESYS export, else MatIEC as Beremiz and OpenPLC), matiec or codesys (docs/plcopen.md)")
      ->check(CLI::IsMember({"auto", "matiec", "codesys"}));
  check->add_option("--period", args->period, "override stime: task period in seconds")
      ->check(positive_seconds());
  check->callback([args] { run_check(*args); });

  CLI::App* compile = app.add_subcommand(
      "compile", "Compile an FBD or SFC file to a verified task image file (.img).");
  compile->footer("A task image is accepted wherever a program is: `rtplc check F.img`, `rtplc sim F.img`,\n"
                  "a task's `program: F.img`, `rtplc swap TASK F.img`. It is verified on every load, runs at\n"
                  "the period it was compiled for (its parameters are prepared for it), and has no source\n"
                  "(so no --explain and no positions in errors). Examples:\n"
                  "  rtplc compile examples/seed_pid.fbd -o pid.img\n  rtplc sim pid.img --duration 10");
  compile->add_option("file", args->file, "control algorithm file (.fbd), SFC program (.sfc) or PLCopen XML project (.xml)")->required();
  compile->add_option("--entry", args->entry, "PLCopen XML: the task, program instance or program to compile (default: the project's only one)");
  compile->add_option("--semantics", args->semantics, "PLCopen XML and ST: whose behaviour where the editors differ (SFC order, TIME conversions): auto (the file header's editor: CODESYS for a CODESYS export, else MatIEC as Beremiz and OpenPLC), matiec or codesys (docs/plcopen.md)")
      ->check(CLI::IsMember({"auto", "matiec", "codesys"}));
  compile->add_option("-o,--output", args->output, "image file (default: FILE with .img)");
  compile->add_flag("--werror", args->werror, "treat warnings as errors");
  compile->add_option("--native-source", args->native_source,
                      "also write the C++ a task with `native: true` compiles this image into (docs/st.md, \"Native code\")");
  compile->add_option("--period", args->period, "override stime: task period in seconds")
      ->check(positive_seconds());
  compile->callback([args] { run_compile(*args); });

  CLI::App* blocks = app.add_subcommand("blocks", "List the primitive blocks and their contracts.");
  blocks->add_option("name", args->block, "show one block in detail");
  blocks->add_flag("--markdown", args->markdown, "print the full reference (docs/blocks.md)");
  blocks->add_flag("--json", args->json, "every block as JSON: pins, parameters and ranges, help (the editor's palette)");
  blocks->add_flag(
      "--iec", args->iec,
      "print how the IEC 61131-3 standard functions and blocks lower to these (docs/iec.md)");
  blocks->callback([args] { run_blocks(*args); });
}

}  // namespace rtplc::app
