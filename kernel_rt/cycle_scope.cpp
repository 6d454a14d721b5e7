// The cycle marker (see cycle_scope.h).
#include "kernel_rt/cycle_scope.h"

namespace rtplc::kernel_rt {
namespace {
thread_local int cycle_depth = 0;
}  // namespace

bool in_cycle() noexcept { return cycle_depth > 0; }
CycleScope::CycleScope() noexcept { ++cycle_depth; }
CycleScope::~CycleScope() { --cycle_depth; }

}  // namespace rtplc::kernel_rt
