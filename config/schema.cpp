// The key tables of the runtime configuration (see schema.h). Changing a row
// changes the loader's checks, its messages and docs/config.md together
// (regenerate the doc: see tests/config/test_docs.cpp).
#include "config/schema.h"

#include <cstdio>
#include <vector>

#include "common/registry.h"
#include "common/capacities.h"
#include "config/config.h"
#include "config/driver_kinds.h"

namespace rtplc::config {
namespace {

constexpr double kMaxDrivers = 32;
constexpr double kNoMin = 0;
constexpr double kNoMax = 0;

const KeySpec kTopKeys[] = {
    {"runtime", ValueType::kSection, false, kNoMin, kNoMax, "runtime", "(all defaults)",
     "Settings of the runtime process as a whole."},
    {"tasks", ValueType::kList, true, 1, static_cast<double>(kMaxTasks), "task", "",
     "The control tasks: one FBD program each, run periodically by its own thread."},
    {"drivers", ValueType::kList, false, 0, kMaxDrivers, "driver", "(no drivers)",
     "The I/O drivers that exchange the process image with the plant."},
};

const KeySpec kRuntimeKeys[] = {
    {"name", ValueType::kName, false, kNoMin, kNoMax, nullptr, kDefaultRuntimeName,
     "Names the shared-memory image (`/rtplc-NAME`) and the control socket, so two "
     "runtimes can share a machine."},
    {"socket", ValueType::kPath, false, kNoMin, kNoMax, nullptr, "(chosen by the runtime)",
     "Path of the control socket (`rtplc stats`, `set`, `swap`); created with mode 0600."},
    {"retain_file", ValueType::kPath, false, kNoMin, kNoMax, nullptr, "(chosen by the runtime)",
     "File holding the retained values (set-points) across restarts."},
    {"programs", ValueType::kChoice, false, kNoMin, kNoMax, "saved|config", "saved",
     "What a task runs when the runtime starts: `saved`, the program it ran last (the "
     "last swap survives a restart, like a PLC's boot application; the start says so), "
     "or `config`, always the file this configuration names."},
    {"monitor_group", ValueType::kText, false, kNoMin, kNoMax, "a group name", "(none: owner only)",
     "A group whose members may read the process image (`rtplc monitor`, `stats`, an HMI): "
     "the image is then mode 0640 with this group instead of 0600. Nobody but the owner "
     "can write it or use the control socket."},
    {"operators", ValueType::kLabelMap, false, kNoMin, kNoMax, "viewer|operator|engineer|admin",
     "(the owner only)",
     "Who else may use the control socket, and for what: `{WHO: ROLE, ...}` where WHO is a "
     "user name, a uid, or `group:NAME`, and ROLE is `viewer` (read), `operator` (also "
     "set-points, within their limits), `engineer` (also force, swap, rollback, trace) or "
     "`admin` (also stop). The runtime's owner and root are admin. With grants the socket's "
     "folder is 0711 and the socket 0666: every request is then authorised by the caller's "
     "uid from the kernel (docs/api.md)."},
    {"priority_band", ValueType::kIntegerPair, false, kMinFifoPriority, kMaxFifoPriority, nullptr,
     "[10, 49]",
     "SCHED_FIFO priorities the tasks may use, `[lo, hi]`; the default stays below the "
     "kernel's IRQ threads (50) and leaves room above for the drivers."},
    {"cpu_dma_latency", ValueType::kBool, false, kNoMin, kNoMax, nullptr, "true",
     "Hold `/dev/cpu_dma_latency` at 0 while running, keeping CPUs out of deep idle states."},
    {"lock_memory", ValueType::kBool, false, kNoMin, kNoMax, nullptr, "true",
     "`mlockall` and prefault before the tasks start, so no cycle page-faults."},
    {"retain_every", ValueType::kDuration, false, kMinRetainEvery, kMaxRetainEvery, nullptr, "1s",
     "How often the retained block state (see the tasks' `retain`) is written to `NAME.state` "
     "beside the retain file; it is also written when the runtime stops. A `kill -9` loses about "
     "this much at most."},
};

const KeySpec kTaskKeys[] = {
    {"name", ValueType::kName, false, kNoMin, kNoMax, nullptr, "the program file's stem",
     "Names the task in `stats`, `swap` and messages; unique among the tasks."},
    {"program", ValueType::kPath, true, kNoMin, kNoMax, nullptr, "",
     "The program file the task runs: FBD (.fbd), SFC (.sfc) or a PLCopen XML project "
     "(.xml, docs/plcopen.md)."},
    {"program_instance", ValueType::kName, false, kNoMin, kNoMax, nullptr,
     "the project's only task or program",
     "For a PLCopen XML or ST (.st) program: the task, program instance or program POU "
     "of the project this task runs."},
    {"semantics", ValueType::kChoice, false, kNoMin, kNoMax, "auto|matiec|codesys", "auto",
     "For a PLCopen XML or ST program: whose behaviour it gets where the editors' runtimes "
     "differ (the order of an SFC's cycle, TIME conversions; docs/plcopen.md, \"Which editor's "
     "semantics\"): `auto` takes the file header's editor (CODESYS for a CODESYS export, else "
     "MatIEC as Beremiz and OpenPLC run), or name one."},
    {"period", ValueType::kDuration, false, kMinPeriod, kMaxPeriod, nullptr,
     "the program's `stime()`", "Overrides the program's period."},
    {"priority", ValueType::kInteger, false, kMinFifoPriority, kMaxFifoPriority, nullptr,
     "rate-monotonic",
     "SCHED_FIFO priority, inside `priority_band`. By default the runtime gives shorter "
     "periods higher priorities."},
    {"cpu", ValueType::kInteger, false, 0, kMaxCpu, nullptr, "(not pinned)",
     "The CPU the task's thread is pinned to."},
    {"overrun", ValueType::kChoice, false, kNoMin, kNoMax, "skip|stop", "skip",
     "What a late cycle does: `skip` the missed releases and go on, or `stop` the task "
     "through the watchdog."},
    {"watchdog", ValueType::kInteger, false, 0, kMaxWatchdog, nullptr, "0 with skip, 3 with stop",
     "Consecutive overruns after which the task is stopped and its outputs take their safe "
     "values; 0 never stops it."},
    {"loop_budget", ValueType::kInteger, false, 1, kMaxLoopBudget, nullptr, "100000",
     "Loop iterations (backward jumps of WHILE, REPEAT, FOR, JMP) the program may take in one "
     "cycle. A cycle past it is a runaway loop: the cycle ends where it is, the task stops "
     "and its outputs take their safe values, as the watchdog does, and the log names the "
     "loop's file:line."},
    {"native", ValueType::kBool, false, kNoMin, kNoMax, nullptr, "false",
     "Run the program as native code: rtplc translates its image into C++ and compiles it "
     "with the machine's C++ compiler (`c++`, or RTPLC_CXX) when the task starts and before "
     "each swap, and refuses either if that fails. The results are the interpreter's, bit "
     "for bit; a loop-heavy program runs three to four times faster (docs/st.md, \"Native code\"). "
     "Needs a C++ compiler on the machine."},
    {"safe_outputs", ValueType::kLabelMap, false, kNoMin, kNoMax, nullptr, "every output 0",
     "`LABEL: value` for the outputs of a stopped task; outputs not listed go to 0."},
    {"on_bad", ValueType::kLabelMap, false, kNoMin, kNoMax, nullptr, "every output hold",
     "`LABEL: hold|safe|send`: what the drivers sending an output do while its status is "
     "not good (computed from a bad or stale input, or before the inputs are up): `hold` "
     "keeps what the peer has (no write, a CAN signal keeps its last bytes), `safe` sends "
     "its `safe_outputs` value, `send` sends the computed value anyway."},
    {"retain", ValueType::kBlockSelection, false, kNoMin, kNoMax, nullptr, "all",
     "Which blocks keep their state (integrators, counters, timers, filters, delays, SFC steps) "
     "across a restart, also after `kill -9`: `all`, `none`, or a list of block names "
     "`[F10, F12]`. `rtplc run --cold` starts every block from zero."},
    {"setpoints", ValueType::kLimitMap, false, kNoMin, kNoMax, nullptr, "(no limits)",
     "`LABEL: {min: lo, max: hi}` for the set-points (asp) of the task's program: `rtplc "
     "set` (and every other writer of set-points) refuses values outside [lo, hi]; the "
     "set-point's init value must lie inside. Either bound may be left out."},
    {"ranges", ValueType::kLimitMap, false, kNoMin, kNoMax, nullptr, "(no ranges)",
     "`LABEL: {min: lo, max: hi}`: the engineering range of an input or output of the "
     "task's program (a transmitter's 0..200 m3/h, a valve's 0..100 %). `rtplc force` "
     "refuses a value outside it, naming it. Either bound may be left out; set-points "
     "take theirs from `setpoints`."},
};

const KeySpec kDriverKeys[] = {
    {"kind", ValueType::kDriverKind, true, kNoMin, kNoMax, nullptr, "",
     "What the driver talks to; its own keys follow below."},
    {"name", ValueType::kName, false, kNoMin, kNoMax, nullptr, "the kind",
     "Names the driver in messages; unique among the drivers."},
    {"period", ValueType::kDuration, false, kMinPeriod, kMaxPeriod, nullptr, "10ms",
     "How often the driver exchanges its channels with the process image."},
    {"priority", ValueType::kInteger, false, kMinFifoPriority, kMaxFifoPriority, nullptr,
     "above the task band",
     "SCHED_FIFO priority of the driver's thread; it should lie above `priority_band` so "
     "the driver preempts the tasks."},
    {"cpu", ValueType::kInteger, false, 0, kMaxCpu, nullptr, "(not pinned)",
     "The CPU the driver's thread is pinned to."},
    {"max_age", ValueType::kDuration, false, 0.001, 3600, nullptr, "the kind's (a few of its polls)",
     "How old a good input of this driver may be before every consumer (tasks, drivers, the "
     "monitor, modbus-server) takes it as stale: a frozen peer, a starved line thread or a "
     "driver that stopped publishing shows within this age. By default each kind declares its "
     "own (three of its poll or frame periods; three driver periods, at least 100 ms, where it "
     "has none: a fast GPIO loop on a loaded machine is not called stale for a few late cycles)."},
};

const SectionSpec kTop{"top", "the config", "Top level", "", kTopKeys};
const SectionSpec kRuntime{"runtime", "the runtime section", "`runtime:`",
                           "Optional; every key has a default.", kRuntimeKeys};
const SectionSpec kTask{"task", "a task", "`tasks:` entries",
                        "One entry per task; each runs on its own SCHED_FIFO thread.", kTaskKeys};
const SectionSpec kDriver{"driver", "a driver", "`drivers:` entries",
                          "Keys every driver has, whatever its kind. An unknown kind is an "
                          "error that lists the known ones.",
                          kDriverKeys};

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, v == static_cast<double>(static_cast<int64_t>(v)) ? "%.0f" : "%g",
                v);
  return buf;
}

}  // namespace

const SectionSpec& top_section() {
  return kTop;
}
const SectionSpec& runtime_section() {
  return kRuntime;
}
const SectionSpec& task_section() {
  return kTask;
}
const SectionSpec& driver_section() {
  return kDriver;
}

namespace {
const char* kind_name(const DriverKind& k) { return k.kind; }
using KindTable = Registry<DriverKind>;
}  // namespace

void register_driver_kind(const DriverKind* kind) { KindTable::add(kind, kind_name); }

std::span<const DriverKind* const> driver_kinds() { return KindTable::all(); }

const DriverKind* find_driver_kind(std::string_view kind) { return KindTable::find(kind, kind_name); }

std::string known_driver_kinds() {
  std::string s;
  for (const DriverKind* d : driver_kinds()) s += (s.empty() ? "" : ", ") + std::string(d->kind);
  return s;
}

const char* type_name(ValueType t) {
  switch (t) {
    case ValueType::kSection:
      return "map";
    case ValueType::kList:
      return "list";
    case ValueType::kLabelMap:
      return "map LABEL: number";
    case ValueType::kLimitMap:
      return "map LABEL: {min, max}";
    case ValueType::kName:
      return "name";
    case ValueType::kPath:
      return "path";
    case ValueType::kDuration:
      return "duration";
    case ValueType::kInteger:
      return "integer";
    case ValueType::kIntegerPair:
      return "[lo, hi]";
    case ValueType::kBool:
      return "boolean";
    case ValueType::kChoice:
      return "word";
    case ValueType::kChannel:
      return "channel";
    case ValueType::kPlantModel:
      return "plant model";
    case ValueType::kDriverKind:
      return "word";
    case ValueType::kText:
      return "text";
    case ValueType::kReal:
      return "number";
    case ValueType::kBlockSelection:
      return "block selection";
  }
  return "";
}

const KeySpec* find_key(const SectionSpec& s, std::string_view key) {
  for (const KeySpec& k : s.keys) {
    if (key == k.key) return &k;
  }
  return nullptr;
}

std::string describe_type(const KeySpec& k) {
  switch (k.type) {
    case ValueType::kSection:
      return "a map of keys";
    case ValueType::kList:
      return std::string("a list of ") + k.choices + " entries";
    case ValueType::kLabelMap:
      return "a map of LABEL: number";
    case ValueType::kLimitMap:
      return "a map of LABEL: {min: number, max: number}";
    case ValueType::kName:
      return "a name of letters, digits, '_' and '-'";
    case ValueType::kPath:
      return "a file path";
    case ValueType::kDuration:
      return "a duration such as 10ms, 250us, 0.5s or 2 (seconds)";
    case ValueType::kInteger:
      return "a whole number";
    case ValueType::kIntegerPair:
      return "a pair [lo, hi] of whole numbers";
    case ValueType::kBool:
      return "true or false";
    case ValueType::kChoice: {
      std::string s = "one of ";
      for (const char* c = k.choices; *c; ++c)
        s += *c == '|' ? std::string(", ") : std::string(1, *c);
      return s;
    }
    case ValueType::kChannel:
      return "a channel address pN.dN.cN";
    case ValueType::kPlantModel:
      return "a plant spec such as second-order or fopdt:T=5,L=1";
    case ValueType::kDriverKind:
      return "a driver kind (" + known_driver_kinds() + ")";
    case ValueType::kText:
      return "a text";
    case ValueType::kReal:
      return "a number";
    case ValueType::kBlockSelection:
      return "`all`, `none` or a list of block names such as [F10, F12]";
  }
  return "a value";
}

std::string describe_allowed(const KeySpec& k) {
  switch (k.type) {
    case ValueType::kSection:
      return "see below";
    case ValueType::kList:
      if (k.min == k.max) return number(k.min) + " entries";
      return number(k.min) + ".." + number(k.max) + " entries";
    case ValueType::kLabelMap:
      return "labels of the task's outputs; finite numbers";
    case ValueType::kLimitMap:
      return std::string("labels of the task's ") +
             (std::string_view(k.key) == "ranges" ? "inputs and outputs" : "set-points") +
             "; finite numbers, min <= max, each optional";
    case ValueType::kName:
      return "1..31 of `A-Z a-z 0-9 _ -`";
    case ValueType::kPath:
      return "relative to the config file's folder";
    case ValueType::kDuration:
      return format_duration(k.min) + ".." + format_duration(k.max);
    case ValueType::kInteger:
      return number(k.min) + ".." + number(k.max);
    case ValueType::kIntegerPair:
      return number(k.min) + " <= lo <= hi <= " + number(k.max);
    case ValueType::kBool:
      return "`true`, `false`";
    case ValueType::kChoice: {
      std::string s = "`";
      for (const char* c = k.choices; *c; ++c)
        s += *c == '|' ? std::string("`, `") : std::string(1, *c);
      return s + "`";
    }
    case ValueType::kChannel:
      return "p, d 0..255; c 0..65535";
    case ValueType::kPlantModel:
      return "see \"Plant models\"";
    case ValueType::kDriverKind: {
      std::string s;
      for (const DriverKind* d : driver_kinds())
        s += (s.empty() ? "`" : ", `") + std::string(d->kind) + "`";
      return s;
    }
    case ValueType::kText:
      return k.choices ? k.choices : "";
    case ValueType::kReal:
      return "finite";
    case ValueType::kBlockSelection:
      return "`all`, `none`, names of the program's blocks (a macro call's or SFC name selects what it expands to)";
  }
  return "";
}

}  // namespace rtplc::config
