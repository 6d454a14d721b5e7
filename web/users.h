// The web console's users (issue "operator's console", item 3): one file the
// runtime's owner manages with `rtplc web user add|del|list|passwd`, one line
// per user: NAME ROLE HASH, HASH libsodium's Argon2id string (salt and cost
// inside it). Mode 0600, written atomically, read without following links.
// There is no default account; the owner's one-time login link needs none.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/result.h"
#include "common/role.h"

namespace rtplc::web {

struct WebUser {
  std::string name;
  Role role = Role::kViewer;
  std::string hash;  // "$argon2id$v=19$m=...,t=...,p=1$..."
};

class UserFile {
 public:
  explicit UserFile(std::string path) : path_(std::move(path)) {}
  const std::string& path() const { return path_; }

  // The users on file; none when the file does not exist yet.
  Result<std::vector<WebUser>> load() const;
  // Adds a user (refuses one that exists), replaces a password, removes one.
  Result<void> add(const std::string& name, Role role, const std::string& password);
  Result<void> set_password(const std::string& name, const std::string& password);
  Result<void> remove(const std::string& name);
  // The user's role when `password` is theirs; nullopt otherwise (also for an
  // unknown user, after as much work as for a known one).
  std::optional<Role> check(const std::string& name, const std::string& password) const;

  // 1 to 32 letters, digits, '_', '-', '.'.
  static bool valid_name(const std::string& name);
  // At least 10 characters: a console that can force outputs deserves one.
  static Result<void> acceptable_password(const std::string& password);

 private:
  Result<void> save(const std::vector<WebUser>& users) const;
  std::string path_;
};

// The users file of runtime `name`: beside its retain file in its state folder.
std::string default_users_path(const std::string& runtime_name);

}  // namespace rtplc::web
