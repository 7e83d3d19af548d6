#pragma once
/// Elementary functions that give the same bits in a scalar loop and over SIMD lanes (issue 63).
///
/// The C library's exp and expm1 are calls the vectoriser cannot turn into lanes, and its vector
/// variants (libmvec) round differently from the scalar ones: a law over lanes calling them would
/// give other bits than the same law row by row. These are plain arithmetic, integer shifts and
/// selects, with no branch and no table, so `#pragma omp simd` loops vectorise them and a scalar
/// call takes the very same operations (the build compiles without contraction into fused
/// multiply-adds, -ffp-contract=off).
///
/// Method (the classic one, e.g. Tang, ACM TOMS 15 (1989) 144 without the table):
///   x = k ln2 + r,  k = round(x / ln2),  |r| <= ln2 / 2  (Cody-Waite: ln2 = ln2_hi + ln2_lo, k ln2_hi exact)
///   e^r - 1 = r + r^2 (1/2! + r/3! + ... + r^11/13!)   (Taylor; truncation below 2^-60 of the result)
///   e^x = 2^k e^r,  e^x - 1 = 2^k (e^r - 1) + (2^k - 1)  (e^x itself for k > 60)
/// 2^k is built from the exponent bits in two factors 2^k1 2^k2 (k1 = round(k / 2)), so results down
/// into the subnormal range round once, and k is clamped so that x < -745.2 gives 0 and x > 709.8
/// gives +inf. Accuracy (tests/unit/test_lane_math.cpp, against the C library over -745..709): within
/// 2 units in the last place for exp; for expm1 within 2 units, or 1e-16 of |e^x - 1| near x = 0.
/// NaN gives NaN.
#include <bit>
#include <cstdint>

namespace sparkdem::lanemath {

/// e^x and e^x - 1 of one argument (one reduction serves both).
struct ExpAndExpm1 {
  double exp;
  double expm1;
};

/// 2^k for an integer-valued double k in [-1022, 1023], from the exponent bits.
[[gnu::always_inline]] inline double pow2_integer(double k) {
  constexpr double kShift = 0x1.8p52;  // k + kShift holds k in its low mantissa bits
  const std::uint64_t bits = std::bit_cast<std::uint64_t>(k + kShift);
  return std::bit_cast<double>((bits << 52) + std::bit_cast<std::uint64_t>(1.0));
}

[[gnu::always_inline]] inline ExpAndExpm1 exp_and_expm1(double x) {
  constexpr double kInvLn2 = 1.4426950408889634;          // 1 / ln 2
  constexpr double kLn2Hi = 6.93147180369123816490e-01;   // ln 2, upper 32 bits (k kLn2Hi is exact)
  constexpr double kLn2Lo = 1.90821492927058770002e-10;   // ln 2 - kLn2Hi
  constexpr double kShift = 0x1.8p52;                      // (y + kShift) - kShift rounds y to an integer
  // Taylor coefficients 1/n!, n = 2 .. 13
  constexpr double c2 = 1.0 / 2.0, c3 = 1.0 / 6.0, c4 = 1.0 / 24.0, c5 = 1.0 / 120.0, c6 = 1.0 / 720.0, c7 = 1.0 / 5040.0,
                   c8 = 1.0 / 40320.0, c9 = 1.0 / 362880.0, c10 = 1.0 / 3628800.0, c11 = 1.0 / 39916800.0,
                   c12 = 1.0 / 479001600.0, c13 = 1.0 / 6227020800.0;
  const double xc = x < -746.0 ? -746.0 : (x > 710.0 ? 710.0 : x);  // a NaN passes unchanged
  const double k = (xc * kInvLn2 + kShift) - kShift;
  const double r = (xc - k * kLn2Hi) - k * kLn2Lo;
  // q(r) = c2 + c3 r + ... + c13 r^11 by Estrin's scheme (pairs, then powers r^2, r^4, r^8): a chain of
  // five dependent operations instead of Horner's 22, for the row-by-row path, whose rows wait on it.
  const double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const double p01 = (c2 + c3 * r) + (c4 + c5 * r) * r2, p23 = (c6 + c7 * r) + (c8 + c9 * r) * r2;
  const double p45 = (c10 + c11 * r) + (c12 + c13 * r) * r2;
  const double q = (p01 + p23 * r4) + p45 * r8;
  const double em1 = r + r2 * q;  // e^r - 1
  const double k1 = (k * 0.5 + kShift) - kShift;
  const double s1 = pow2_integer(k1), s2 = pow2_integer(k - k1);
  const double e = (s1 * (1.0 + em1)) * s2;
  // Beyond k = 60, e^x - 1 rounds to e^x (and 2^k - 1 would overflow first at k = 1024).
  return {e, k > 60.0 ? e : (s1 * em1) * s2 + (s1 * s2 - 1.0)};
}

/// e^x (exp_and_expm1's first value).
[[gnu::always_inline]] inline double exp(double x) { return exp_and_expm1(x).exp; }

}  // namespace sparkdem::lanemath
