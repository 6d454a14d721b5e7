// The web console's users file (see users.h).
#include "web/users.h"

#include <sodium.h>

#include <sstream>

#include "common/files.h"
#include "sched/runtime.h"

namespace rtplc::web {
namespace {

constexpr size_t kMaxFile = 1u << 20;

Result<void> sodium_ready() {
  if (sodium_init() < 0) return make_error("libsodium could not be initialised");
  return {};
}

Result<std::string> hash_of(const std::string& password) {
  if (auto r = sodium_ready(); !r) return make_error(r.error());
  char out[crypto_pwhash_STRBYTES];
  // Argon2id (libsodium's default for crypto_pwhash_str), interactive cost:
  // about 0.1 s and 64 MiB per login, which also throttles guessing.
  if (crypto_pwhash_str_alg(out, password.data(), password.size(), crypto_pwhash_OPSLIMIT_INTERACTIVE,
                            crypto_pwhash_MEMLIMIT_INTERACTIVE, crypto_pwhash_ALG_ARGON2ID13) != 0) {
    return make_error("cannot hash the password (out of memory)");
  }
  return std::string(out);
}

}  // namespace

bool UserFile::valid_name(const std::string& name) {
  if (name.empty() || name.size() > 32) return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-' || c == '.';
    if (!ok) return false;
  }
  return true;
}

Result<void> UserFile::acceptable_password(const std::string& password) {
  if (password.size() < 10) return make_error("a password needs at least 10 characters");
  if (password.size() > 1024) return make_error("a password of more than 1024 characters is refused");
  return {};
}

Result<std::vector<WebUser>> UserFile::load() const {
  auto text = read_file_bounded(path_, kMaxFile, FollowLinks::kNo);
  std::vector<WebUser> users;
  if (!text) {
    if (is_missing_file_error(text.error())) return users;
    return make_error(text.error());
  }
  std::istringstream in(*text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream words(line);
    WebUser u;
    std::string role, extra;
    words >> u.name >> role >> u.hash;
    const auto r = parse_role(role);
    if (!valid_name(u.name) || !r || u.hash.rfind("$argon2id$", 0) != 0 || (words >> extra)) {
      return make_error(path_ + ":" + std::to_string(n) + ": not a user line (NAME ROLE ARGON2ID-HASH); fix or "
                        "remove it with `rtplc web user del`");
    }
    u.role = *r;
    users.push_back(std::move(u));
  }
  return users;
}

Result<void> UserFile::save(const std::vector<WebUser>& users) const {
  std::string text = "# rtplc web users: NAME ROLE ARGON2ID-HASH (managed by `rtplc web user`)\n";
  for (const WebUser& u : users) text += u.name + " " + role_name(u.role) + " " + u.hash + "\n";
  if (auto r = make_folders(folder_of(path_), 0700, 0755); !r) return r;
  return write_file_atomically(path_, text, 0600);
}

Result<void> UserFile::add(const std::string& name, Role role, const std::string& password) {
  if (!valid_name(name)) return make_error("'" + name + "' is not a user name (1 to 32 letters, digits, '_', '-', '.')");
  if (auto r = acceptable_password(password); !r) return r;
  auto users = load();
  if (!users) return make_error(users.error());
  for (const WebUser& u : *users) {
    if (u.name == name) return make_error("user " + name + " exists; change the password with `rtplc web user passwd " + name + "`");
  }
  auto h = hash_of(password);
  if (!h) return make_error(h.error());
  users->push_back(WebUser{name, role, *h});
  return save(*users);
}

Result<void> UserFile::set_password(const std::string& name, const std::string& password) {
  if (auto r = acceptable_password(password); !r) return r;
  auto users = load();
  if (!users) return make_error(users.error());
  for (WebUser& u : *users) {
    if (u.name != name) continue;
    auto h = hash_of(password);
    if (!h) return make_error(h.error());
    u.hash = *h;
    return save(*users);
  }
  return make_error("no user " + name + " in " + path_);
}

Result<void> UserFile::remove(const std::string& name) {
  auto users = load();
  if (!users) return make_error(users.error());
  for (size_t i = 0; i < users->size(); ++i) {
    if ((*users)[i].name != name) continue;
    users->erase(users->begin() + static_cast<std::ptrdiff_t>(i));
    return save(*users);
  }
  return make_error("no user " + name + " in " + path_);
}

std::optional<Role> UserFile::check(const std::string& name, const std::string& password) const {
  if (!sodium_ready()) return std::nullopt;
  auto users = load();
  if (!users) return std::nullopt;
  for (const WebUser& u : *users) {
    if (u.name != name) continue;
    if (crypto_pwhash_str_verify(u.hash.c_str(), password.data(), password.size()) == 0) return u.role;
    return std::nullopt;
  }
  // As much work for an unknown name as for a wrong password: no user list by timing.
  char dummy[crypto_pwhash_STRBYTES];
  if (crypto_pwhash_str_alg(dummy, password.data(), password.size(), crypto_pwhash_OPSLIMIT_INTERACTIVE,
                            crypto_pwhash_MEMLIMIT_INTERACTIVE, crypto_pwhash_ALG_ARGON2ID13) != 0) {
    return std::nullopt;
  }
  return std::nullopt;
}

std::string default_users_path(const std::string& runtime_name) {
  return folder_of(sched::default_retain_path(runtime_name)) + "/" + runtime_name + ".web-users";
}

}  // namespace rtplc::web
