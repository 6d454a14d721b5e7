// The runtime configuration (spec runtime.md, "Configuration"): what
// `rtplc run CONFIG` reads — the tasks (program, period, priority, cpu, overrun
// policy, watchdog, safe outputs) and the I/O drivers (kind, period, priority,
// cpu, and per kind their channel maps). The loader checks everything it can
// without compiling the programs; the runtime does the rest, and every field it
// may still have to complain about carries its source position so its messages
// point into the config file like the loader's own (see common/diagnostic.h).
// The keys, defaults and ranges are in config/schema.h; docs/config.md is
// generated from there.
#pragma once

#include <any>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/diagnostic.h"
#include "common/role.h"
#include "config/values.h"

namespace rtplc::config {

// Defaults shared by the structs below and the schema (config/schema.cpp) so the
// documented default and the applied one are one constant.
inline constexpr const char* kDefaultRuntimeName = "rtplc";
inline constexpr int kDefaultBandLo = 10;
inline constexpr int kDefaultBandHi = 49;
inline constexpr int kMinFifoPriority = 1;
inline constexpr int kMaxFifoPriority = 98;  // 99 is left to the kernel's watchdogs
inline constexpr double kDefaultDriverPeriod = 0.01;
inline constexpr double kMinPeriod = 10e-6;
inline constexpr double kMaxPeriod = 3600;
inline constexpr uint32_t kDefaultStopWatchdog = 3;
inline constexpr uint32_t kMaxWatchdog = 1000000;
inline constexpr uint64_t kMaxLoopBudget = 1'000'000'000;
inline constexpr uint64_t kDefaultLoopBudget = 100'000;  // blocks/executor.h's, checked in sched/runtime.cpp
inline constexpr unsigned kMaxCpu = 1023;  // CPU_SETSIZE - 1
inline constexpr double kDefaultRetainEvery = 1.0;  // seconds between state-file writes
inline constexpr double kMinRetainEvery = 0.01;
inline constexpr double kMaxRetainEvery = 3600;

// What a late cycle does (one definition for the config and the scheduler).
enum class OverrunPolicy : uint8_t {
  kSkip,  // missed releases are skipped and counted; the task goes on
  kStop,  // the watchdog stops the task after N consecutive overruns
};
const char* to_string(OverrunPolicy p);

// One value a stopped task's output takes (by the output's label).
// What the drivers that send an output do while its status is not good
// (docs/runtime.md, "Status of values"): keep what the peer has (hold, the
// default), send the task's safe value for it, or send the computed value anyway.
enum class OnBad : uint8_t { kHold = 0, kSafe = 1, kSend = 2 };
const char* on_bad_name(OnBad p);

struct OnBadPolicy {
  std::string label;
  OnBad policy = OnBad::kHold;
  SourcePos pos;  // of the label
};

struct SafeOutput {
  std::string label;
  double value = 0;
  SourcePos pos;  // of the label, for "no output of task X has this label"
};

// The range `rtplc set` allows for one set-point (by its label); a bound left
// out is no bound.
struct SetpointLimits {
  std::string label;
  std::optional<double> min;
  std::optional<double> max;
  SourcePos pos;  // of the label
};

struct TaskConfig {
  std::string name;     // given, or the program file's stem
  SourcePos pos;        // the task's entry in the list
  SourcePos name_pos;   // the name's value, or program_pos when the name is the stem
  std::string program;  // resolved against the config file's folder
  SourcePos program_pos;
  std::string program_instance;  // PLCopen XML: what of the project runs (empty: its only one)
  std::string semantics = "auto";  // PLCopen XML, ST: auto | matiec | codesys (lang::EditorSemantics)
  std::optional<double> period_s;  // overrides the program's stime() when set
  SourcePos period_pos;
  std::optional<int> priority;  // SCHED_FIFO, inside the band; unset: rate-monotonic
  SourcePos priority_pos;
  std::optional<unsigned> cpu;
  SourcePos cpu_pos;
  OverrunPolicy overrun = OverrunPolicy::kSkip;
  SourcePos overrun_pos;
  uint32_t watchdog = 0;  // consecutive overruns before the stop; 0 = never
  SourcePos watchdog_pos;
  // Backward branches (loop iterations) one cycle may take; past it the task
  // stops into its safe outputs (docs/st.md, "Loops").
  uint64_t loop_budget = kDefaultLoopBudget;
  SourcePos loop_budget_pos;
  // Run the program as native code (blocks/native.h, docs/st.md "Native code").
  bool native = false;
  std::vector<SafeOutput> safe_outputs;
  std::vector<OnBadPolicy> on_bad;  // outputs not listed: hold
  // Retained block state (docs/runtime.md, "Retained block state"): every
  // block (the default), none, or the blocks named in retain_blocks.
  bool retain_all = true;
  std::vector<std::string> retain_blocks;
  SourcePos retain_pos;
  std::vector<SetpointLimits> setpoint_limits;  // `setpoints:`
  std::vector<SetpointLimits> channel_ranges;   // `ranges:` engineering ranges of inputs and outputs
};

struct DriverConfig {
  std::string kind;  // "sim"; see config/driver_kinds.h for the known ones
  std::string name;  // given, or the kind
  SourcePos pos;     // the driver's entry
  SourcePos kind_pos;
  SourcePos name_pos;
  double period_s = kDefaultDriverPeriod;
  SourcePos period_pos;
  std::optional<int> priority;  // unset: the runtime puts drivers above the task band
  SourcePos priority_pos;
  std::optional<unsigned> cpu;
  SourcePos cpu_pos;
  std::optional<double> max_age_s;  // unset: the kind's claims say (ChannelClaim::max_age_ns)
  SourcePos max_age_pos;
  // The kind's own settings, as the kind's own plain struct (no YAML), made by
  // its parser and read only by its own code: e.g. the sim driver's
  // std::any_cast<const sim::Settings>(&d.settings).
  std::any settings;
};

// One grant of `runtime.operators`: a user (by name or uid) or a group (by
// name) and the role its members get on the operator API (common/role.h).
struct OperatorGrant {
  bool group = false;  // "group:NAME"
  std::string who;     // user name, uid digits, or group name
  Role role = Role::kViewer;
  SourcePos pos;
};

struct RuntimeConfig {
  std::string file;                        // the config file as named by the caller
  std::string base_dir;                    // relative paths inside it were resolved against this
  std::string name = kDefaultRuntimeName;  // shared memory /rtplc-NAME, socket name
  SourcePos name_pos;
  std::string socket_path;  // empty: the runtime chooses
  SourcePos socket_pos;
  std::string retain_path;  // empty: the runtime chooses
  SourcePos retain_pos;
  bool programs_from_config = false;  // runtime.programs: config (else: the saved programs)
  SourcePos programs_pos;
  std::string monitor_group;  // empty: the image is readable by its owner only
  SourcePos monitor_group_pos;
  std::vector<OperatorGrant> operators;  // `operators:`; the owner and root are admin anyway
  SourcePos operators_pos;
  int band_lo = kDefaultBandLo;  // SCHED_FIFO band of the tasks, inclusive
  int band_hi = kDefaultBandHi;
  SourcePos band_pos;  // line 0 when the band is the default
  bool cpu_dma_latency = true;
  bool lock_memory = true;
  double retain_every_s = kDefaultRetainEvery;  // state-file writes (runtime.retain_every)
  std::vector<TaskConfig> tasks;
  std::vector<DriverConfig> drivers;

  const TaskConfig* find_task(std::string_view task_name) const;
  const DriverConfig* find_driver(std::string_view driver_name) const;
};

struct LoadOptions {
  // Check that every program file exists (an error at its position if not).
  // Off for configs checked away from their programs (and for the fuzzer).
  bool check_program_files = true;
};

struct LoadResult {
  std::optional<RuntimeConfig> config;  // set exactly when there is no error
  DiagnosticList diags;                 // errors and warnings, positions into `source`
  std::string file;                     // for rendering
  std::string source;                   // the text the positions refer to

  bool ok() const { return config.has_value() && !diags.has_errors(); }
  // Compiler-style text of every diagnostic ("file:line:col: error: ...").
  std::string render(bool color = false) const { return diags.render(file, source, color); }
};

// Reads and checks the config file at `path`; relative paths inside it are
// resolved against the file's folder. Never throws.
LoadResult load_config(const std::string& path, const LoadOptions& options = {});

// The same for text in memory: `file_name` names it in diagnostics, `base_dir`
// resolves relative paths ("" leaves them as written). Never throws.
LoadResult parse_config(std::string_view yaml, const std::string& file_name,
                        const std::string& base_dir, const LoadOptions& options = {});

// docs/config.md, generated from the schema (config/schema.h) and the driver
// kinds (config/driver_kinds.h); a test keeps the committed file equal to it.
std::string config_reference_markdown();

}  // namespace rtplc::config
