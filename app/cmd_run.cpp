// `rtplc run` and the operator's verbs that talk to a running runtime:
// `rtplc set`, `rtplc swap`, `rtplc status`, `rtplc stop`, `rtplc force`,
// `rtplc unforce`.
#include <CLI/CLI.hpp>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <ctime>
#include <memory>
#include <thread>
#include <vector>

#include "app/arguments.h"
#include "app/log_output.h"
#include "common/files.h"
#include "app/commands.h"
#include "config/config.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/rt_kernel.h"
#include "lang/compiler.h"
#include "sched/control.h"
#include "sched/runtime.h"
#include "sched/stats_source.h"

namespace rtplc::app {
namespace {

struct RunArgs {
  std::string config;
  std::string name;
  double duration = 0;
  bool count_faults = false;
  bool no_lock = false;
  bool quiet = false;
  bool cold = false;
};

struct ClientArgs {
  std::string name = "rtplc";
  std::string socket;
  std::string label;
  std::string value;
  std::string task;
  std::string file;
  bool rollback = false;
  bool check = false;  // swap --check
  bool all = false;
  bool json = false;
  std::vector<std::string> drop_outputs;
};

// " drop=A,B" for the control request, "" when no output is to be dropped.
std::string drop_word(const ClientArgs& a) {
  if (a.drop_outputs.empty()) return "";
  std::string w = " drop=";
  for (size_t i = 0; i < a.drop_outputs.size(); ++i) w += (i ? "," : "") + a.drop_outputs[i];
  return w;
}

std::string socket_for(const ClientArgs& a) { return sched::control_socket_of(a.name, a.socket); }


// A client command that could not reach its runtime also says which ones run.
[[noreturn]] void fail_client(const std::string& what, const std::string& error) {
  const bool unreachable = error.rfind("cannot reach the runtime at ", 0) == 0;
  fail(what + ": " + error + (unreachable ? sched::running_runtimes_hint() : std::string()));
}

void run_runtime(const RunArgs& a) {
  // Before anything can write to a pipe: the runtime never dies of its log.
  signal(SIGPIPE, SIG_IGN);
  if (const InputKind k = input_kind(a.config); k != InputKind::kConfig) {
    fail("rtplc run: " + a.config + ": " +
             (k == InputKind::kMissing  ? std::string("no such file")
              : k == InputKind::kFolder ? std::string("is a folder")
              : k == InputKind::kSpecial ? std::string("is not a regular file (a FIFO, device or socket)")
                                        : std::string("is not a runtime configuration (.yaml)")) +
             "; `rtplc run` takes a runtime configuration, e.g. examples/seed_pid.yaml",
         kExitUsage);
  }
  config::LoadResult cfg = config::load_config(a.config);
  if (!cfg.diags.items().empty()) std::fputs(cfg.render(isatty(STDERR_FILENO)).c_str(), stderr);
  if (!cfg.ok()) fail(a.config + ": the configuration has errors; nothing started");

  sched::RuntimeOptions opt;
  opt.count_faults = a.count_faults;
  opt.lock_memory = !a.no_lock;
  opt.name_override = a.name;
  opt.cold = a.cold;
  sched::LoadReport report;
  std::unique_ptr<sched::Runtime> rt = sched::Runtime::load(*cfg.config, opt, report);
  const std::string rendered = report.render(isatty(STDERR_FILENO));
  if (!rendered.empty()) std::fputs(rendered.c_str(), stderr);
  if (!rt) fail("rtplc run: nothing started");
  // The log goes to stdout while stdout works, then to a file in the
  // runtime's private folder (the socket's): docs/operations.md, "Logs".
  const auto log = install_runtime_log(folder_of(rt->socket_path()) + "/" + rt->name() + ".log");

  // Signals are taken by sigwait below, not by handlers: block them before any
  // thread starts so every thread inherits the mask.
  sigset_t sigs;
  sigemptyset(&sigs);
  sigaddset(&sigs, SIGINT);
  sigaddset(&sigs, SIGTERM);
  sigaddset(&sigs, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &sigs, nullptr);

  if (!a.quiet) {
    spdlog::info("runtime {}: {} tasks, shared memory {}, control socket {}", rt->name(),
                 rt->task_count(), rt->image().object_name(), rt->socket_path());
    for (const std::string& l : rt->describe()) spdlog::info("  {}", l);
    spdlog::info("  log: here, and in {} if this output goes away", log->fallback_path());
  }
  auto started = rt->start();
  if (!started) fail("rtplc run: " + started.error());
  for (const std::string& n : *started) spdlog::warn("{}", n);

  sched::ControlServer control(*rt, [&a](bool error, const std::string& line) {
    // Forces are logged whatever -q says: who forced what, when.
    if (error && (line.rfind("FORCE", 0) == 0 || line.rfind("UNFORCE", 0) == 0)) spdlog::warn("{}", line);
    else if (error) spdlog::error("{}", line);
    else if (!a.quiet) spdlog::info("{}", line);
  });
  if (auto r = control.start(rt->socket_path()); !r) {
    rt->stop();
    fail("rtplc run: " + r.error());
  }
  if (!a.quiet) spdlog::info("running; `rtplc stats`, `rtplc monitor`, `rtplc set`, `rtplc swap` work now; Ctrl-C stops");

  const int64_t t0 = kernel_rt::monotonic_now_ns();
  for (;;) {
    timespec wait{0, 100000000};
    const int sig = sigtimedwait(&sigs, nullptr, &wait);
    if (sig > 0) {
      if (!a.quiet) spdlog::info("signal {}: stopping", sig);
      break;
    }
    if (control.stop_requested()) break;
    if (a.duration > 0 && static_cast<double>(kernel_rt::monotonic_now_ns() - t0) / 1e9 >= a.duration) break;
  }
  control.stop();
  rt->stop();
  if (!rt->stop_state_error().empty()) spdlog::error("{}", rt->stop_state_error());
  // What the drivers said while stopping (the last writes, links closing).
  rt->tick([&a](bool error, const std::string& line) {
    if (error) spdlog::error("{}", line);
    else if (!a.quiet) spdlog::info("{}", line);
  });
  if (!a.quiet) {
    auto views = rt->stats_views();
    auto summary = sched::summary_of(rt->image(), views);
    std::fputs((sched::render_table(views, summary) + sched::render_links_table(rt->image())).c_str(), stdout);
  }
}

// The value of `set` and `force`, checked before the runtime is asked: an
// empty or misspelt number is the operator's typo, said as such.
void require_number(const char* verb, const ClientArgs& a) {
  char* end = nullptr;
  const char* v = a.value.c_str();
  (void)std::strtod(v, &end);
  if (a.value.empty() || end == v || *end != '\0') {
    fail("rtplc " + std::string(verb) + ": '" + a.value + "' is not a number; give the value, e.g. rtplc " + verb +
             " " + a.label + " 42",
         kExitUsage);
  }
}

void run_set(const ClientArgs& a) {
  require_number("set", a);
  auto r = sched::control_request(socket_for(a), "set " + a.label + " " + a.value);
  if (!r) fail_client("rtplc set", r.error());
  std::fputs(r->c_str(), stdout);
}

void run_force(const ClientArgs& a) {
  require_number("force", a);
  auto r = sched::control_request(socket_for(a), "force " + a.label + " " + a.value);
  if (!r) fail_client("rtplc force", r.error());
  std::fputs(r->c_str(), stdout);
}

void run_unforce(const ClientArgs& a) {
  if (a.all == !a.label.empty()) {
    fail(a.all ? "rtplc unforce: give a LABEL or --all, not both" : "rtplc unforce: give the LABEL to release, or --all",
         kExitUsage);
  }
  auto r = sched::control_request(socket_for(a), a.all ? std::string("unforce_all") : "unforce " + a.label);
  if (!r) fail_client("rtplc unforce", r.error());
  std::fputs(r->c_str(), stdout);
}

void run_swap(const ClientArgs& a) {
  if (a.rollback) {
    if (a.task.empty()) fail("rtplc swap --rollback TASK", kExitUsage);
    if (a.check) fail("rtplc swap --rollback --check: a rollback cannot be checked; `rtplc status` names the program each task runs", kExitUsage);
    if (!a.file.empty()) {
      fail("rtplc swap --rollback " + a.task + " " + a.file +
               ": --rollback goes back to the task's previous code and takes no FILE; "
               "to load FILE, leave out --rollback",
           kExitUsage);
    }
    auto r = sched::control_request(socket_for(a), "rollback " + a.task + drop_word(a), "", sched::kSwapAnswerMs);
    if (!r) fail_client("rtplc swap --rollback", r.error());
    std::fputs(r->c_str(), stdout);
    return;
  }
  if (a.task.empty() || a.file.empty()) fail("rtplc swap TASK FILE (or --rollback TASK)", kExitUsage);
  require_program(a.file, "swap");
  std::string err;
  auto text = lang::read_text_file(a.file, &err);
  if (!text) fail("rtplc swap: " + err, kExitUsage);
  // Checked here first, so a typo is reported with colours and without bothering the runtime.
  lang::CompileResult local = lang::compile_source(*text);
  if (!local.ok()) {
    std::fputs(local.diags.render(a.file, *text, isatty(STDERR_FILENO)).c_str(), stderr);
    fail("rtplc swap: " + a.file + " has errors; the running task is unchanged");
  }
  std::string label = a.file;
  for (char& c : label) {
    if (c == ' ' || c == '\n') c = '_';
  }
  auto r = sched::control_request(socket_for(a),
                                  std::string(a.check ? "swap-check " : "swap ") + a.task + " " + label + " " + std::to_string(text->size()) + drop_word(a),
                                  *text, sched::kSwapAnswerMs);
  if (!r) fail_client("rtplc swap", r.error());
  std::fputs(r->c_str(), stdout);
  // The runtime's answer says when the file's stime differs from the task's
  // period (the task keeps its grid).
}

// `rtplc stop` returns once the runtime has let go (its outputs driven safe,
// its lock released), so an immediate `rtplc run` of the same name starts.
// The lock beside the socket is held until the runtime's process ends.
void wait_until_stopped(const std::string& socket, const std::string& answer) {
  const std::string prefix = "stopping runtime ";
  if (answer.rfind(prefix, 0) != 0) return;
  std::string name = answer.substr(prefix.size());
  while (!name.empty() && (name.back() == '\n' || name.back() == '.')) name.pop_back();
  const std::string lock = folder_of(socket) + "/" + name + ".lock";
  constexpr int kPollMs = 50, kPatienceMs = 60000;
  // Without rights to the lock (another user's runtime, reached through
  // monitor_group), the socket going silent is the best sign there is.
  const bool can_lock = access(lock.c_str(), R_OK | W_OK) == 0;
  for (int waited = 0; waited < kPatienceMs; waited += kPollMs) {
    const bool gone = can_lock ? FileLock::acquire(lock).ok() : !sched::control_request(socket, "ping").ok();
    if (gone) {
      std::printf("runtime %s stopped\n", name.c_str());
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(kPollMs));
  }
  fail("rtplc stop: runtime " + name + " is still stopping after " + std::to_string(kPatienceMs / 1000) +
       " s (its lock " + lock + " is held)");
}

void run_simple(const ClientArgs& a, const char* request) {
  auto r = sched::control_request(socket_for(a), request);
  const std::string verb(request, std::strcspn(request, " "));  // "status json": the command is status
  if (!r) {
    // No answer: if the runtime left its image behind (kill -9, a crash), say
    // that it died and when, rather than only that the socket is silent.
    if (auto img = io::ProcessImage::attach(a.name); img.ok()) {
      const io::Liveness live = img->liveness();
      if (!live.alive) {
        fail(std::string("rtplc ") + verb + ": " + sched::not_running_text(a.name, live) +
             "; every channel in its image is stale");
      }
    }
    fail_client(std::string("rtplc ") + verb, r.error());
  }
  std::fputs(r->c_str(), stdout);
  if (verb == "stop") wait_until_stopped(socket_for(a), *r);
}

void run_list() {
  const std::vector<sched::RuntimeSeen> seen = sched::runtimes_on_this_machine();
  if (seen.empty()) {
    std::printf("no runtime on this machine (`rtplc run CONFIG` starts one)\n");
    return;
  }
  size_t w = 4;
  for (const auto& r : seen) w = std::max(w, r.name.size());
  std::printf("%-*s  %-7s  %s\n", static_cast<int>(w), "NAME", "STATE", "SOCKET");
  for (const auto& r : seen) {
    std::printf("%-*s  %-7s  %s\n", static_cast<int>(w), r.name.c_str(), r.alive ? "running" : "dead",
                r.alive ? r.socket.c_str() : r.why.c_str());
  }
}

void add_client_options(CLI::App* c, ClientArgs& a) {
  c->add_option("--name", a.name, "runtime name (runtime.name in the config; default rtplc)")
      ->check(runtime_name());
  c->add_option("--socket", a.socket, "control socket path (default from the name)");
}

}  // namespace

void add_run_commands(CLI::App& app) {
  auto run = std::make_shared<RunArgs>();
  CLI::App* r = app.add_subcommand("run", "Run the tasks of a runtime configuration (YAML) in real time.");
  r->footer(
      "Compiles every task's program, builds the shared process image, readies the box for real\n"
      "time (locked memory, /dev/cpu_dma_latency), and runs one SCHED_FIFO thread per task on a\n"
      "common time grid. Without the privileges for SCHED_FIFO or on a non-RT kernel it runs\n"
      "anyway and says so once. Stops on Ctrl-C, SIGTERM, `rtplc stop` or --duration, setting\n"
      "every output to its safe value, and prints the timing table.\n"
      "Warm start by default: blocks continue from the state they had when the runtime last\n"
      "stopped or died (integrators, counters, timers, filters, delays, SFC steps; a task's\n"
      "`retain` key selects which), read from NAME.state beside the retain file, written every\n"
      "runtime.retain_every and at the stop. The start says which blocks it restored and from\n"
      "when; a damaged file is reported and ignored. --cold starts every block from zero.\n"
      "Examples:\n"
      "  rtplc run examples/seed_pid.yaml\n"
      "  rtplc run examples/seed_pid.yaml --cold\n"
      "  rtplc run examples/sixteen.yaml --duration 20");
  r->add_option("config", run->config, "runtime configuration (.yaml)")->required();
  r->add_option("--name", run->name, "run under this name instead of runtime.name")
      ->check(runtime_name());
  r->add_option("--duration", run->duration, "stop after this many seconds")
      ->check(positive_seconds());
  r->add_flag("--count-faults", run->count_faults, "count minor page faults per cycle (test mode)");
  r->add_flag("--no-lock", run->no_lock, "do not lock memory (mlockall)");
  r->add_flag("-q,--quiet", run->quiet, "log only errors");
  r->add_flag("--cold", run->cold,
              "cold start: every block from its initial state, not from the\n"
              "retained block state (set-points keep their retained values)");
  r->callback([run] { run_runtime(*run); });

  auto cl = std::make_shared<ClientArgs>();
  CLI::App* set = app.add_subcommand("set", "Change a set-point (asp/dsp) of the running runtime; retained.");
  set->footer("The value is on disk (retained across restarts and crashes) before the command returns.\n"
              "A value outside the set-point's limits (the task's `setpoints: {LABEL: {min, max}}` in\n"
              "the config), or not a finite number, is refused and the range named.\n"
              "Example:\n  rtplc set SV_Msp 42.5");
  set->add_option("label", cl->label, "the set-point's label")->required();
  set->add_option("value", cl->value, "new value (0 or 1 for a digital set-point)")->required();
  add_client_options(set, *cl);
  set->callback([cl] { run_set(*cl); });

  CLI::App* force = app.add_subcommand("force", "Force an input or an output of the running runtime to a value.");
  force->footer(
      "Forcing an input: every task reads VALUE instead of what its driver reads from the plant.\n"
      "Forcing an output: the task still computes it, but every driver sends VALUE and the\n"
      "monitor shows it. Forced channels are marked FORCED in `monitor`, `stats` and `status`;\n"
      "every force is logged with your uid and the time. Forces stay until `rtplc unforce` and\n"
      "are NOT kept across a restart (a PLC must not boot forced). A stopped task's safe values\n"
      "win over forces. Set-points are changed with `rtplc set`, not forced. A digital channel\n"
      "takes 0 or 1.\n"
      "Examples:\n  rtplc force ProcVal 42.5\n  rtplc force Valve1 0\n  rtplc unforce --all");
  force->add_option("label", cl->label, "the channel's label (see `rtplc monitor`)")->required();
  force->add_option("value", cl->value, "the forced value (0 or 1 for a digital channel)")->required();
  add_client_options(force, *cl);
  force->callback([cl] { run_force(*cl); });

  CLI::App* unforce = app.add_subcommand("unforce", "Release a forced channel (or --all of them).");
  unforce->footer("The channel's own value (its driver's for an input, its task's for an output) applies\n"
                  "again from the next cycle. `rtplc status` lists what is forced.\n"
                  "Examples:\n  rtplc unforce ProcVal\n  rtplc unforce --all");
  unforce->add_option("label", cl->label, "the forced channel's label");
  unforce->add_flag("--all", cl->all, "release every forced channel");
  add_client_options(unforce, *cl);
  unforce->callback([cl] { run_unforce(*cl); });

  CLI::App* swap = app.add_subcommand("swap", "Replace one task's code while the plant keeps running.");
  swap->footer(
      "The runtime compiles and verifies the file off the real-time path (an error changes nothing),\n"
      "keeps the state of every block whose id and type match (integrators, filters, timers,\n"
      "counters: a PID stays bumpless), and hands the new code to the task at its next cycle\n"
      "boundary. The previous code is kept: --rollback TASK swaps it back.\n"
      "Examples:\n  rtplc swap loop3 new.fbd --check\n  rtplc swap loop3 new.fbd\n  rtplc swap --rollback loop3");
  swap->add_option("task", cl->task, "task name");
  swap->add_option("file", cl->file, "new program (.fbd, .sfc or PLCopen .xml; an .xml task runs its program_instance)");
  swap->add_flag("--rollback", cl->rollback, "go back to the task's previous code");
  swap->add_flag("--check", cl->check,
                 "only say what the swap would do (the compiler's errors, or which blocks keep\n"
                 "their state, which reset, the active steps kept, new channels); changes nothing");
  swap->add_option("--drop-output", cl->drop_outputs,
                   "let the new code leave out this output (its label; repeatable): it goes to its\n"
                   "safe value with bad quality and drivers stop sending it. Without it, a swap\n"
                   "that leaves out an output is refused");
  add_client_options(swap, *cl);
  swap->callback([cl] { run_swap(*cl); });

  CLI::App* status = app.add_subcommand("status", "Show what the running runtime is doing.");
  add_client_options(status, *cl);
  status->add_flag("--json", cl->json, "the same as one JSON object (tasks, forces, links)");
  status->callback([cl] { run_simple(*cl, cl->json ? "status json" : "status"); });

  CLI::App* audit = app.add_subcommand("audit", "The last operator actions: who set, forced, swapped, stopped what, and when.");
  audit->footer("Every write through the operator API (CLI, Modbus, ...), accepted or refused, is one\n"
                "line: UTC time, the caller (uid and name, or the driver), its role, the request, and\n"
                "what came of it (old -> new for set and force).\n"
                "The trail is NAME.audit in the runtime's state folder, bounded to 512 KiB.\n"
                "Examples:\n  rtplc audit\n  rtplc audit --lines 500 --name plant");
  auto audit_lines = std::make_shared<int>(50);
  audit->add_option("--lines", *audit_lines, "how many of the last actions (default 50)")
      ->check(CLI::Range(1, 100000));
  add_client_options(audit, *cl);
  audit->callback([cl, audit_lines] {
    const std::string req = "audit " + std::to_string(*audit_lines);
    run_simple(*cl, req.c_str());
  });

  CLI::App* whoami = app.add_subcommand("whoami", "Who the runtime takes you for, and your role on it.");
  whoami->footer("The runtime's owner and root are admin; others get what the config's\n"
                 "runtime.operators grants (viewer, operator, engineer, admin; docs/api.md).\n"
                 "Examples:\n  rtplc whoami --name plant\n  rtplc whoami --socket /run/rtplc/plant.sock");
  add_client_options(whoami, *cl);
  whoami->callback([cl] { run_simple(*cl, "whoami"); });

  CLI::App* stop = app.add_subcommand("stop", "Stop the running runtime (outputs to their safe values).");
  add_client_options(stop, *cl);
  stop->callback([cl] { run_simple(*cl, "stop"); });

  CLI::App* list = app.add_subcommand("list", "List the runtimes on this machine: name, state, control socket.");
  list->footer("A runtime that died (kill -9, a crash) is listed until its name runs again.\n"
               "Every client command takes --name NAME to choose one; the default name is rtplc.");
  list->callback([] { run_list(); });
}

}  // namespace rtplc::app
