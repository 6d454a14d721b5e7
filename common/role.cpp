// Role names (see role.h).
#include "common/role.h"

namespace rtplc {

const char* role_name(Role r) {
  switch (r) {
    case Role::kViewer: return "viewer";
    case Role::kOperator: return "operator";
    case Role::kEngineer: return "engineer";
    case Role::kAdmin: return "admin";
    case Role::kNone: break;
  }
  return "none";
}

std::optional<Role> parse_role(std::string_view word) {
  for (Role r : {Role::kViewer, Role::kOperator, Role::kEngineer, Role::kAdmin}) {
    if (word == role_name(r)) return r;
  }
  return std::nullopt;
}

}  // namespace rtplc
