// The runtime's store of the programs its tasks run (see program_store.h).
// Manifest format, one version per line, oldest first within a task:
//   TASK <tab> HASH <tab> REALTIME_NS <tab> ORIGIN
#include "sched/program_store.h"
#include "kernel_rt/clock.h"

#include <sys/stat.h>

#include <cinttypes>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "blocks/image.h"
#include "common/files.h"
#include "lang/compiler.h"

namespace rtplc::sched {
namespace {

const std::vector<ProgramVersion> kNone;
// A manifest line is about 80 bytes; a store keeps a bounded history per task.
constexpr size_t kMaxManifestBytes = size_t{16} << 20;

bool is_hash(const std::string& h) {
  if (h.size() != 16) return false;
  for (char c : h) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

}  // namespace

std::string ProgramStore::hash_of(const std::string& source) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, fnv1a64(source));
  return buf;
}

Result<void> ProgramStore::load() {
  versions_.clear();
  // The store decides what a task boots with: read it without following
  // links (a link planted in the state folder must not choose our program).
  Result<std::string> manifest =
      read_file_bounded(dir_ + "/programs.manifest", kMaxManifestBytes, FollowLinks::kNo);
  if (!manifest) {
    if (is_missing_file_error(manifest.error())) return {};
    return make_error(manifest.error());
  }
  std::istringstream in(*manifest);
  std::string line;
  size_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream f(line);
    ProgramVersion v;
    std::string task, when;
    if (!std::getline(f, task, '\t') || !std::getline(f, v.hash, '\t') || !std::getline(f, when, '\t') ||
        !std::getline(f, v.origin) || task.empty() || !is_hash(v.hash)) {
      versions_.clear();
      return make_error(dir_ + "/programs.manifest:" + std::to_string(n) + ": not a program record");
    }
    v.realtime_ns = std::strtoll(when.c_str(), nullptr, 10);
    versions_[task].push_back(std::move(v));
  }
  return {};
}

std::optional<ProgramVersion> ProgramStore::current(const std::string& task) const {
  auto it = versions_.find(task);
  if (it == versions_.end() || it->second.empty()) return std::nullopt;
  return it->second.back();
}

const std::vector<ProgramVersion>& ProgramStore::history(const std::string& task) const {
  auto it = versions_.find(task);
  return it == versions_.end() ? kNone : it->second;
}

Result<std::string> ProgramStore::source(const std::string& hash) const {
  if (!is_hash(hash)) return make_error("'" + hash + "' is not a program hash");
  const std::string path = dir_ + "/" + hash + ".prog";
  Result<std::string> read = read_file_bounded(path, lang::kMaxSourceBytes, FollowLinks::kNo);
  if (!read) {
    if (is_missing_file_error(read.error())) return make_error("the stored program " + path + " is missing");
    return make_error("the stored program " + read.error());
  }
  std::string text = std::move(read).value();
  if (hash_of(text) != hash) return make_error("the stored program " + path + " is damaged (its hash differs)");
  return text;
}

Result<ProgramVersion> ProgramStore::push(const std::string& task, const std::string& text, std::string origin) {
  ProgramVersion v;
  v.hash = hash_of(text);
  v.realtime_ns = kernel_rt::realtime_now_ns();
  for (char& c : origin) {
    if (c == '\t' || c == '\n') c = ' ';
  }
  v.origin = std::move(origin);
  const std::string path = dir_ + "/" + v.hash + ".prog";
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) {
    if (auto r = write_file_atomically(path, text, 0640); !r) return make_error(r.error());
  }
  std::vector<ProgramVersion>& h = versions_[task];
  h.push_back(v);
  if (h.size() > kHistory) h.erase(h.begin(), h.end() - kHistory);
  if (auto r = save(); !r) {
    h.pop_back();
    return make_error(r.error());
  }
  return v;
}

Result<void> ProgramStore::pop(const std::string& task) {
  auto it = versions_.find(task);
  if (it == versions_.end() || it->second.empty()) return {};
  const ProgramVersion dropped = it->second.back();
  it->second.pop_back();
  if (auto r = save(); !r) {
    it->second.push_back(dropped);
    return r;
  }
  return {};
}

Result<void> ProgramStore::save() const {
  std::string text = "# rtplc: the programs each task runs, oldest first (TASK HASH TIME ORIGIN)\n";
  for (const auto& [task, versions] : versions_) {
    for (const ProgramVersion& v : versions) {
      text += task + "\t" + v.hash + "\t" + std::to_string(v.realtime_ns) + "\t" + v.origin + "\n";
    }
  }
  return write_file_atomically(dir_ + "/programs.manifest", text, 0640);
}

}  // namespace rtplc::sched
