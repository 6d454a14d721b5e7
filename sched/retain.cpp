// Atomic retain file (see retain.h).
#include "sched/retain.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "common/files.h"

namespace rtplc::sched {
Result<void> RetainStore::load() {
  values_.clear();
  // Retained values go straight into the plant's set-points: never read
  // through a link someone planted where the retain file belongs.
  Result<std::string> text = read_file_bounded(path_, size_t{16} << 20, FollowLinks::kNo);
  if (!text) {
    if (is_missing_file_error(text.error())) return {};
    return make_error(text.error());
  }
  std::istringstream f(*text);
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string label, value, extra;
    if (!(ls >> label >> value) || (ls >> extra)) {
      return make_error(path_ + ":" + std::to_string(n) + ": expected 'LABEL VALUE'");
    }
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (*end != '\0' || !std::isfinite(v)) {
      return make_error(path_ + ":" + std::to_string(n) + ": '" + value + "' is not a number");
    }
    values_[label] = v;
  }
  return {};
}

Result<void> RetainStore::save() const {
  std::string text = "# rtplc retained values: LABEL VALUE per line, replaced atomically by the runtime\n";
  char buf[64];
  for (const auto& [label, v] : values_) {
    std::snprintf(buf, sizeof buf, "%.17g", v);
    text += label + " " + buf + "\n";
  }
  return write_file_atomically(path_, text, 0640);
}

}  // namespace rtplc::sched
