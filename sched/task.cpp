// The task thread's cycle and the swap hand-over (see task.h).
#include "sched/task.h"

#include <cstring>

#include <algorithm>
#include <limits>

#include "kernel_rt/clock.h"
#include "kernel_rt/cycle_scope.h"
#include "kernel_rt/memory.h"

namespace rtplc::sched {

Task::Task(TaskParams params, io::ProcessImage& image, uint32_t index, uint32_t output_region,
           uint32_t setpoint_region, std::unique_ptr<LoadedProgram> first)
    : params_(std::move(params)),
      image_(image),
      index_(index),
      region_(output_region),
      setpoint_region_(setpoint_region),
      info_(&image.task_info(index)),
      stats_(static_cast<CycleStats*>(image.task_stats(index))),
      owned_(std::move(first)),
      trace_(image.trace_block(index)) {
  current_ = owned_.get();
  active_ = owned_.get();
}

Task::~Task() {
  request_stop();
  join();
  // The thread is gone, so nothing moves under us. A program published but
  // never taken (the task stopped first) is still pending; one taken but not
  // yet collected is the current program and owned_ holds the one it replaced.
  if (LoadedProgram* never_applied = pending_.exchange(nullptr)) {
    delete never_applied;
  } else if (in_flight_ != nullptr) {
    owned_.reset(in_flight_);  // frees the replaced program, keeps the running one until now
  }
  in_flight_ = nullptr;
}

Result<void> Task::start(int64_t first_release_ns) {
  first_release_ = first_release_ns;
  kernel_rt::ThreadSpec spec;
  spec.name = "rtplc:" + params_.name.substr(0, 9);
  spec.fifo_priority = params_.priority;
  if (params_.cpu >= 0) spec.cpu = static_cast<unsigned>(params_.cpu);
  // The cycle's deepest call chain (executor, input copy, stats) needs a few KiB;
  // tests/runtime holds a 10,000-block task under half of the default stack.
  spec.stack_bytes = kernel_rt::kDefaultStackBytes;
  spec.prefault_stack = 64 * 1024;
  info_->state.store(static_cast<uint8_t>(io::TaskState::kStarting), std::memory_order_relaxed);
  auto t = kernel_rt::start_thread(spec, [this] { run(); });
  if (!t) return make_error("task " + params_.name + ": " + t.error());
  thread_ = std::move(t).value();
  const kernel_rt::SchedOutcome& o = thread_.outcome();
  fell_back_ = o.fell_back;
  fallback_reason_ = o.fallback_reason;
  info_->fifo = o.obtained.policy == kernel_rt::SchedPolicy::kFifo ? 1 : 0;
  info_->priority = o.obtained.priority;
  return {};
}

void Task::join() {
  if (thread_.joinable()) thread_.join();
}

bool Task::publish(std::unique_ptr<LoadedProgram> next) {
  if (in_flight_ != nullptr) return false;
  in_flight_ = next.release();
  pending_.store(in_flight_, std::memory_order_release);
  return true;
}

std::unique_ptr<LoadedProgram> Task::collect() {
  if (in_flight_ == nullptr || !swap_applied()) return nullptr;
  retired_.exchange(nullptr, std::memory_order_acquire);  // == owned_.get()
  std::unique_ptr<LoadedProgram> previous(owned_.release());
  owned_.reset(in_flight_);
  in_flight_ = nullptr;
  active_ = owned_.get();
  return previous;
}

bool read_group(const io::ProcessImage& image, InputGroup& g, double* io_in, uint8_t* in_status,
                int64_t now_ns, uint32_t max_tries, bool* any_not_good) noexcept {
  uint64_t seen = 0;
  const auto n = static_cast<uint32_t>(g.src.size());
  if (!image.read_values(g.region, g.src.data(), n, g.scratch.data(), max_tries, &seen, g.quality_scratch.data(),
                         g.time_scratch.data())) {
    return false;
  }
  g.seen = seen;
  for (uint32_t i = 0; i < n; ++i) {
    io_in[g.dst[i]] = g.scratch[i];
    // One rule for every consumer (io::judge_quality); a forced value carries
    // `forced` in the snapshot itself (process_image.h, "Forcing").
    const Quality q = io::judge_quality(g.quality_scratch[i], g.scratch[i], g.time_scratch[i], now_ns, g.max_age_ns[i]);
    g.quality_scratch[i] = q;
    const auto s = static_cast<uint8_t>(lane_of(q));
    in_status[g.dst[i]] = s;
    if (s != 0 && any_not_good != nullptr) *any_not_good = true;
  }
  for (size_t j = 0; j < g.quality_dst.size(); ++j) {
    io_in[g.quality_dst[j]] = lane_of(g.quality_scratch[g.quality_pos[j]]) == Lane::kGood ? 1.0 : 0.0;
  }
  return true;
}

void Task::read_inputs(LoadedProgram& p, int64_t now_ns) noexcept {
  for (InputGroup& g : p.inputs) {
    if (g.setpoints) {
      // Set-points change when an operator types; most cycles skip them.
      const uint64_t pub = image_.ring(g.region).published.load(std::memory_order_acquire);
      if (pub == g.seen) continue;
    }
    // Three tries: a fourth would only be needed if the writer finished three
    // more snapshots while we copied one; then we keep last cycle's inputs.
    if (!read_group(image_, g, p.arena.io_in.data(), p.lane.in.data(), now_ns, 3, &p.lane.in_dirty) &&
        image_.ring(g.region).published.load(std::memory_order_relaxed) != 0) {
      info_->input_misses.fetch_add(1, std::memory_order_relaxed);
    }
  }
}

void Task::write_outputs(LoadedProgram& p, bool safe) noexcept {
  const uint32_t k = image_.begin_write(region_);
  double* slot = image_.values(region_, k);
  ExecContext ctx = make_context(p.image, p.arena);
  if (p.native != nullptr) ctx.native = p.native->entry();
  if (!safe && p.outputs_in_place) {
    // The executor writes the outputs straight into the snapshot being built
    // (atomic release stores, see blocks/executor_body.inc and io/process_image.h).
    ctx.io_out = slot;
    execute_cycle(ctx);
  } else if (!safe) {
    execute_cycle(ctx);
    if (p.arena.loop_fault == 0) {
      const double* out = p.arena.io_out.data();
      for (size_t i = 0; i < p.output_slots.size(); ++i) {
        io::store_value(slot + p.output_slots[i], out[i]);
      }
    }
  }
  // A runaway loop cut the cycle short: what it stored is partial and is never
  // published; the safe values take its place in this very snapshot, and
  // run() stops the task.
  if (!safe && p.arena.loop_fault != 0) safe = true;
  if (safe) {
    for (size_t i = 0; i < p.output_slots.size(); ++i) {
      io::store_value(slot + p.output_slots[i], p.safe_values[i]);
    }
  }
  for (const LoadedProgram::Dropped& d : p.dropped) io::store_value(slot + d.index, d.safe_value);
  if (safe) {
    // Safe values are what the runtime means to send: vouched for as such.
    p.region_quality = p.output_quality;
    p.lane.settled = false;
  } else if (p.lane.needs_pass(p.arena.total_errors)) {
    // Some value may not be good: each output's quality is its program's
    // (holes, dropped outputs: bad) made worse by the status of what computed it.
    propagate_status(p.image, p.arena, p.lane);
    for (size_t i = 0; i < p.output_slots.size(); ++i) {
      const uint32_t at = p.output_slots[i];
      if (at >= p.region_quality.size() || i >= p.lane.out.size()) continue;
      p.region_quality[at] = static_cast<uint8_t>(
          worse(static_cast<Quality>(p.output_quality[at]), quality_of(static_cast<Lane>(p.lane.out[i]))));
    }
  }
  // Every quality in every snapshot: the ring's four slots each hold their
  // own, and a force's stamp must not outlive the force (process_image.h).
  uint8_t* q = image_.quality(region_, k);
  for (size_t i = 0; i < p.region_quality.size(); ++i) {
    std::atomic_ref<uint8_t>(q[i]).store(p.region_quality[i], std::memory_order_release);
  }
  image_.slot(region_, k).region_state.store(safe ? 1 : 0, std::memory_order_relaxed);
  image_.end_write(region_, k, kernel_rt::monotonic_now_ns(), p.arena.cycles);
}

namespace {

// The report of instruction i's errors so far, named and positioned.
BlockErrorReport block_report(const LoadedProgram& p, uint32_t i, int64_t now_ns) noexcept {
  BlockErrorReport r;
  r.count = p.arena.errors[i];
  r.source_hash = p.image.header().source_hash;
  r.when_ns = now_ns;
  const BlockInfo& b = p.image.blocks()[i];
  r.line = b.line;
  r.col = b.col;
  std::strncpy(r.name, p.image.str(b.name), sizeof r.name - 1);
  std::strncpy(r.block, p.image.str(b.block), sizeof r.block - 1);
  return r;
}

}  // namespace

void Task::report_block_errors(LoadedProgram& p, int64_t now_ns) noexcept {
  const auto n = static_cast<uint32_t>(p.errors_reported.size());
  if (n == 0 || p.arena.errors.size() < n) return;
  for (uint32_t k = 0; k < n; ++k) {
    const uint32_t i = (p.next_error_scan + k) % n;
    const uint64_t now = p.arena.errors[i];
    if (now <= p.errors_reported[i]) continue;
    BlockErrorReport r = block_report(p, i, now_ns);
    r.new_errors = now - p.errors_reported[i];
    // Counted as reported even when the queue is full: the image's count says
    // how many there were, and the next report is a second away.
    (void)block_errors_.push(r);
    p.errors_reported_total += r.new_errors;
    p.errors_reported[i] = now;
    p.next_error_scan = (i + 1) % n;
    next_error_report_ns_ = now_ns + p.error_report_gap_ns;
    p.error_report_gap_ns = std::min<int64_t>(p.error_report_gap_ns * 2, int64_t{60} * 1000000000);
    return;
  }
  // Counters that were reset (a program's own arena reset): start again from them.
  p.errors_reported_total = p.arena.total_errors;
}

void Task::report_runaway_loop(LoadedProgram& p, int64_t now_ns) noexcept {
  const uint32_t i = p.arena.loop_fault - 1;
  if (i >= p.image.blocks().size()) return;
  BlockErrorReport r = block_report(p, i, now_ns);
  r.runaway_loop = true;
  r.budget = p.arena.loop_budget;
  r.new_errors = 1;
  // The usual report of this error count is this one.
  if (i < p.errors_reported.size()) {
    p.errors_reported_total += p.arena.errors[i] - p.errors_reported[i];
    p.errors_reported[i] = p.arena.errors[i];
  }
  (void)block_errors_.push(r);
}

void Task::resolve_trace(const LoadedProgram& p) noexcept {
  for (uint32_t i = 0; i < trace_.n(); ++i) {
    const io::TraceSource& s = trace_.sources()[i];
    trace_output_[i] = -1;
    trace_input_[i] = nullptr;
    if (s.region == region_) {
      trace_output_[i] = static_cast<int32_t>(s.index);
      continue;
    }
    // An input or set-point: the value this program copied in this cycle.
    for (const InputGroup& g : p.inputs) {
      if (g.region != s.region) continue;
      for (size_t k = 0; k < g.src.size(); ++k) {
        if (g.src[k] == s.index) trace_input_[i] = p.arena.io_in.data() + g.dst[k];
      }
    }
  }
}

void Task::record_trace(uint64_t cycle, int64_t release_ns) noexcept {
  double v[io::kTraceChannels];
  // The snapshot this cycle just published (only this thread writes the region).
  const uint64_t published = image_.ring(region_).published.load(std::memory_order_relaxed);
  const double* slot = image_.values(region_, static_cast<uint32_t>(published % io::kRingSlots));
  for (uint32_t i = 0; i < trace_.n(); ++i) {
    if (trace_output_[i] >= 0) v[i] = io::load_value(slot + trace_output_[i]);
    else if (trace_input_[i] != nullptr) v[i] = *trace_input_[i];
    else v[i] = std::numeric_limits<double>::quiet_NaN();  // this program does not read it
  }
  trace_.append(cycle, release_ns, v);
}

void Task::run() noexcept {
  const int64_t period = params_.period_ns;
  int64_t release = first_release_;
  bool stopped = false;  // by the watchdog: outputs safe, code not run until a swap
  uint64_t faults_before = 0;
  uint64_t cycle = 0;
  uint32_t until_snapshot = 1;  // the first cycle takes one, so a restart soon after has it
  uint32_t until_watch = 1;
  current_->arena.loop_budget = params_.loop_budget;
  info_->state.store(static_cast<uint8_t>(io::TaskState::kRunning), std::memory_order_relaxed);
  while (!stop_.load(std::memory_order_relaxed)) {
    if (params_.back_to_back) {
      release = kernel_rt::monotonic_now_ns();
    } else {
      kernel_rt::sleep_until_ns(release);
    }
    const int64_t wake = kernel_rt::monotonic_now_ns();
    const kernel_rt::CycleScope no_allocation;  // to the end of this cycle
    if (params_.count_faults) faults_before = kernel_rt::minor_faults_this_thread();

    // Swap boundary: the new program runs in this very cycle.
    bool swapped = false;
    if (LoadedProgram* next = pending_.load(std::memory_order_acquire)) {
      swapped = true;
      next->arena.loop_budget = params_.loop_budget;
      if (next->migration.active) apply_migration(next->migration, current_->arena, next->arena);
      for (InputGroup& g : next->inputs) g.seen = 0;  // refresh every input now
      until_snapshot = 1;  // the new program's layout: snapshot it in this cycle
      retired_.store(current_, std::memory_order_release);
      current_ = next;
      pending_.store(nullptr, std::memory_order_release);
      info_->swaps.fetch_add(1, std::memory_order_relaxed);
      next_error_report_ns_ = 0;  // the new program's first block error is said at once
      info_->last_swap_ns.store(wake, std::memory_order_relaxed);
      if (stopped) {
        stopped = false;  // new code is how an operator restarts a stopped task
        info_->state.store(static_cast<uint8_t>(io::TaskState::kRunning), std::memory_order_relaxed);
      }
    }

    // A new trace selection, or a new program, changes where traced values are.
    if (trace_.pick_up() || swapped) resolve_trace(*current_);

    if (!stopped) {
      read_inputs(*current_, wake);
      write_outputs(*current_, false);
      if (current_->arena.loop_fault != 0) {
        stopped = true;
        report_runaway_loop(*current_, wake);
        info_->state.store(static_cast<uint8_t>(io::TaskState::kStoppedLoop), std::memory_order_relaxed);
      }
      info_->block_errors.store(current_->arena.total_errors, std::memory_order_relaxed);
      if (current_->arena.total_errors != current_->errors_reported_total && wake >= next_error_report_ns_) {
        report_block_errors(*current_, wake);
      }
      if (params_.snapshot_every > 0 && --until_snapshot == 0) {
        until_snapshot = params_.snapshot_every;
        current_->snapshot.take(current_->arena, wake);
      }
      if (watch_until_ns_.load(std::memory_order_relaxed) > wake && --until_watch == 0) {
        until_watch = params_.watch_every;
        current_->watch.take_watch(current_->arena, current_->lane, wake);
      }
      if (trace_.n() > 0) record_trace(cycle, release);
    }
    const int64_t end = kernel_rt::monotonic_now_ns();
    if (params_.count_faults && cycle > 16) {
      // The first cycles may still touch fresh pages (a just-swapped program's
      // arena); every later one must fault nothing.
      const uint64_t f = kernel_rt::minor_faults_this_thread() - faults_before;
      if (f) info_->minor_faults.fetch_add(f, std::memory_order_relaxed);
    }
    ++cycle;
    stats_->record(wake - release, end - wake);

    release += period;
    if (end > release) {
      // Every release that passed while we ran is skipped: the next cycle starts
      // on the grid again instead of running late back to back.
      const uint64_t skipped = static_cast<uint64_t>((end - release) / period) + 1;
      release += static_cast<int64_t>(skipped) * period;
      if (stopped) continue;  // a stopped task runs no code: nothing to account for
      if (swapped) info_->swap_overruns.fetch_add(1, std::memory_order_relaxed);
      const uint64_t consecutive = stats_->record_overrun(skipped);
      const bool limit = params_.watchdog > 0 && consecutive >= params_.watchdog;
      if (!stopped && (limit || (params_.overrun == OverrunPolicy::kStop && params_.watchdog == 0))) {
        stopped = true;
        write_outputs(*current_, true);
        info_->state.store(static_cast<uint8_t>(io::TaskState::kStoppedWatchdog),
                           std::memory_order_relaxed);
      }
    }
  }
  // Leaving: the outputs go to their safe values, as when the watchdog fires.
  write_outputs(*current_, true);
  info_->state.store(static_cast<uint8_t>(io::TaskState::kStopped), std::memory_order_relaxed);
}

}  // namespace rtplc::sched
