// Root-prefixed reads of /proc and /sys, and parsers of their contents (spec: runtime.md,
// "Tasks and the scheduler", the doctor paragraph).
#include "kernel_rt/host_files.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <utility>

#ifdef RTPLC_HAVE_ZLIB
#include <zlib.h>
#endif

namespace rtplc::kernel_rt {

HostFiles::HostFiles(std::string root) : root_(std::move(root)) {
  if (root_.empty()) root_ = "/";
  while (root_.size() > 1 && root_.back() == '/') root_.pop_back();
}

std::string HostFiles::path(std::string_view abs) const {
  if (root_ == "/") return std::string(abs);
  std::string p = root_;
  if (abs.empty() || abs.front() != '/') p += '/';
  p += abs;
  return p;
}

std::optional<std::string> HostFiles::read(std::string_view abs, size_t max_bytes) const {
  const std::string p = path(abs);
  std::FILE* f = std::fopen(p.c_str(), "rbe");
  if (f == nullptr) return std::nullopt;
  std::string out;
  char buf[4096];
  bool failed = false;
  while (out.size() < max_bytes) {
    const size_t n = std::fread(buf, 1, sizeof buf, f);
    out.append(buf, n);
    if (n < sizeof buf) {
      failed = std::ferror(f) != 0;
      break;
    }
  }
  std::fclose(f);
  if (failed) return std::nullopt;
  if (out.size() > max_bytes) out.resize(max_bytes);
  return out;
}

std::optional<std::string> HostFiles::read_line(std::string_view abs) const {
  auto text = read(abs, 64u * 1024u);
  if (!text) return std::nullopt;
  const size_t nl = text->find('\n');
  return trim(std::string_view(*text).substr(0, nl));
}

std::optional<long long> HostFiles::read_integer(std::string_view abs) const {
  auto line = read_line(abs);
  if (!line || line->empty()) return std::nullopt;
  char* end = nullptr;
  const long long v = std::strtoll(line->c_str(), &end, 10);
  if (end == line->c_str()) return std::nullopt;
  return v;
}

bool HostFiles::exists(std::string_view abs) const {
  struct stat st {};
  return ::stat(path(abs).c_str(), &st) == 0;
}

std::vector<std::string> HostFiles::list_dir(std::string_view abs) const {
  std::vector<std::string> names;
  DIR* d = ::opendir(path(abs).c_str());
  if (d == nullptr) return names;
  while (const dirent* e = ::readdir(d)) {
    const std::string_view n = e->d_name;
    if (n != "." && n != "..") names.emplace_back(n);
  }
  ::closedir(d);
  std::sort(names.begin(), names.end());
  return names;
}

bool HostFiles::writable(std::string_view abs) const {
  const int fd = ::open(path(abs).c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return false;
  ::close(fd);
  return true;
}

std::optional<std::pair<std::string, std::string>> HostFiles::kernel_config() const {
#ifdef RTPLC_HAVE_ZLIB
  {
    const std::string p = path("/proc/config.gz");
    if (gzFile gz = gzopen(p.c_str(), "rb")) {
      std::string text;
      char buf[16384];
      int n = 0;
      while ((n = gzread(gz, buf, sizeof buf)) > 0) text.append(buf, static_cast<size_t>(n));
      gzclose(gz);
      if (n == 0 && !text.empty())
        return std::pair{std::move(text), std::string("/proc/config.gz")};
    }
  }
#endif
  if (auto release = read_line("/proc/sys/kernel/osrelease"); release && !release->empty()) {
    const std::string boot = "/boot/config-" + *release;
    if (auto text = read(boot, 4u << 20)) return std::pair{std::move(*text), boot};
  }
  return std::nullopt;
}

std::string trim(std::string_view s) {
  size_t b = 0;
  size_t e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b])) != 0) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1])) != 0) --e;
  return std::string(s.substr(b, e - b));
}

namespace {

bool parse_uint(std::string_view s, unsigned& out) {
  if (s.empty() || s.size() > 6) return false;
  unsigned v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    v = v * 10u + static_cast<unsigned>(c - '0');
  }
  out = v;
  return true;
}

}  // namespace

std::vector<unsigned> parse_cpu_list(std::string_view text) {
  std::vector<unsigned> cpus;
  const std::string t = trim(text);
  if (t.empty() || t == "(null)") return cpus;
  std::string_view rest = t;
  while (!rest.empty()) {
    const size_t comma = rest.find(',');
    std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    // isolcpus flags ("nohz", "domain", "managed_irq") precede the list itself.
    if (!item.empty() && std::isalpha(static_cast<unsigned char>(item.front())) != 0) continue;
    // Ranges may carry a stride: "0-7:2/4" is rare enough to be read as its plain range.
    const size_t colon = item.find(':');
    if (colon != std::string_view::npos) item = item.substr(0, colon);
    const size_t dash = item.find('-');
    unsigned lo = 0;
    unsigned hi = 0;
    if (dash == std::string_view::npos) {
      if (!parse_uint(item, lo)) break;
      hi = lo;
    } else if (!parse_uint(item.substr(0, dash), lo) || !parse_uint(item.substr(dash + 1), hi) ||
               hi < lo) {
      break;
    }
    for (unsigned c = lo; c <= hi && c < 65536u; ++c) cpus.push_back(c);
  }
  std::sort(cpus.begin(), cpus.end());
  cpus.erase(std::unique(cpus.begin(), cpus.end()), cpus.end());
  return cpus;
}

std::string format_cpu_list(const std::vector<unsigned>& cpus) {
  std::string out;
  size_t i = 0;
  while (i < cpus.size()) {
    size_t j = i;
    while (j + 1 < cpus.size() && cpus[j + 1] == cpus[j] + 1) ++j;
    if (!out.empty()) out += ',';
    out += std::to_string(cpus[i]);
    if (j > i) out += '-' + std::to_string(cpus[j]);
    i = j + 1;
  }
  return out;
}

std::vector<unsigned> parse_cpu_mask(std::string_view hex) {
  std::vector<unsigned> cpus;
  std::string digits;
  for (char c : trim(hex)) {
    if (c != ',') digits += c;
  }
  unsigned bit = 0;
  for (auto it = digits.rbegin(); it != digits.rend(); ++it, bit += 4) {
    const char c = static_cast<char>(std::tolower(static_cast<unsigned char>(*it)));
    unsigned v = 0;
    if (c >= '0' && c <= '9') {
      v = static_cast<unsigned>(c - '0');
    } else if (c >= 'a' && c <= 'f') {
      v = static_cast<unsigned>(c - 'a' + 10);
    } else {
      return {};
    }
    for (unsigned b = 0; b < 4; ++b) {
      if ((v & (1u << b)) != 0) cpus.push_back(bit + b);
    }
  }
  std::sort(cpus.begin(), cpus.end());
  return cpus;
}

std::optional<std::string> cmdline_value(std::string_view cmdline, std::string_view key) {
  std::optional<std::string> found;
  size_t pos = 0;
  while (pos < cmdline.size()) {
    while (pos < cmdline.size() && std::isspace(static_cast<unsigned char>(cmdline[pos])) != 0)
      ++pos;
    size_t end = pos;
    bool quoted = false;
    while (end < cmdline.size() &&
           (quoted || std::isspace(static_cast<unsigned char>(cmdline[end])) == 0)) {
      if (cmdline[end] == '"') quoted = !quoted;
      ++end;
    }
    const std::string_view word = cmdline.substr(pos, end - pos);
    // Everything after a lone "--" belongs to init, not to the kernel.
    if (word == "--") break;
    const size_t eq = word.find('=');
    const std::string_view name = word.substr(0, eq);
    if (name == key) {
      std::string value =
          eq == std::string_view::npos ? std::string() : std::string(word.substr(eq + 1));
      value.erase(std::remove(value.begin(), value.end(), '"'), value.end());
      found = std::move(value);
    }
    pos = end;
  }
  return found;
}

std::optional<std::string> config_value(std::string_view config, std::string_view name) {
  const std::string key = "CONFIG_" + std::string(name) + "=";
  size_t pos = 0;
  while (pos < config.size()) {
    const size_t nl = config.find('\n', pos);
    const std::string_view line =
        config.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    if (line.substr(0, key.size()) == key) {
      std::string v(line.substr(key.size()));
      if (v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
      return v;
    }
    if (nl == std::string_view::npos) break;
    pos = nl + 1;
  }
  return std::nullopt;
}

}  // namespace rtplc::kernel_rt
