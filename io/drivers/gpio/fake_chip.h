// An in-process GPIO chip set for host tests (the op table of chip.h): chips
// of N lines, each line driven from outside like gpio-sim's `pull` attribute
// and read back like its `value`. Edges on requested lines queue events with
// the timestamps the test gives, exactly as the kernel queues them, so a test
// can drive bursts and bounces without timing anything. A line's event queue
// can be bounded like the kernel's (16 events per line in the uAPI v1 that
// libgpiod 1.6 uses): an edge that finds it full is dropped and counted.
// Thread-safe (one mutex: the fake is not real-time).
#pragma once

#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "io/drivers/gpio/chip.h"

namespace rtplc::gpio {

class FakeChips {
 public:
  FakeChips();
  ~FakeChips();
  FakeChips(const FakeChips&) = delete;
  FakeChips& operator=(const FakeChips&) = delete;

  const ChipOps& ops() const { return ops_; }
  // A chip `name` (opened as name, /dev/name or its label) with `lines` lines
  // named by `names` (fewer names: the rest unnamed).
  void add_chip(const std::string& name, const std::string& label, unsigned lines,
                std::vector<std::string> names = {});
  // Drives the physical level of an input line (the bias of an unrequested or
  // input line); queues an edge event stamped `ts_ns` when it changes and the
  // line was requested for that edge.
  void pull(const std::string& chip, unsigned offset, int level, int64_t ts_ns);
  // The physical level of a line (an output's driven level).
  int level(const std::string& chip, unsigned offset) const;
  bool requested(const std::string& chip, unsigned offset) const;
  // How many set() calls reached the chip (all lines).
  uint64_t sets() const;
  // Makes get()/set() on every line fail with `err` (0: work again).
  void fail_io(int err);
  // Each requested line queues at most `events` edge events (0: no limit,
  // the default); an edge that finds the queue full is dropped and counted.
  void limit_events(size_t events);
  // Edge events dropped so far because a line's queue was full (all lines).
  uint64_t events_dropped() const;

 private:
  struct Line;
  struct Chip;
  Line& line(const std::string& chip, unsigned offset) const;

  ChipOps ops_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::map<std::string, std::unique_ptr<Chip>> chips_;
  uint64_t sets_ = 0;
  int fail_ = 0;
  size_t event_limit_ = 0;
  uint64_t events_dropped_ = 0;

  friend struct FakeOps;
};

}  // namespace rtplc::gpio
