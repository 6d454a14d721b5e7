// Who may do what to a runtime (issue "values you can trust", item 4): the
// four roles of the operator API, each including the ones below it.
//   viewer    reads: status, values, statistics, the audit trail
//   operator  also sets set-points, within their limits
//   engineer  also forces, swaps, rolls back and traces
//   admin     also stops the runtime
// The runtime's owner (and root) is admin; others get the role the config's
// `runtime.operators` grants them (docs/api.md), or none and are refused.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace rtplc {

enum class Role : uint8_t { kNone = 0, kViewer, kOperator, kEngineer, kAdmin };

// "viewer", "operator", "engineer", "admin"; "none" for kNone.
const char* role_name(Role r);
// The inverse for the four granted roles ("none" is not a role one grants).
std::optional<Role> parse_role(std::string_view word);
inline bool role_allows(Role have, Role need) { return static_cast<uint8_t>(have) >= static_cast<uint8_t>(need); }

}  // namespace rtplc
