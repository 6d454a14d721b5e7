// The runtime: what `rtplc run CONFIG` builds and runs (spec runtime.md). It
// compiles every task's program, plans the process image from the programs and
// the drivers' claims (image_plan.h), creates it, creates every driver through
// its kind (io/drivers/driver.h) without knowing which kinds there are,
// prepares the process for real time, and starts the driver and task threads on
// a common time grid (runtime.cpp). Afterwards its methods are the operator's
// verbs — set a set-point, swap or roll back a task's code, report — called
// from the control thread only (runtime_ops.cpp, see control.h).
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/diagnostic.h"
#include "common/files.h"
#include "common/quality.h"
#include "common/role.h"
#include "common/result.h"
#include "config/config.h"
#include "io/drivers/driver.h"
#include "io/process_image.h"
#include "kernel_rt/rt_process.h"
#include "kernel_rt/rt_thread.h"
#include "sched/image_plan.h"
#include "sched/operator_api.h"
#include "sched/program_store.h"
#include "sched/retain.h"
#include "sched/state_file.h"
#include "sched/stats_render.h"
#include "sched/task.h"

namespace rtplc::lang {
struct CompileResult;
enum class EditorSemantics : uint8_t;
}

namespace rtplc::sched {

struct RuntimeOptions {
  bool count_faults = false;       // measure minor page faults per cycle (test mode)
  bool back_to_back = false;       // benchmarks: tasks run cycles without sleeping
  bool lock_memory = true;         // overridden by the config's lock_memory: false
  std::string name_override;       // run under another name (tests run several at once)
  std::string socket_override;
  std::string retain_override;
  bool cold = false;  // `rtplc run --cold`: no block starts from its retained state
  // Whose state (NAME.state, the default NAME.retain, NAME.programs) to read:
  // empty, this runtime's own name.
  // `rtplc check` runs under a name of its own but reports the real one's.
  std::string state_name;
  // `rtplc check`: load and plan everything, then go; takes no lock and keeps
  // no copy of the programs (nothing is left behind in the runtime's folders).
  bool check_only = false;
};

// One diagnostic source: the runtime reports problems in the config file and in
// the programs it names, each rendered against its own text.
struct LoadReport {
  struct File {
    std::string name;
    std::string text;
    DiagnosticList diags;
  };
  std::vector<File> files;
  bool ok = true;
  std::string render(bool color = false) const;
};

// One channel an operator forced (rtplc force), as `status` lists it.
struct ForceRecord {
  std::string label;
  std::string dir;      // "input", "output"
  double value = 0;
  uint32_t uid = 0;     // who forced it (the control socket's peer)
  int64_t since_realtime_ns = 0;
};

class Runtime {
 public:
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  // Builds everything up to (not including) starting threads. On failure the
  // report says why; nothing is left behind (no shared memory, no threads).
  static std::unique_ptr<Runtime> load(const config::RuntimeConfig& cfg, const RuntimeOptions& opt,
                                       LoadReport& report);

  // Readies the process for RT, starts drivers then tasks. Returns notices to log
  // once (not PREEMPT_RT, running SCHED_OTHER, memory not locked, ...).
  Result<std::vector<std::string>> start();
  // Stops tasks (outputs to safe values) and drivers; idempotent.
  void stop();

  // ---- operator verbs (control thread) ----
  // Refuses a value that is not finite, not 0/1 for a digital set-point, or
  // outside the set-point's configured limits (task key `setpoints`), the
  // range named; every writer of set-points goes through here. Also called by
  // drivers' non-RT threads through DriverSetup::set_point (an HMI writing over
  // Modbus): it holds setpoint_mu_, as make_program() does. `durable`: a
  // retained value is on disk before the answer; otherwise (a Modbus write)
  // it is saved by the next tick() with every other change since, one fsync
  // for them all. `was`, when given, receives the value before.
  Result<std::string> set_value(const std::string& label, double value, bool durable = true,
                                double* was = nullptr);
  // Saves retained set-points that set_value(durable = false) changed; tick()
  // and stop() call it. False with `error` set when the file could not be written.
  bool flush_setpoints(std::string* error = nullptr);
  // Forces an input (what every task reads) or an output (what every driver
  // sends) to `value` until unforced; `uid` is who asked (for the record).
  // Not kept across a restart. Refuses set-points (use set_value), inputs no
  // driver provides, non-finite values and non-0/1 values for digital channels.
  Result<std::string> force(const std::string& label, double value, uint32_t uid);
  Result<std::string> unforce(const std::string& label);
  Result<std::string> unforce_all();
  // The forced channels, by label.
  std::vector<ForceRecord> forces() const;
  // Compiles `source` for task `task` and swaps it in at the task's next cycle
  // boundary; waits for the hand-over. A compile or verification error changes
  // nothing. A program that no longer writes an output the running one writes
  // is refused, the label named, unless that label is in `drop_outputs`: then
  // the channel goes to its safe value with bad quality and drivers stop
  // sending it.
  Result<std::string> swap(const std::string& task, const std::string& source,
                           const std::string& file_label,
                           const std::vector<std::string>& drop_outputs = {});
  // What swap() with the same arguments would do — the compiler's errors, or
  // the migration report (state kept and reset, active steps, new channels,
  // outputs dropped) — and changes nothing.
  Result<std::string> swap_check(const std::string& task, const std::string& source,
                                 const std::string& file_label,
                                 const std::vector<std::string>& drop_outputs = {});
  Result<std::string> rollback(const std::string& task, const std::vector<std::string>& drop_outputs = {});
  // A task's program as the store keeps it: what runs now (file, origin,
  // hash), its versions newest last, and the source of one of them (`hash`,
  // or the running one when empty). For the console's program browser and
  // chart view.
  struct ProgramInfo {
    std::string file, origin, hash, source;
    std::vector<ProgramVersion> history;
  };
  Result<ProgramInfo> program_info(const std::string& task, const std::string& hash = "");
  // The watch (the editor's live wires): renews the task's lease for
  // kWatchLeaseNs and answers the last watch snapshot, every block's output
  // and status by name; `pending` until the task has taken one.
  static constexpr int64_t kWatchLeaseNs = 3'000'000'000;
  struct WatchedValue {
    std::string name;
    std::string kind;
    double value = 0;
    Quality quality = Quality::kGood;
    std::optional<std::string> text;  // a STRING's value (value is then its length)
  };
  struct WatchInfo {
    bool pending = true;
    uint64_t cycle = 0;
    double age_s = 0;
    std::string program;  // the hash of the program the values are from
    std::vector<WatchedValue> blocks;
  };
  Result<WatchInfo> watch(const std::string& task);
  std::string status() const;
  // The same facts as one JSON object (`rtplc status --json`).
  std::string status_json() const;
  // Tracing (`rtplc trace`, trace_ops.cpp): selects up to io::kTraceChannels
  // channels of one task for its trace ring and answers what the tool needs
  // to drain it (see control.h, the trace verbs). The selection is held by a
  // lease the tool renews with trace_keep; tick() ends one not renewed for
  // kTraceLeaseNs, so a tool that died does not leave its task tracing.
  Result<std::string> trace_start(const std::vector<std::string>& labels);
  Result<std::string> trace_keep(const std::string& token);
  Result<std::string> trace_end(const std::string& token);
  // Frees programs the tasks have let go of (call periodically off the RT path).
  void reap();
  // The control thread's housekeeping, a few times a second: the heartbeat in
  // the image, and the drivers' queued events to `log(error, line)`.
  void tick(const std::function<void(bool, const std::string&)>& log);
  // The ticks a native compile makes (make_program): where they log, and
  // whether the runtime is stopping (the compile is then stopped). The control
  // server's, set before its thread starts and cleared after it ended.
  void set_tick_log(std::function<void(bool, const std::string&)> log, std::function<bool()> stopping) {
    tick_log_ = std::move(log);
    stopping_ = std::move(stopping);
  }

  const std::string& name() const { return name_; }
  const std::string& socket_path() const { return socket_path_; }
  // `runtime.operators`, resolved to uids and gids when the runtime loaded.
  struct Grant {
    bool group = false;
    uint32_t id = 0;
    Role role = Role::kViewer;
  };
  const std::vector<Grant>& grants() const { return grants_; }
  // The operator API every caller goes through (operator_api.h).
  OperatorApi& api() { return *api_; }
  const std::string& retain_path() const { return retain_.path(); }
  // The retained block state (state_file.h): NAME.state beside the retain file.
  const std::string& state_path() const { return state_path_; }
  // Writes the state file now from the tasks' latest snapshots (tick() does it
  // every runtime.retain_every, stop() once the tasks have stopped). False with
  // `error` set when the file could not be written.
  bool persist_state(std::string* error = nullptr);
  // Why stop() could not write the state file ("" when it could).
  const std::string& stop_state_error() const { return stop_state_error_; }
  const ProgramStore& programs() const { return programs_; }
  io::ProcessImage& image() { return image_; }
  size_t task_count() const { return tasks_.size(); }
  Task& task(size_t i) { return *tasks_[i]; }
  // "no task named X; the tasks are a, b" for an operator's typo.
  std::string no_task_text(const std::string& name) const;
  Task* find_task(const std::string& name);
  // The task's program compiled against its running grid and output layout.
  lang::CompileResult compile_for(const Task& t, const std::string& source) const;
  // SFC tasks: their step flags are channels <chart>.<step> (docs/sfc.md).
  static bool is_chart(const Task& t);
  std::vector<std::string> active_step_names(const Task& t) const;
  std::string steps_json(const Task& t) const;
  // Summary lines printed when the runtime starts (with what the warm start restored).
  std::vector<std::string> describe() const;
  // Per-task views for `stats` rendering.
  std::vector<TaskStatsView> stats_views() const;

 private:
  Runtime() = default;
  struct ChannelRef {
    uint32_t index;      // in the image's channel table
    std::string label;
    std::string key;
  };
  bool build(const config::RuntimeConfig& cfg, LoadReport& report);
  bool create_drivers(const config::RuntimeConfig& cfg, DiagnosticList& cdiag);
  Result<std::unique_ptr<LoadedProgram>> make_program(uint32_t task, TaskImage image,
                                                      std::string source, std::string file,
                                                      const LoadedProgram* running,
                                                      const std::vector<std::string>& drop_outputs = {},
                                                      bool compile_native_code = true);
  // What a set-point a swap adds starts at: its retained value if that fits its
  // kind and `setpoints` limits, else its init value; an init value that does
  // not fit refuses the program. Caller holds setpoint_mu_.
  Result<double> new_setpoint_value(const std::string& label, Kind kind, double init) const;
  // The channels make_program() planned enter the image, the label table and
  // the set-point region (caller holds setpoint_mu_): only once nothing can
  // refuse the program any more.
  void commit_new_channels(uint32_t task, LoadedProgram& p);
  void publish_setpoints();
  void restore_state(const config::RuntimeConfig& cfg, DiagnosticList& cdiag);
  struct TraceLease {
    std::string token;   // "" = no trace on this task
    int64_t expires_ns = 0;
    std::string labels;  // for the log
    bool clearing = false;  // ended; the empty selection is not yet taken by the task
  };
  void expire_traces(const std::function<void(bool, const std::string&)>& log);
  // Logs what the tasks reported of their blocks' errors and keeps the last for `status`.
  void report_block_errors(const std::function<void(bool, const std::string&)>& log);
  bool clear_trace(uint32_t task);
  Result<std::string> install(Task& t, std::unique_ptr<LoadedProgram> next, bool keep_previous);

  // The heartbeat in the image, from a thread of its own (SCHED_OTHER): a
  // control thread that waits for a slow task's swap boundary, or writes a
  // file, never makes the tools think the runtime is gone.
  void start_heartbeat();
  void stop_heartbeat();
  std::atomic<bool> beat_stop_{false};
  kernel_rt::RtThread beat_thread_;

  FileLock lock_;  // held while this runtime lives: no second one of its name
  int monitor_gid_ = -1;
  config::RuntimeConfig config_;
  std::string name_;
  std::string socket_path_;
  io::ProcessImage image_;
  kernel_rt::RtProcess rt_;
  RetainStore retain_;
  ProgramStore programs_;             // the boot programs (program_store.h)
  std::vector<std::string> origins_;  // per task: where its running program came from
  std::vector<std::string> last_block_error_;  // per task: the last block error reported, for `status`
  std::vector<std::string> notices_;  // said once at start
  RuntimeOptions options_;
  bool lock_memory_ = true;
  bool cpu_dma_latency_ = true;
  std::vector<std::unique_ptr<Task>> tasks_;
  io::LinkEventQueue events_;
  std::vector<std::unique_ptr<io::Driver>> drivers_;
  std::vector<std::unique_ptr<LoadedProgram>> previous_;   // per task, for rollback
  std::vector<std::unique_ptr<LoadedProgram>> graveyard_;  // retired, freed by reap()
  std::vector<std::vector<std::string>> task_output_keys_; // per task: region index -> channel key
  std::vector<std::string> task_entries_;  // per task: the PLCopen program_instance (swap recompiles it)
  std::vector<lang::EditorSemantics> task_semantics_;  // per task: its `semantics` (swap recompiles with it)
  std::vector<config::SafeOutput> no_safe_;
  std::vector<std::vector<config::SafeOutput>> safe_outputs_;
  std::map<std::string, uint32_t> channel_by_key_;  // key -> channel index in the image
  uint32_t setpoint_region_ = 0;
  uint32_t unwired_region_ = 0;
  uint64_t events_dropped_said_ = 0;
  // The set-point region's one writer is whoever holds setpoint_mu_: the
  // control thread (`rtplc set`, a swap adding a set-point) or a driver's
  // thread setting one for its peer. It guards setpoint_values_, retain_'s
  // values and the region's snapshots (publish_setpoints()).
  std::mutex setpoint_mu_;
  std::vector<double> setpoint_values_;  // the set-point region's values
  std::map<std::string, config::SetpointLimits> setpoint_limits_;  // by label
  std::map<std::string, config::SetpointLimits> channel_ranges_;  // `ranges:` of every task, by label
  std::map<std::string, ForceRecord> forces_;  // by label (control thread); the image's force table says what applies
  ImagePlan plan_;
  std::vector<TraceLease> traces_;  // per task
  uint64_t trace_counter_ = 0;
  bool started_ = false;
  // Retained block state (control thread only).
  std::string state_path_;
  std::vector<Grant> grants_;
  std::unique_ptr<OperatorApi> api_;
  std::string flush_error_said_;
  bool setpoints_unsaved_ = false;  // under setpoint_mu_: set_value(durable = false) awaits flush_setpoints()
  std::string state_name_;  // the runtime the state file belongs to
  int64_t retain_every_ns_ = 1000000000;
  int64_t last_persist_ns_ = 0;
  // Per task, what the file holds for it now: what it had at the start
  // (saved_tasks_, until the task's first snapshot), then the layout and the
  // last snapshot persisted (one flat vector, not a copy per block).
  std::vector<SavedTask> saved_tasks_;
  std::vector<std::shared_ptr<const std::vector<RetainedBlock>>> persisted_layout_;
  std::vector<std::vector<double>> persisted_data_;
  std::vector<uint64_t> persisted_cycle_;
  std::vector<uint64_t> persisted_taken_;        // per task: snapshot count last written
  std::vector<const LoadedProgram*> persisted_program_;
  std::vector<std::string> restore_lines_;       // said at start
  std::string persist_error_said_;
  std::function<void(bool, const std::string&)> tick_log_;
  std::function<bool()> stopping_;
  std::string stop_state_error_;
};

// A CLOCK_REALTIME instant as "2026-12-01T19:50:01Z" (force records, logs).
std::string format_utc(int64_t realtime_ns);
// A trace selection lives this long after the tool's last renewal.
inline constexpr int64_t kTraceLeaseNs = 5000000000;

// Default control socket and retain file for a runtime name: system paths when
// running as root, per-user paths otherwise.
std::string default_socket_path(const std::string& name);
std::string default_retain_path(const std::string& name);

}  // namespace rtplc::sched
