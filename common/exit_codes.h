// Exit codes shared by every rtplc subcommand, the app's own and those a driver
// kind adds (io/drivers/<kind>/cli.cpp).
#pragma once

namespace rtplc {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // the work failed (compile errors, peer refused, ...)
inline constexpr int kExitUsage = 2;    // bad command line

}  // namespace rtplc
