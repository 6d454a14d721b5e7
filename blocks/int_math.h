// The IEC integer rules on double-held values, shared by the executor's kernels
// (wrap, imul, round) and the compilers' constant folding, so a value folded at
// compile time is the one the task would compute (docs/language.md, "Types").
//
// An integer type of `bits` bits is described by m = 2^bits and `half`, where
// a value starts to read as negative: m/2 for a signed type, m for an unsigned
// one (the prepared parameters of `wrap` and `imul`).
//
// Every function here has internal linkage: the executor's body is compiled
// twice (baseline and AVX2), and one inline copy must not serve the other.
#pragma once

#include <cmath>
#include <cstdint>

namespace rtplc::int_math {

inline constexpr double kTwo53 = 9007199254740992.0;
inline constexpr double kTwo64 = 18446744073709551616.0;

// trunc(x) reduced modulo m into [half - m, half). fmod is exact; the additions
// are exact up to 2^53 (beyond, doubles cannot hold every integer).
[[gnu::always_inline]] static inline double wrap_whole(double x, double m, double half) {
  // Already in the type's range (nearly always): the same result without the
  // fmod, which costs tens of nanoseconds in a loop that wraps every step.
  const double t = std::trunc(x);
  if (t >= half - m && t < half) return t;
  const double r0 = std::fmod(t, m);
  const double r1 = r0 < 0.0 ? r0 + m : r0;
  const double r = r1 >= m ? r1 - m : r1;
  return r >= half ? r - m : r;
}

// A whole number |x| < 2^64 as its two's complement bit string modulo 2^64.
[[gnu::always_inline]] static inline uint64_t to_u64(double x) {
  return x >= 0.0 ? static_cast<uint64_t>(x) : 0ull - static_cast<uint64_t>(-x);
}

// trunc(a) * trunc(b) reduced modulo m into the type's range, computed in 64-bit
// integer arithmetic: exact whenever the operands are (every value of a type of
// at most 32 bits), where the double product rounds past 2^53 before any wrap
// (a UDINT linear congruential generator drifts from its first step). NaN when
// an operand is not a number below 2^64 or m is not a power of two in [2, 2^64]
// (a crafted image): the kernel then holds its output and counts an error.
[[gnu::always_inline]] static inline double wrapped_product(double a, double b, double m, double half) {
  const double x = std::trunc(a), y = std::trunc(b);
  if (!(std::fabs(x) < kTwo64 && std::fabs(y) < kTwo64 && m >= 2.0 && m <= kTwo64 && half <= m)) {
    return NAN;
  }
  const uint64_t mask = m >= kTwo64 ? ~0ull : static_cast<uint64_t>(m) - 1ull;
  const uint64_t r = (to_u64(x) * to_u64(y)) & mask;
  // A signed type: r >= half reads as r - m = -((mask - r) + 1), which fits.
  if (half < m && static_cast<double>(r) >= half) return -static_cast<double>((mask - r) + 1ull);
  return static_cast<double>(r);
}

// x rounded to the nearest whole number, an exact half to the even neighbour
// (2.5 -> 2, 3.5 -> 4, -2.5 -> -2): MatIEC's __real_round under REAL_TO_INT.
[[gnu::always_inline]] static inline double round_half_even(double x) {
  const double r = std::round(x);  // halves away from zero
  if (std::fabs(r - x) == 0.5) return 2.0 * std::round(x / 2.0);
  return r;
}

// s on the grid of 1/per seconds: round(s * per) / per, ties to even, as the
// blocks scale, round and div compute it.
[[gnu::always_inline]] static inline double snap_to(double s, double per) { return round_half_even(s * per) / per; }

// A TIME (held in seconds) on the nanosecond grid: the double nearest to a
// whole number of nanoseconds, as round(s * 1e9) / 1e9 computes it with the
// blocks scale, round and div. A TIME variable takes its value so, so sums of
// T#100ms reach T#1s exactly instead of drifting (exact below 2^53 ns, about
// 104 days). A DATE or DT (seconds since 1970) lands on the microsecond grid
// instead (lang/iec's time_grid): whole microseconds stay exact until 2255,
// nanoseconds since 1970 would not fit a double's 53 bits.
[[gnu::always_inline]] static inline double snap_time(double s) { return snap_to(s, 1e9); }

// m and half for a type of `bits` bits (1..64), as `wrap` prepares them.
static inline double type_modulus(int bits) { return std::ldexp(1.0, bits); }
static inline double type_half(int bits, bool is_signed) {
  return is_signed ? std::ldexp(1.0, bits - 1) : std::ldexp(1.0, bits);
}

}  // namespace rtplc::int_math
