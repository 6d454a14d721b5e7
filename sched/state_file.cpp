// The retained-state file: format, checksum and restore matching (see state_file.h).
#include "sched/state_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <sstream>
#include <unordered_map>

#include "common/files.h"

namespace rtplc::sched {

// 16 bytes per double written: this is millions of state values.
constexpr off_t kMaxStateBytes = off_t{256} << 20;

const SavedTask* SavedState::find(std::string_view task) const {
  for (const SavedTask& t : tasks) {
    if (t.name == task) return &t;
  }
  return nullptr;
}

uint32_t crc32_update(uint32_t c, std::string_view bytes) {
  // IEEE 802.3 polynomial, reflected; the table is built once.
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t v = i;
      for (int k = 0; k < 8; ++k) v = (v & 1u) ? 0xEDB88320u ^ (v >> 1) : v >> 1;
      t[i] = v;
    }
    return t;
  }();
  for (const char ch : bytes) c = table[(c ^ static_cast<uint8_t>(ch)) & 0xFFu] ^ (c >> 8);
  return c;
}

uint32_t crc32(std::string_view bytes) { return crc32_final(crc32_update(kCrc32Start, bytes)); }

bool encode_state_to(const std::function<bool(std::string_view)>& sink, std::string_view runtime,
                     int64_t saved_unix_ms, const std::vector<TaskStateRef>& tasks) {
  uint32_t crc = kCrc32Start;
  std::string line;
  auto put = [&](std::string_view piece) {
    crc = crc32_update(crc, piece);
    return sink(piece);
  };
  char buf[40];
  auto block = [&](std::string_view name, std::string_view kind, const double* v, size_t n) {
    line.assign("block ").append(name).append(" ").append(kind).append(" ").append(std::to_string(n));
    for (size_t i = 0; i < n; ++i) {
      std::snprintf(buf, sizeof buf, " %.17g", v[i]);
      line += buf;
    }
    line += "\n";
    return put(line);
  };
  line = std::string(kStateMagic) + " " + std::to_string(kStateVersion) + "\nruntime " + std::string(runtime) +
         "\nsaved " + std::to_string(saved_unix_ms) + "\n";
  if (!put(line)) return false;
  for (const TaskStateRef& t : tasks) {
    const size_t n_blocks = t.saved ? t.saved->blocks.size() : t.layout ? t.layout->size() : 0;
    line = "task " + std::string(t.name) + " " + std::to_string(t.cycle) + " " + std::to_string(n_blocks) + "\n";
    if (!put(line)) return false;
    if (t.saved) {
      for (const SavedBlock& sb : t.saved->blocks) {
        if (!block(sb.name, sb.kind, sb.values.data(), sb.values.size())) return false;
      }
    } else if (t.layout) {
      size_t i = 0;
      for (const RetainedBlock& rb : *t.layout) {
        if (!block(rb.name, rb.kind, t.data->data() + i, rb.width())) return false;
        i += rb.width();
      }
    }
  }
  std::snprintf(buf, sizeof buf, "crc32 %08x\n", crc32_final(crc));
  return sink(buf);
}

namespace {
std::vector<TaskStateRef> refs_of(const SavedState& s) {
  std::vector<TaskStateRef> refs;
  for (const SavedTask& t : s.tasks) refs.push_back({t.name, t.cycle, &t, nullptr, nullptr});
  return refs;
}
}  // namespace

std::string encode_state(const SavedState& s) {
  std::string text;
  encode_state_to(
      [&](std::string_view piece) {
        text.append(piece);
        return true;
      },
      s.runtime, s.saved_unix_ms, refs_of(s));
  return text;
}

namespace {

bool parse_u64(const std::string& w, uint64_t& out) {
  if (w.empty() || w[0] == '-') return false;
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(w.c_str(), &end, 10);
  if (*end != '\0' || errno != 0) return false;
  out = v;
  return true;
}

bool parse_double(const std::string& w, double& out) {
  if (w.empty()) return false;
  char* end = nullptr;
  out = std::strtod(w.c_str(), &end);
  return *end == '\0';
}

}  // namespace

Result<SavedState> decode_state(std::string_view text, const std::string& file) {
  auto bad = [&](const std::string& why) { return make_error(file + ": " + why); };
  const std::string magic = std::string(kStateMagic) + " ";
  if (text.substr(0, magic.size()) != magic)
    return bad("not an rtplc state file (no '" + magic + "' header)");
  // The checksum line is the last line; anything cut off before it is a torn file.
  if (text.empty() || text.back() != '\n')
    return bad("truncated (the file does not end with its checksum line)");
  const size_t last = text.rfind('\n', text.size() - 2);
  const std::string_view tail = last == std::string_view::npos ? text : text.substr(last + 1);
  if (tail.substr(0, 6) != "crc32 ") return bad("truncated (no checksum line at its end)");
  const std::string_view body = text.substr(0, last + 1);
  char want[16];
  std::snprintf(want, sizeof want, "%08x", crc32(body));
  if (tail.substr(6, tail.size() - 7) != want) {
    return bad("checksum mismatch (crc32 " + std::string(tail.substr(6, tail.size() - 7)) +
               " in the file, " + want + " of its contents): the file is damaged");
  }
  SavedState s;
  std::istringstream in{std::string(body)};
  std::string line;
  int n = 0;
  SavedTask* task = nullptr;
  size_t blocks_left = 0;
  while (std::getline(in, line)) {
    ++n;
    std::istringstream ls(line);
    std::vector<std::string> w{std::istream_iterator<std::string>(ls),
                               std::istream_iterator<std::string>()};
    auto at = [&](const std::string& why) { return bad("line " + std::to_string(n) + ": " + why); };
    if (w.empty()) return at("empty line");
    if (n == 1) {
      uint64_t v = 0;
      if (w.size() != 2 || !parse_u64(w[1], v)) return at("expected '" + magic + "VERSION'");
      if (v != kStateVersion) {
        return at("format version " + w[1] + ", this rtplc reads version " +
                  std::to_string(kStateVersion));
      }
    } else if (w[0] == "runtime" && w.size() == 2) {
      s.runtime = w[1];
    } else if (w[0] == "saved" && w.size() == 2) {
      uint64_t v = 0;
      if (!parse_u64(w[1], v)) return at("expected 'saved UNIX_MS'");
      s.saved_unix_ms = static_cast<int64_t>(v);
    } else if (w[0] == "task") {
      uint64_t cycle = 0, count = 0;
      if (blocks_left != 0) return at("task " + task->name + " has fewer blocks than it says");
      if (w.size() != 4 || !parse_u64(w[2], cycle) || !parse_u64(w[3], count)) {
        return at("expected 'task NAME CYCLE N_BLOCKS'");
      }
      s.tasks.push_back({w[1], cycle, {}});
      task = &s.tasks.back();
      blocks_left = count;
    } else if (w[0] == "block") {
      uint64_t count = 0;
      if (task == nullptr || blocks_left == 0) return at("a block outside a task");
      if (w.size() < 4 || !parse_u64(w[3], count) || w.size() != 4 + count) {
        return at("expected 'block NAME KIND N V1 .. VN'");
      }
      SavedBlock b{w[1], w[2], {}};
      b.values.resize(count);
      for (size_t k = 0; k < count; ++k) {
        if (!parse_double(w[4 + k], b.values[k])) return at("'" + w[4 + k] + "' is not a number");
      }
      task->blocks.push_back(std::move(b));
      --blocks_left;
    } else {
      return at("unexpected '" + w[0] + "'");
    }
  }
  if (blocks_left != 0) return bad("task " + task->name + " has fewer blocks than it says");
  return s;
}

Result<std::optional<SavedState>> load_state_file(const std::string& path) {
  // Plain POSIX reads: whatever sits at the path (a folder, a device, a huge
  // file) is an error that names it, never an exception.
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) {
    if (errno == ENOENT) return std::optional<SavedState>();
    return make_error("cannot read " + path + ": " + std::strerror(errno));
  }
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(fd);
    return make_error(path + ": not a regular file");
  }
  if (st.st_size > kMaxStateBytes) {
    close(fd);
    return make_error(path + ": " + std::to_string(st.st_size) +
                      " bytes, more than a state file can be");
  }
  std::string text(static_cast<size_t>(st.st_size), '\0');
  size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = read(fd, text.data() + got, text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<size_t>(n);
  }
  close(fd);
  text.resize(got);
  auto s = decode_state(text, path);
  if (!s) return make_error(s.error());
  return std::optional<SavedState>(std::move(s).value());
}

Result<void> save_state_file(const std::string& path, const SavedState& s) {
  return save_state_file(path, s.runtime, s.saved_unix_ms, refs_of(s));
}

Result<void> save_state_file(const std::string& path, std::string_view runtime, int64_t saved_unix_ms,
                             const std::vector<TaskStateRef>& tasks) {
  return write_file_atomically(path, 0640, [&](const FileSink& sink) {
    return encode_state_to(sink, runtime, saved_unix_ms, tasks);
  });
}

SavedTask saved_task(const std::string& task, const std::vector<RetainedBlock>& layout,
                     const std::vector<double>& data, uint64_t cycle) {
  SavedTask t{task, cycle, {}};
  t.blocks.reserve(layout.size());
  size_t i = 0;
  for (const RetainedBlock& rb : layout) {
    SavedBlock b{rb.name, std::string(rb.kind), {}};
    b.values.assign(data.begin() + static_cast<std::ptrdiff_t>(i),
                    data.begin() + static_cast<std::ptrdiff_t>(i + rb.width()));
    i += rb.width();
    t.blocks.push_back(std::move(b));
  }
  return t;
}

RestoreOutcome restore_task(const SavedTask& saved, const std::vector<RetainedBlock>& layout,
                            TaskArena& arena) {
  RestoreOutcome o;
  std::unordered_map<std::string_view, const SavedBlock*> by_name;
  for (const SavedBlock& b : saved.blocks) by_name.emplace(b.name, &b);
  for (const RetainedBlock& rb : layout) {
    auto it = by_name.find(rb.name);
    if (it == by_name.end()) {
      o.missing.push_back(rb.name);
      continue;
    }
    const SavedBlock& b = *it->second;
    if (b.kind != rb.kind || b.values.size() != rb.width()) {
      o.refused.push_back(rb.name + " (saved as " + b.kind + " with " +
                          std::to_string(b.values.size()) + " values, now " + std::string(rb.kind) + " with " +
                          std::to_string(rb.width()) + ")");
      continue;
    }
    size_t k = 0;
    if (rb.value != RetainedBlock::kNoValue) {
      for (uint32_t v = 0; v < rb.n_value; ++v) arena.values[rb.value + v] = b.values[k++];
      if (rb.n_value > 1) {
        // A string: a length within its cap and character codes, whatever the file said.
        double& len = arena.values[rb.value];
        len = len >= 0 ? std::min(std::floor(len), static_cast<double>(rb.n_value - 1)) : 0;
        for (uint32_t v = 1; v < rb.n_value; ++v) {
          double& c = arena.values[rb.value + v];
          c = c >= 0 && c <= 65535 ? std::floor(c) : 0;  // a byte, or a WSTRING's UTF-16 unit
        }
      }
    }
    for (uint32_t s = 0; s < rb.n_state; ++s) arena.state[rb.state + s] = b.values[k++];
    o.restored.push_back(rb.name);
  }
  std::unordered_map<std::string_view, bool> retained;
  for (const RetainedBlock& rb : layout) retained.emplace(rb.name, true);
  for (const SavedBlock& b : saved.blocks) {
    if (!retained.count(b.name)) o.dropped.push_back(b.name);
  }
  return o;
}

}  // namespace rtplc::sched
