// The interpreter body built for AVX2 (four doubles per vector). Selected at
// start-up by executor.cpp when the CPU has AVX2; results are bit-identical to
// the baseline body (no FMA, no contraction).
#include <algorithm>
#include <atomic>
#include <bit>
#include <cfloat>
#include <cmath>

#include "blocks/executor.h"
#include "blocks/int_math.h"
#include "blocks/string_ops.h"

namespace rtplc::exec_avx2 {
#include "blocks/executor_body.inc"
}  // namespace rtplc::exec_avx2
