// Reads the kernel's /proc and /sys files below a root prefix, so `rtplc doctor` and RT-kernel
// detection can be pointed at a fake tree in tests (spec: runtime.md, "Tasks and the
// scheduler": doctor reads /sys/kernel/realtime, uname -v, rt throttling, isolated CPUs,
// governor). Also the small parsers for what those files hold: CPU lists, the kernel command
// line, kernel config text.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rtplc::kernel_rt {

class HostFiles {
 public:
  // `root` is prepended to every absolute path; "/" (the default) reads the live system.
  explicit HostFiles(std::string root = "/");

  const std::string& root() const noexcept { return root_; }
  bool is_live() const noexcept { return root_ == "/"; }
  // The real path of `abs` (an absolute path such as "/proc/cmdline").
  std::string path(std::string_view abs) const;

  // Whole file, or nullopt when missing or unreadable. /proc files report size 0, so this
  // reads until EOF rather than trusting stat.
  std::optional<std::string> read(std::string_view abs, size_t max_bytes = 1u << 20) const;
  // First line without surrounding white space.
  std::optional<std::string> read_line(std::string_view abs) const;
  std::optional<long long> read_integer(std::string_view abs) const;
  bool exists(std::string_view abs) const;
  // Names in a directory (no "." or ".."), sorted; empty when missing.
  std::vector<std::string> list_dir(std::string_view abs) const;
  // Whether the file can be opened for writing (opened and closed again, nothing written).
  bool writable(std::string_view abs) const;

  // The running kernel's build configuration: /proc/config.gz when the kernel exposes it
  // (and this build can decompress it), else /boot/config-<release>. The second element names
  // the source it came from.
  std::optional<std::pair<std::string, std::string>> kernel_config() const;

 private:
  std::string root_;
};

std::string trim(std::string_view s);

// "0-3,8,10-11" -> {0,1,2,3,8,10,11}. Stops at the first malformed element; an empty or
// "(null)" input gives an empty list. Tolerates the flag prefixes isolcpus accepts
// ("managed_irq,domain,2-3").
std::vector<unsigned> parse_cpu_list(std::string_view text);
// {0,1,2,3,8} -> "0-3,8".
std::string format_cpu_list(const std::vector<unsigned>& cpus);
// A hex CPU mask as in /proc/irq/default_smp_affinity ("ff", "00000000,00000003").
std::vector<unsigned> parse_cpu_mask(std::string_view hex);

// Value of `key=` on a kernel command line ("" for a bare flag such as `nosmt`), or nullopt.
// The last occurrence wins, as in the kernel.
std::optional<std::string> cmdline_value(std::string_view cmdline, std::string_view key);

// Value of CONFIG_<name> in kernel config text: "y", "m", a string, or nullopt when unset.
std::optional<std::string> config_value(std::string_view config, std::string_view name);

}  // namespace rtplc::kernel_rt
