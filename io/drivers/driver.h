// One interface for every I/O driver (spec io-links.md, "Where data comes
// from"): the sim plant, S7, and the field drivers to come. A driver kind is one
// folder under io/drivers/ holding its protocol, its config keys, its bridge
// thread, its fake peer, its CLI and its tests, plus one line in
// io/drivers/registry.cpp. The runtime, `stats`, `monitor` and `status` see
// only what is declared here and never name a kind.
//
// The life of a driver, the same for every kind (the ros2_control lifecycle):
//   configure  the kind's parser fills DriverConfig::settings; its claims say
//              which input channels it provides (in the order of its region),
//              which task outputs it consumes, how many link rows it reports
//              (config/driver_kinds.h). The runtime lays the image out from the
//              claims and hands the driver a DriverSetup saying where each lives.
//   create     the kind builds its Driver (no threads, no network yet); errors
//              name the config entry.
//   start      the bridge thread starts on the common time grid.
//   cycle      every period on the bridge thread: read the outputs it consumes,
//              exchange with the peer (never blocking on the network), publish
//              one snapshot of its region: its inputs, and per consumed output
//              the delivery state (what it last sent and whether that arrived).
//   stop/join  after the tasks stopped (outputs at their safe values), one last
//              cycle sends those, then the thread ends.
//
// Region of a driver: [0, provides) its inputs, then one delivery entry per
// consumed output, [provides, provides + consumes). A delivery entry's quality
// is good while the output reaches its peer, bad while it cannot (peer down,
// write refused): the monitor shows an output as the worse of the task's
// quality and its delivery's, so an output never looks good while it is not
// being delivered. An output whose task quality is bad (a swap dropped it) is
// not sent at all: drivers read quality with the value (read_output()).
//
// Forcing (process_image.h, "Forcing") asks nothing of a kind: end_snapshot()
// puts an operator's forced inputs in place of the ones the driver read, and
// read_output() returns a forced output's value like any other.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "common/quality.h"
#include "common/result.h"
#include "config/config.h"
#include "config/driver_kinds.h"
#include "io/link/handoff.h"
#include "io/process_image.h"
#include "kernel_rt/rt_thread.h"

namespace CLI {
class App;
}

namespace rtplc::io {

// Where a consumed task output lives in the image.
struct OutputSource {
  uint32_t region = 0;
  uint32_t index = 0;
  int64_t max_age_ns = 0;  // the channel's (io::judge_quality)
  config::OnBad on_bad = config::OnBad::kHold;  // the channel's policy while not good
  double safe_value = 0;                        // what `safe` sends
};

// What a driver does with one consumed output this cycle (Driver::output_to_send).
enum class SendDecision : uint8_t {
  kSend,    // send `value`: good or forced, or the policy says what to send instead
  kHold,    // not good and its policy is hold: keep what the peer has
  kNoRead,  // no consistent snapshot this cycle: keep what was sent last
};

// A log line formatted without allocating: what a bridge's cycle() logs
// (kernel_rt/cycle_scope.h). Arguments must not allocate either: texts a
// kind needs (an item's name) are made once at construction.
struct LogLine {
  char text[160];
  template <typename... Args>
  explicit LogLine(fmt::format_string<Args...> f, Args&&... args) {
    const auto r = fmt::format_to_n(text, sizeof text - 1, f, std::forward<Args>(args)...);
    *r.out = '\0';
  }
};

// Something a driver wants in the log (a link went down or came back, the peer
// refused an item, a peer unreachable at start). Queued without blocking by the
// driver's threads, logged by the runtime's control thread.
struct LinkEvent {
  enum class Level : uint8_t { kInfo, kWarning, kError };
  Level level = Level::kInfo;
  char driver[kLabelBytes] = {};
  char text[160] = {};
};

// Many producers (drivers' threads), one consumer (the control thread); a full
// queue drops the event and counts it, never waits.
class LinkEventQueue {
 public:
  explicit LinkEventQueue(size_t capacity = 1024) : queue_(capacity) {}
  void push(LinkEvent::Level level, std::string_view driver, std::string_view text) noexcept;
  bool pop(LinkEvent& out) { return queue_.pop(out); }
  uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  link::BoundedQueue<LinkEvent> queue_;
  std::atomic<uint64_t> dropped_{0};
};

// What the runtime gives a driver when it creates it.
struct DriverSetup {
  const config::DriverConfig* config = nullptr;
  ProcessImage* image = nullptr;
  uint32_t region = 0;                // the driver's own region (see above)
  uint32_t n_provides = 0;            // = claims.provides.size()
  std::vector<OutputSource> consumes; // parallel to claims.consumes
  uint32_t first_link = 0;            // its rows: [first_link, first_link + claims.links)
  int64_t period_ns = 0;
  int priority = 0;         // SCHED_FIFO of the bridge thread (above the task band)
  int helper_priority = 0;  // for threads that only move bytes (below the task band)
  int cpu = -1;             // -1: not pinned
  LinkEventQueue* events = nullptr;
  // Changes a set-point by its label exactly as `rtplc set` does (the
  // runtime's checks, retained on disk before it takes effect); returns what
  // `rtplc set` prints, or why it refused. For a driver that lets a peer set
  // values (an HMI writing a set-point): call it from the driver's own non-RT
  // threads, never from cycle(). Null when no runtime is behind the driver
  // (tests that drive one alone).
  std::function<Result<std::string>(const std::string& label, double value)> set_point;
  // Where a driver may keep small files of its own across restarts: a path
  // prefix in the runtime's checked state folder ("/var/lib/rtplc/plant"); the
  // kind appends ".KIND-NAME.something". Empty when no runtime is behind it.
  std::string state_prefix;
};

// A driver with a periodic bridge thread (every kind so far). A kind
// implements cycle() and, when it has more to do, the hooks around it.
class Driver {
 public:
  explicit Driver(DriverSetup setup, const char* thread_tag);
  // A kind's destructor calls request_stop() and join() first, so the bridge
  // thread and the kind's own threads end while the kind's members still live
  // (this base destructor does it too, but by then only the base remains).
  virtual ~Driver();
  Driver(const Driver&) = delete;
  Driver& operator=(const Driver&) = delete;

  const std::string& name() const { return setup_.config->name; }
  const std::string& kind() const { return setup_.config->kind; }
  // Starts the kind's own machinery (on_start), publishes a first snapshot and
  // starts the bridge thread; its first cycle is at `first_release_ns`.
  Result<void> start(int64_t first_release_ns);
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }
  // Waits for the bridge thread (which runs on_stop() last) and ends the kind's machinery.
  void join();
  // Runs one cycle on the calling thread, inside a kernel_rt::CycleScope (the
  // bridge thread's loop, and tests that drive a driver themselves).
  void cycle_now(int64_t now_ns) noexcept;
  uint64_t cycles() const { return cycles_.load(std::memory_order_relaxed); }

  // The task outputs this driver sends, in the order of its delivery entries.
  const std::vector<OutputSource>& consumed_outputs() const { return setup_.consumes; }
  // Whether consumed output j could be sent as `value` (engineering units):
  // it fits the peer's encoding after the kind's scaling. Asked by a force on
  // the control thread before anything changes; the default takes any finite
  // number. The reason names the item and its range.
  virtual Result<void> can_send(uint32_t j, double value) const {
    (void)j;
    (void)value;
    return {};
  }

 protected:
  // One exchange; runs on the bridge thread. Never blocks, allocates or throws.
  virtual void cycle(int64_t now_ns) noexcept = 0;
  // Before the thread starts (on the control thread): e.g. an engine's own thread.
  virtual Result<void> on_start() { return {}; }
  // On the bridge thread after the last cycle: e.g. flush writes of safe values.
  virtual void on_stop() noexcept {}
  // After the bridge thread ended (control thread): stop the kind's own threads.
  virtual void on_joined() noexcept {}

  // Consumed output j: its value and the task's quality of it, judged by the
  // one freshness rule at `now_ns`. False when no consistent snapshot could be
  // read (keep what was sent last).
  bool read_output(uint32_t j, double& value, Quality& quality, int64_t now_ns) const noexcept;
  // Consumed output j through its `on_bad` policy, the one rule every kind
  // applies: good or forced -> send it; else hold (keep what the peer has),
  // safe (send its safe value) or send (the value anyway). `value` is what to
  // send when kSend.
  SendDecision output_to_send(uint32_t j, double& value, int64_t now_ns) const noexcept;

  // One snapshot of the driver's region per cycle.
  uint32_t begin_snapshot() const noexcept { return setup_.image->begin_write(setup_.region); }
  void put_input(uint32_t k, uint32_t i, double value, Quality q, int64_t timestamp_ns) const noexcept {
    setup_.image->put(setup_.region, k, i, value, q, timestamp_ns);
  }
  void put_delivery(uint32_t k, uint32_t j, double sent, Quality q, int64_t timestamp_ns) const noexcept {
    setup_.image->put(setup_.region, k, setup_.n_provides + j, sent, q, timestamp_ns);
  }
  void end_snapshot(uint32_t k, int64_t now_ns) const noexcept {
    setup_.image->end_write(setup_.region, k, now_ns, cycles());
  }
  LinkStatus& link_row(uint32_t l) const { return setup_.image->link(setup_.first_link + l); }
  // Names a link row (before start): its peer's name and address.
  void describe_link(uint32_t l, std::string_view name, std::string_view peer) const;
  // Names gauge g of link row l (before start): shown as "NAME VALUE" after the row.
  void name_gauge(uint32_t l, uint32_t g, std::string_view gauge_name) const;
  // Link row l's last error (LinkStatus::last_error): from one thread per row only.
  void set_link_error(uint32_t l, std::string_view text) const noexcept;
  void log(LinkEvent::Level level, std::string_view text) const noexcept;

  const DriverSetup& setup() const { return setup_; }
  // The first release start() was given (the common time grid); 0 before start
  // or when a test drives cycles itself.
  int64_t first_release_ns() const { return first_release_; }
  bool stopping() const { return stop_.load(std::memory_order_relaxed); }

 private:
  void run() noexcept;

  DriverSetup setup_;
  const char* tag_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> cycles_{0};
  int64_t first_release_ = 0;
  bool started_ = false;
  kernel_rt::RtThread thread_;
};

// The runtime side of a driver kind; `config` is its configuration side.
struct DriverKind {
  const config::DriverKind* config;
  Result<std::unique_ptr<Driver>> (*create)(const DriverSetup& setup);
  // Adds the kind's commissioning subcommand (`rtplc s7 ...`); may be null.
  void (*add_commands)(CLI::App& app);
};

// Registers a kind and its configuration side (io/drivers/registry.cpp does,
// for every built-in driver, before main() runs).
void register_driver_kind(const DriverKind* kind);
std::span<const DriverKind* const> driver_kinds();
const DriverKind* find_driver_kind(std::string_view kind);

}  // namespace rtplc::io
