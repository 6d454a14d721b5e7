// Explicitly scheduled threads with SCHED_OTHER fallback (spec: runtime.md, "Tasks and the
// scheduler").
#include "kernel_rt/rt_thread.h"

#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <fmt/format.h>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cstring>
#include <memory>
#include <semaphore>
#include <utility>

#include "kernel_rt/memory.h"

namespace rtplc::kernel_rt {
namespace {

std::atomic<bool> g_fallback_reported{false};

SchedPolicy from_native(int policy) {
  switch (policy) {
    case SCHED_OTHER:
      return SchedPolicy::kOther;
    case SCHED_FIFO:
      return SchedPolicy::kFifo;
    case SCHED_RR:
      return SchedPolicy::kRoundRobin;
    case SCHED_BATCH:
      return SchedPolicy::kBatch;
    case SCHED_IDLE:
      return SchedPolicy::kIdle;
#ifdef SCHED_DEADLINE
    case SCHED_DEADLINE:
      return SchedPolicy::kDeadline;
#endif
    default:
      return SchedPolicy::kUnknown;
  }
}

// Asks the kernel about one thread id (0 = the calling thread). pthread_getschedparam is not
// used because glibc may answer from the attributes it cached at creation.
SchedState query_tid(pid_t tid) {
  const int policy = sched_getscheduler(tid);
  if (policy < 0) return {};
  sched_param sp{};
  if (sched_getparam(tid, &sp) != 0) return {};
  return SchedState{from_native(policy & ~SCHED_RESET_ON_FORK), sp.sched_priority};
}

std::string fifo_refusal_reason(int priority) {
  rlimit lim{};
  getrlimit(RLIMIT_RTPRIO, &lim);
  const std::string limit =
      lim.rlim_cur == RLIM_INFINITY ? "unlimited" : fmt::format("{}", lim.rlim_cur);
  return fmt::format(
      "SCHED_FIFO priority {} refused (no CAP_SYS_NICE, RLIMIT_RTPRIO {}), running SCHED_OTHER "
      "without real-time guarantees; run as root, or allow it with `LimitRTPRIO=99` in the "
      "systemd unit or `<user> - rtprio 99` in /etc/security/limits.d/rtplc.conf "
      "(`rtplc doctor` checks this)",
      priority, limit);
}

// Shared between the starter and the new thread: the starter waits on `ready` until the
// thread has named itself and prefaulted its stack, then reads `stack_note`. Shared
// ownership because a short body may finish before the starter has read the note.
struct StartBlock {
  std::function<void()> body;
  std::string name;
  size_t prefault = 0;
  std::string stack_note;
  pid_t tid = 0;
  SchedState obtained;
  std::binary_semaphore ready{0};
  std::shared_ptr<std::atomic<size_t>> high_water = std::make_shared<std::atomic<size_t>>(0);
};

void* trampoline(void* arg) {
  std::shared_ptr<StartBlock> block(*static_cast<std::shared_ptr<StartBlock>*>(arg));
  delete static_cast<std::shared_ptr<StartBlock>*>(arg);
  if (!block->name.empty()) {
    // The kernel limit is 16 bytes with the terminator; a longer name makes the call fail.
    const std::string comm = block->name.substr(0, 15);
    pthread_setname_np(pthread_self(), comm.c_str());
  }
  if (block->prefault > 0) {
    Result<void> st = prefault_stack(block->prefault);
    if (!st) block->stack_note = st.error();
  }
  paint_stack_of_this_thread();
  block->tid = gettid();
  block->obtained = query_tid(0);
  const std::shared_ptr<std::atomic<size_t>> high_water = block->high_water;
  block->ready.release();
  block->body();
  high_water->store(stack_high_water_of_this_thread(), std::memory_order_relaxed);
  return nullptr;
}

// Owns a pthread_attr_t for the length of one start attempt.
struct Attr {
  pthread_attr_t a;
  Attr() { pthread_attr_init(&a); }
  ~Attr() { pthread_attr_destroy(&a); }
  Attr(const Attr&) = delete;
  Attr& operator=(const Attr&) = delete;
};

size_t page_rounded(size_t bytes) {
  const long p = sysconf(_SC_PAGESIZE);
  const size_t page = p > 0 ? static_cast<size_t>(p) : 4096u;
  return (bytes + page - 1) / page * page;
}

// One pthread_create with the given policy; returns its error number.
size_t stack_size_for(const ThreadSpec& spec) {
  const size_t min = static_cast<size_t>(PTHREAD_STACK_MIN);
  return page_rounded(std::max(spec.stack_bytes > 0 ? spec.stack_bytes : kDefaultStackBytes, min));
}

int create_with(const ThreadSpec& spec, bool fifo, pthread_t* out, void* arg) {
  Attr attr;
  if (const int rc = pthread_attr_setstacksize(&attr.a, stack_size_for(spec)); rc != 0) return rc;
  if (spec.cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(*spec.cpu, &set);
    const int rc = pthread_attr_setaffinity_np(&attr.a, sizeof set, &set);
    if (rc != 0) return rc;
  }
  // Without EXPLICIT_SCHED the new thread would inherit the creator's policy and silently
  // ignore the one set here.
  pthread_attr_setinheritsched(&attr.a, PTHREAD_EXPLICIT_SCHED);
  sched_param sp{};
  if (fifo) {
    pthread_attr_setschedpolicy(&attr.a, SCHED_FIFO);
    sp.sched_priority = spec.fifo_priority;
  } else {
    pthread_attr_setschedpolicy(&attr.a, SCHED_OTHER);
  }
  pthread_attr_setschedparam(&attr.a, &sp);
  return pthread_create(out, &attr.a, trampoline, arg);
}

}  // namespace

const char* policy_name(SchedPolicy p) noexcept {
  switch (p) {
    case SchedPolicy::kOther:
      return "SCHED_OTHER";
    case SchedPolicy::kFifo:
      return "SCHED_FIFO";
    case SchedPolicy::kRoundRobin:
      return "SCHED_RR";
    case SchedPolicy::kBatch:
      return "SCHED_BATCH";
    case SchedPolicy::kIdle:
      return "SCHED_IDLE";
    case SchedPolicy::kDeadline:
      return "SCHED_DEADLINE";
    case SchedPolicy::kUnknown:
      break;
  }
  return "unknown";
}

RtThread::RtThread(RtThread&& other) noexcept
    : handle_(other.handle_),
      tid_(other.tid_),
      joinable_(std::exchange(other.joinable_, false)),
      stack_bytes_(other.stack_bytes_),
      stack_high_water_(std::move(other.stack_high_water_)),
      outcome_(std::move(other.outcome_)) {}

RtThread& RtThread::operator=(RtThread&& other) noexcept {
  if (this != &other) {
    join();
    handle_ = other.handle_;
    tid_ = other.tid_;
    joinable_ = std::exchange(other.joinable_, false);
    stack_bytes_ = other.stack_bytes_;
    stack_high_water_ = std::move(other.stack_high_water_);
    outcome_ = std::move(other.outcome_);
  }
  return *this;
}

RtThread::~RtThread() {
  join();
}

void RtThread::join() noexcept {
  if (!joinable_) return;
  pthread_join(handle_, nullptr);
  joinable_ = false;
}

size_t RtThread::stack_high_water() const noexcept {
  return stack_high_water_ ? stack_high_water_->load(std::memory_order_relaxed) : 0;
}

SchedState RtThread::sched_now() const noexcept {
  if (!joinable_ || tid_ == 0) return {};
  return query_tid(tid_);
}

Result<RtThread> start_thread(const ThreadSpec& spec, std::function<void()> body) {
  if (!body) return make_error("thread '" + spec.name + "' has no body");
  const bool want_fifo = spec.fifo_priority != 0;
  if (want_fifo) {
    const int lo = sched_get_priority_min(SCHED_FIFO);
    const int hi = sched_get_priority_max(SCHED_FIFO);
    if (spec.fifo_priority < lo || spec.fifo_priority > hi) {
      return make_error(fmt::format("thread '{}': SCHED_FIFO priority {} is outside {}..{}",
                                    spec.name, spec.fifo_priority, lo, hi));
    }
  }
  if (spec.cpu && !cpu_allowed(*spec.cpu)) {
    return make_error(
        fmt::format("thread '{}': CPU {} is not available to this process ({} allowed)", spec.name,
                    *spec.cpu, allowed_cpu_count()));
  }

  auto block = std::make_shared<StartBlock>();
  block->body = std::move(body);
  block->name = spec.name;
  block->prefault = spec.prefault_stack;

  RtThread thread;
  SchedOutcome& out = thread.outcome_;
  out.requested = want_fifo ? SchedState{SchedPolicy::kFifo, spec.fifo_priority}
                            : SchedState{SchedPolicy::kOther, 0};

  // The trampoline takes over this heap copy of the pointer; a failed create leaves it to us.
  auto* arg = new std::shared_ptr<StartBlock>(block);
  int rc = create_with(spec, want_fifo, &thread.handle_, arg);
  if (rc == EPERM && want_fifo) {
    out.fell_back = true;
    out.fallback_reason = fifo_refusal_reason(spec.fifo_priority);
    out.first_fallback_in_process = !g_fallback_reported.exchange(true);
    rc = create_with(spec, false, &thread.handle_, arg);
  }
  if (rc != 0) {
    delete arg;
    return make_error(fmt::format("thread '{}' could not start: {}", spec.name, std::strerror(rc)));
  }
  thread.joinable_ = true;
  thread.stack_bytes_ = stack_size_for(spec);
  thread.stack_high_water_ = block->high_water;
  block->ready.acquire();
  out.stack_note = block->stack_note;
  out.obtained = block->obtained;
  thread.tid_ = block->tid;
  return thread;
}

SchedState current_thread_sched() noexcept {
  return query_tid(0);
}

unsigned allowed_cpu_count() noexcept {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return 0;
  return static_cast<unsigned>(CPU_COUNT(&set));
}

bool cpu_allowed(unsigned cpu) noexcept {
  if (cpu >= CPU_SETSIZE) return false;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return false;
  return CPU_ISSET(cpu, &set);
}

void reset_fallback_notice_for_tests() noexcept {
  g_fallback_reported.store(false);
}

}  // namespace rtplc::kernel_rt
