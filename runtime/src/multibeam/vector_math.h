// Elementary functions written so that the compiler can vectorize the loops
// that call them (libm's exp is an opaque call that keeps a loop scalar).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace organsim::multibeam {

/// e^y for y ≤ 0, relative error below 2·10⁻¹⁵; exactly 1 at y = 0; y below
/// −700 is taken as −700 (e^−700 ≈ 10⁻³⁰⁴). Cody–Waite reduction y = n ln 2 + r,
/// |r| ≤ ln2/2, then the degree-13 Taylor polynomial of e^r and 2^n built in
/// the exponent bits. No branches, so loops calling it vectorize.
inline double exp_nonpositive(double y) noexcept {
  constexpr double kLn2High = 0.693147180369123816490;  // ln 2 split so that n·kLn2High is exact
  constexpr double kLn2Low = 1.90821492927058770002e-10;
  constexpr double kInvLn2 = 1.44269504088896338700;
  // Round y / ln 2 to the nearest integer n by adding 1.5·2⁵²: the sum's low
  // mantissa bits then hold n (two's complement), and subtracting it back gives n.
  constexpr double kShift = 6755399441055744.0;  // 1.5 · 2⁵²
  constexpr std::uint64_t kShiftBits = 0x4338000000000000;
  y = std::max(y, -700.0);
  const double shifted = y * kInvLn2 + kShift;
  const double nd = shifted - kShift;
  std::uint64_t shifted_bits;
  std::memcpy(&shifted_bits, &shifted, sizeof shifted_bits);
  const double r = (y - nd * kLn2High) - nd * kLn2Low;
  double p = 1.0 / 6227020800.0;  // 1/13!
  p = p * r + 1.0 / 479001600.0;
  p = p * r + 1.0 / 39916800.0;
  p = p * r + 1.0 / 3628800.0;
  p = p * r + 1.0 / 362880.0;
  p = p * r + 1.0 / 40320.0;
  p = p * r + 1.0 / 5040.0;
  p = p * r + 1.0 / 720.0;
  p = p * r + 1.0 / 120.0;
  p = p * r + 1.0 / 24.0;
  p = p * r + 1.0 / 6.0;
  p = p * r + 0.5;
  p = p * r + 1.0;
  p = p * r + 1.0;
  const std::uint64_t bits = (shifted_bits - kShiftBits + 1023) << 52;  // 2^n: n + 1023 ≥ 13 for y ≥ −700
  double scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return p * scale;
}

}  // namespace organsim::multibeam
