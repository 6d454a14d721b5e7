// The trace verbs of a running runtime (see runtime.h and io/trace_ring.h):
// which task samples the channels an operator names, the hand-over of the
// selection to that task, and the lease that ends a trace whose tool went
// away. Control thread only.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <thread>

#include "common/diagnostic.h"
#include "kernel_rt/clock.h"
#include "sched/runtime.h"

namespace rtplc::sched {
namespace {

const char* dir_name(uint8_t dir) {
  switch (static_cast<io::ChannelDir>(dir)) {
    case io::ChannelDir::kInput: return "input";
    case io::ChannelDir::kOutput: return "output";
    case io::ChannelDir::kSetpoint: return "setpoint";
  }
  return "?";
}

// "no channel is labelled X (did you mean Y?)".
std::string unknown_label(const io::ProcessImage& img, const std::string& label) {
  std::string best;
  size_t best_d = 3;
  for (uint32_t c = 0; c < img.channel_count(); ++c) {
    const size_t d = edit_distance(img.channel(c).label, label);
    if (d < best_d) {
      best_d = d;
      best = img.channel(c).label;
    }
  }
  return "no channel is labelled \"" + label + "\"" + (best.empty() ? "" : " (did you mean \"" + best + "\"?)") +
         "; `rtplc monitor` lists the labels";
}

}  // namespace

Result<std::string> Runtime::trace_start(const std::vector<std::string>& labels) {
  if (labels.empty()) return make_error("name at least one channel to trace");
  if (labels.size() > io::kTraceChannels) {
    return make_error("at most " + std::to_string(io::kTraceChannels) + " channels per trace, not " +
                      std::to_string(labels.size()));
  }
  traces_.resize(tasks_.size());
  // Which task samples each channel: an output on the cycles of the task that
  // writes it, an input or set-point on those of the first task that reads it
  // (the value its program used in that cycle).
  int task = -1;
  std::string task_of_first;
  io::TraceSource src[io::kTraceChannels] = {};
  std::string body_columns;
  for (size_t i = 0; i < labels.size(); ++i) {
    const std::string& label = labels[i];
    if (std::find(labels.begin(), labels.begin() + static_cast<std::ptrdiff_t>(i), label) !=
        labels.begin() + static_cast<std::ptrdiff_t>(i)) {
      return make_error("\"" + label + "\" is named twice");
    }
    const int c = image_.find_channel(label);
    if (c < 0) return make_error(unknown_label(image_, label));
    const io::ChannelDesc& d = image_.channel(static_cast<uint32_t>(c));
    int owner = -1;
    if (d.dir == static_cast<uint8_t>(io::ChannelDir::kOutput)) {
      const io::RegionDesc& r = image_.region(d.region);
      if (r.kind == static_cast<uint8_t>(io::RegionKind::kTask)) owner = static_cast<int>(r.owner);
    } else {
      for (size_t t = 0; t < tasks_.size() && owner < 0; ++t) {
        for (const InputGroup& g : tasks_[t]->active().inputs) {
          if (g.region == d.region && std::find(g.src.begin(), g.src.end(), d.index) != g.src.end()) {
            owner = static_cast<int>(t);
          }
        }
      }
    }
    if (owner < 0) {
      return make_error("\"" + label + "\" is read by no task's program, so no task cycle samples it "
                        "(a trace records channels on the cycles of the task that writes or reads them)");
    }
    const std::string owner_name = tasks_[static_cast<size_t>(owner)]->params().name;
    if (task >= 0 && owner != task) {
      return make_error("\"" + labels[0] + "\" is sampled by task " + task_of_first + " and \"" + label +
                        "\" by task " + owner_name + ": one trace records one task's cycles (so every row "
                        "is one real cycle); run one `rtplc trace` per task");
    }
    task = owner;
    task_of_first = owner_name;
    src[i].region = d.region;
    src[i].index = d.index;
    body_columns += "column " + label + " " + dir_name(d.dir) + " " + (d.kind ? "digital" : "analog") + "\n";
  }
  const auto t = static_cast<uint32_t>(task);
  Task& tk = *tasks_[t];
  TraceLease& lease = traces_[t];
  if (!lease.token.empty() && !lease.clearing) {
    return make_error("task " + tk.params().name + " is already being traced (" + lease.labels +
                      "); one trace per task at a time: stop that `rtplc trace` first, or wait until "
                      "its lease runs out (" + std::to_string(kTraceLeaseNs / 1000000000) + " s after it died)");
  }
  io::TraceBlock* block = image_.trace_block(t);
  if (block == nullptr) return make_error("this runtime's image has no trace rings");
  if (!tk.running()) return make_error("task " + tk.params().name + " is not running");
  // The task takes a selection at its next cycle boundary: wait at most a few periods.
  const int64_t deadline = kernel_rt::monotonic_now_ns() + std::max<int64_t>(10 * tk.params().period_ns, 2000000000);
  auto wait_taken = [&](uint64_t* first) {
    while (!io::trace_applied(*block, first)) {
      if (kernel_rt::monotonic_now_ns() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    return true;
  };
  // The last selection (a trace that just ended hands over an empty one) first.
  if (!wait_taken(nullptr) || (lease.clearing && (!clear_trace(t) || !wait_taken(nullptr)))) {
    return make_error("task " + tk.params().name + " has not let go of its last trace (is it running?)");
  }
  io::prefault(*block);
  if (!io::request_trace(*block, src, static_cast<uint32_t>(labels.size()))) {
    return make_error("task " + tk.params().name + " has not taken its last trace selection (is it running?)");
  }
  lease.token = "T" + std::to_string(++trace_counter_) + "." + std::to_string(kernel_rt::monotonic_now_ns() % 1000000);
  lease.expires_ns = kernel_rt::monotonic_now_ns() + kTraceLeaseNs;
  lease.clearing = false;
  lease.labels.clear();
  for (size_t i = 0; i < labels.size(); ++i) lease.labels += (i ? ", " : "") + labels[i];
  uint64_t first = 0;
  if (!wait_taken(&first)) {
    // It may take it later: the lease runs out and tick() clears it then.
    return make_error("task " + tk.params().name + " did not take the trace selection (is it running?)");
  }
  return "trace " + lease.token + "\ntask " + tk.params().name + " " + std::to_string(t) + " " +
         std::to_string(tk.params().period_ns) + " " + std::to_string(first) + "\n" + body_columns;
}

Result<std::string> Runtime::trace_keep(const std::string& token) {
  for (TraceLease& l : traces_) {
    if (l.token == token && !l.clearing) {
      l.expires_ns = kernel_rt::monotonic_now_ns() + kTraceLeaseNs;
      return std::string("kept ") + token;
    }
  }
  return make_error("no trace " + token + " (it ended, or its lease ran out)");
}

Result<std::string> Runtime::trace_end(const std::string& token) {
  for (uint32_t t = 0; t < traces_.size(); ++t) {
    TraceLease& l = traces_[t];
    if (l.token != token || l.clearing) continue;
    l.clearing = true;
    clear_trace(t);
    return std::string("ended ") + token;
  }
  return make_error("no trace " + token + " (it ended, or its lease ran out)");
}

// Hands the task an empty selection; false while it has not taken the last
// one yet (then tick() tries again).
bool Runtime::clear_trace(uint32_t t) {
  TraceLease& l = traces_[t];
  io::TraceBlock* block = image_.trace_block(t);
  if (block == nullptr || io::request_trace(*block, nullptr, 0)) {
    l = TraceLease{};
    return true;
  }
  return false;
}

void Runtime::expire_traces(const std::function<void(bool, const std::string&)>& log) {
  const int64_t now = kernel_rt::monotonic_now_ns();
  for (uint32_t t = 0; t < traces_.size(); ++t) {
    TraceLease& l = traces_[t];
    if (l.token.empty()) continue;
    if (l.clearing) {
      clear_trace(t);
      continue;
    }
    if (now < l.expires_ns) continue;
    log(false, "trace of task " + tasks_[t]->params().name + " (" + l.labels +
                   ") ended: its reader stopped renewing it");
    l.clearing = true;
    clear_trace(t);
  }
}

}  // namespace rtplc::sched
