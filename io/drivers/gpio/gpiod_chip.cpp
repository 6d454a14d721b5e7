// The libgpiod 1.6 implementation of the chip op table (chip.h): the v1
// character-device API of Debian 12. A line handle is the library's
// gpiod_line; the chip handle its gpiod_chip.
#include <dirent.h>
#include <gpiod.h>
#include <poll.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include "io/drivers/gpio/chip.h"

namespace rtplc::gpio {
namespace {

gpiod_chip* as_chip(void* c) {
  return static_cast<gpiod_chip*>(c);
}
gpiod_line* as_line(void* l) {
  return static_cast<gpiod_line*>(l);
}

Result<void*> open_chip(void*, const std::string& chip) {
  gpiod_chip* c = gpiod_chip_open_lookup(chip.c_str());
  if (c == nullptr) {
    const int err = errno;
    if (auto a = gpio_cdev_available(); !a) return make_error(fmt::format("GPIO chip '{}': {}", chip, a.error()));
    return make_error(fmt::format("GPIO chip '{}' cannot be opened: {} (`rtplc gpio info` lists the chips)", chip,
                                  err == ENOENT || err == 0 ? "no such chip" : std::strerror(err)));
  }
  return static_cast<void*>(c);
}

void close_chip(void* chip) {
  gpiod_chip_close(as_chip(chip));
}

ChipInfo chip_info(void* chip) {
  ChipInfo i;
  i.name = gpiod_chip_name(as_chip(chip));
  i.label = gpiod_chip_label(as_chip(chip));
  i.lines = gpiod_chip_num_lines(as_chip(chip));
  return i;
}

LineInfo line_info(void* chip, unsigned offset) {
  LineInfo i;
  i.offset = offset;
  gpiod_line* l = gpiod_chip_get_line(as_chip(chip), offset);
  if (l == nullptr) return i;
  if (const char* n = gpiod_line_name(l)) i.name = n;
  if (const char* c = gpiod_line_consumer(l)) i.consumer = c;
  i.used = gpiod_line_is_used(l);
  i.output = gpiod_line_direction(l) == GPIOD_LINE_DIRECTION_OUTPUT;
  i.active_low = gpiod_line_active_state(l) == GPIOD_LINE_ACTIVE_STATE_LOW;
  return i;
}

int find_line(void* chip, const std::string& name) {
  gpiod_line* l = gpiod_chip_find_line(as_chip(chip), name.c_str());
  return l == nullptr ? -1 : static_cast<int>(gpiod_line_offset(l));
}

Result<void*> request_line(void* chip, const LineRequest& req, const char* consumer) {
  gpiod_line* l = gpiod_chip_get_line(as_chip(chip), req.offset);
  if (l == nullptr) {
    return make_error(fmt::format("line {} does not exist on {} ({} lines)", req.offset,
                                  gpiod_chip_name(as_chip(chip)), gpiod_chip_num_lines(as_chip(chip))));
  }
  gpiod_line_request_config cfg{};
  cfg.consumer = consumer;
  if (req.output) {
    cfg.request_type = GPIOD_LINE_REQUEST_DIRECTION_OUTPUT;
  } else {
    switch (req.edge) {
      case Edge::kNone: cfg.request_type = GPIOD_LINE_REQUEST_DIRECTION_INPUT; break;
      case Edge::kRising: cfg.request_type = GPIOD_LINE_REQUEST_EVENT_RISING_EDGE; break;
      case Edge::kFalling: cfg.request_type = GPIOD_LINE_REQUEST_EVENT_FALLING_EDGE; break;
      case Edge::kBoth: cfg.request_type = GPIOD_LINE_REQUEST_EVENT_BOTH_EDGES; break;
    }
  }
  if (req.active_low) cfg.flags |= GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW;
  switch (req.bias) {
    case Bias::kAsIs: break;
    case Bias::kDisable: cfg.flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE; break;
    case Bias::kPullUp: cfg.flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP; break;
    case Bias::kPullDown: cfg.flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN; break;
  }
  if (gpiod_line_request(l, &cfg, req.initial) != 0) {
    const int err = errno;
    const char* user = gpiod_line_consumer(l);
    return make_error(fmt::format("line {} of {} cannot be requested: {}{}", req.offset,
                                  gpiod_chip_name(as_chip(chip)), std::strerror(err),
                                  err == EBUSY && user ? fmt::format(" (used by '{}')", user) : std::string()));
  }
  return static_cast<void*>(l);
}

void release_line(void* line) {
  gpiod_line_release(as_line(line));
}

int get_line(void* line) {
  const int v = gpiod_line_get_value(as_line(line));
  return v < 0 ? -errno : v;
}

int set_line(void* line, int value) {
  return gpiod_line_set_value(as_line(line), value) == 0 ? 0 : errno;
}

int wait_lines(std::span<void* const> lines, int64_t timeout_ns, bool* ready) {
  constexpr size_t kMax = 64;  // config.h kMaxEventLines: the config refuses more
  pollfd fds[kMax];
  const size_t n = lines.size() < kMax ? lines.size() : kMax;
  for (size_t i = 0; i < n; ++i) {
    fds[i].fd = gpiod_line_event_get_fd(as_line(lines[i]));
    fds[i].events = POLLIN | POLLPRI;
    fds[i].revents = 0;
  }
  const timespec ts{static_cast<time_t>(timeout_ns / 1000000000), static_cast<long>(timeout_ns % 1000000000)};
  const int r = ppoll(fds, n, &ts, nullptr);
  if (r < 0) return errno == EINTR ? 0 : -errno;
  for (size_t i = 0; i < n; ++i) ready[i] = (fds[i].revents & (POLLIN | POLLPRI)) != 0;
  return r;
}

int read_events(void* line, EdgeEvent* out, unsigned max) {
  constexpr unsigned kMax = 16;  // the kernel's queue per line (v1 uAPI)
  gpiod_line_event e[kMax] = {};
  const int n = gpiod_line_event_read_multiple(as_line(line), e, max < kMax ? max : kMax);
  if (n < 0) return -errno;
  for (int i = 0; i < n; ++i) {
    out[i].rising = e[i].event_type == GPIOD_LINE_EVENT_RISING_EDGE;
    out[i].ts_ns = static_cast<int64_t>(e[i].ts.tv_sec) * 1000000000 + e[i].ts.tv_nsec;
  }
  return n;
}

const ChipOps kOps{"libgpiod", nullptr,   &open_chip,   &close_chip, &chip_info,  &line_info,  &find_line,
                   &request_line, &release_line, &get_line, &set_line, &wait_lines, &read_events};

}  // namespace

const ChipOps& gpiod_chip_ops() {
  return kOps;
}

Result<void> gpio_cdev_available() {
  DIR* d = opendir("/dev");
  if (d == nullptr) return make_error("/dev cannot be read");
  bool any = false;
  while (dirent* e = readdir(d)) any = any || std::strncmp(e->d_name, "gpiochip", 8) == 0;
  closedir(d);
  if (!any) {
    return make_error("this machine has no GPIO character device (/dev/gpiochipN): a kernel without "
                      "CONFIG_GPIO_CDEV, or no GPIO controller (gpio-sim makes one for tests)");
  }
  return {};
}

}  // namespace rtplc::gpio
