// Planning the process image (spec runtime.md, "The process image"): from the
// configuration, the compiled programs and what each driver claims
// (config/driver_kinds.h), where every channel lives — one output region per
// task, one region per driver (its inputs, then the delivery state of each
// output it consumes), the set-points, the inputs nobody provides — plus the
// tasks' rate-monotonic priorities. A pure function: no shared memory, no
// threads; the runtime creates the image from the plan, and the tests check
// plans directly.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "blocks/image.h"
#include "common/diagnostic.h"
#include "config/config.h"
#include "config/driver_kinds.h"
#include "io/drivers/driver.h"
#include "io/process_image.h"

namespace rtplc::sched {

inline constexpr uint32_t kSpareOutputs = 32;    // room for outputs a hot swap adds
inline constexpr uint32_t kSpareSetpoints = 64;  // ... and set-points
inline constexpr uint32_t kSpareUnwired = 64;    // ... and inputs no driver provides

struct DriverPlan {
  uint32_t region = 0;
  uint32_t n_provides = 0;
  std::vector<io::OutputSource> consumes;  // parallel to its claims' consumes
  uint32_t first_link = 0;
  int priority = 0;         // its bridge thread
  int helper_priority = 0;  // threads that only move bytes
};

struct ImagePlan {
  io::ImageLayout layout;
  std::vector<io::ChannelDesc> channels;
  std::map<std::string, uint32_t> channel_by_key;  // channel key -> index in `channels`
  std::vector<std::vector<std::string>> task_output_keys;  // per task: output index -> key
  std::vector<int64_t> periods_ns;  // per task
  std::vector<int> priorities;      // per task
  std::vector<DriverPlan> drivers;
  uint32_t setpoint_region = 0;
  uint32_t unwired_region = 0;
};

// Where diagnostics go: the config file's list, and each task's program's.
struct PlanDiagnostics {
  DiagnosticList* config = nullptr;
  std::vector<DiagnosticList*> programs;  // per task
};

// Rate-monotonic priorities inside cfg's band: shorter period, higher priority,
// and consistent with the priorities the user set explicitly.
std::vector<int> rate_monotonic_priorities(const config::RuntimeConfig& cfg,
                                           std::span<const int64_t> periods_ns);

// Plans the image; false (with diagnostics) when the configuration and the
// programs do not fit together: an output with two writers, a label naming two
// channels, a driver consuming an output no task writes, a safe output that
// names no output, too many channels.
bool plan_image(const config::RuntimeConfig& cfg, const std::string& name,
                std::span<const TaskImage> images, std::span<const config::DriverClaims> claims,
                PlanDiagnostics diags, ImagePlan& out);

// The range of a set-point's limits for messages: "[0, 100]", ">= 0", "<= 100".
std::string limits_text(const std::optional<double>& min, const std::optional<double>& max);

// A channel table entry; init and retain are set by the caller for set-points.
// The age after which an input of driver `dc` is stale: its `max_age:`, else
// its kind's claim, else three driver periods and at least 100 ms (io::judge_quality).
int64_t input_max_age_ns(const config::DriverConfig& dc, const config::ChannelClaim& claim);

// The age after which a task's output is stale: three of its periods, and at
// least a second (a task that stopped writing, its runtime frozen).
int64_t output_max_age_ns(int64_t task_period_ns);

io::ChannelDesc channel_desc(const std::string& label, const std::string& key, io::ChannelDir dir,
                             uint8_t kind, uint32_t region, uint32_t index);
// The same for a task image's binding: its kind, and its HMI mark (kBindingHmi).
io::ChannelDesc channel_desc(const Binding& b, const std::string& label, const std::string& key, io::ChannelDir dir,
                             uint32_t region, uint32_t index);

// An output's `on_bad` policy and safe value from its task's config.
void set_output_policy(const config::TaskConfig& task, const std::string& label, io::ChannelDesc& d);

}  // namespace rtplc::sched
