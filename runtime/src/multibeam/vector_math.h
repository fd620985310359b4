// Elementary functions written so that the compiler can vectorize the loops
// that call them (libm's exp is an opaque call that keeps a loop scalar), and
// a small lane type for loops whose vectorization the compiler does not find
// by itself (GCC/Clang vector extensions: eight floats, one AVX register or
// two SSE ones, chosen by the compiler for the target).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__AVX512VL__)
#include <immintrin.h>
#endif

// Included by kernels.cpp, which is compiled once per instruction set
// (kernels.h): each compilation names its own namespace, so that the linker
// never merges one level's copy of these inline functions with another's.
#ifndef ORGANSIM_KERNEL_LEVEL
#define ORGANSIM_KERNEL_LEVEL generic
#endif

namespace organsim::multibeam {
inline namespace ORGANSIM_KERNEL_LEVEL {

constexpr std::size_t kLanes = 8;
using Lanes = float __attribute__((vector_size(kLanes * sizeof(float))));
using LaneIntegers = std::int32_t __attribute__((vector_size(kLanes * sizeof(std::int32_t))));

inline Lanes load_lanes(const float* values) noexcept {
  Lanes lanes;
  std::memcpy(&lanes, values, sizeof lanes);
  return lanes;
}
inline void store_lanes(float* values, Lanes lanes) noexcept { std::memcpy(values, &lanes, sizeof lanes); }
// A shuffle of lane 0 rather than `Lanes{} + value` (which costs an
// addition: 0 + x is not x for x = −0).
static_assert(kLanes == 8);
inline Lanes splat(float v) noexcept {
  const Lanes first{v};
  return __builtin_shufflevector(first, first, 0, 0, 0, 0, 0, 0, 0, 0);
}
inline LaneIntegers splat_integer(std::int32_t v) noexcept {
  const LaneIntegers first{v};
  return __builtin_shufflevector(first, first, 0, 0, 0, 0, 0, 0, 0, 0);
}

/// A point or vector of R³ in one register: (x, y, z, w), w unspecified.
using Xyz = double __attribute__((vector_size(4 * sizeof(double))));
/// Point i of an xyz-interleaved array in one register. Lane w is 0 with
/// AVX-512; otherwise it is the next point's x (one 32-byte load instead of
/// three, where a next point exists: i < last) or 0. Callers ignore lane w.
inline Xyz load_xyz(const double* points, std::uint32_t i, std::uint32_t last) noexcept {
  const double* p = points + 3 * static_cast<std::size_t>(i);
#if defined(__AVX512VL__)
  (void)last;
  return _mm256_maskz_loadu_pd(0x7, p);  // one load; the masked lane is not read (no fault past the end)
#else
  Xyz v;
  if (i < last) {
    std::memcpy(&v, p, sizeof v);
  } else {
    v = Xyz{p[0], p[1], p[2], 0.0};
  }
  return v;
#endif
}
/// (y, z, x, 0): a × b = yzx(a ∘ yzx(b) − yzx(a) ∘ b).
inline Xyz yzx(Xyz v) noexcept { return __builtin_shufflevector(v, v, 1, 2, 0, 3); }

/// Whether every lane of v equals value.
inline bool all_equal(LaneIntegers v, std::int32_t value) noexcept {
  const LaneIntegers differs = v != splat_integer(value);
  std::uint64_t halves[4];
  std::memcpy(halves, &differs, sizeof halves);
  return (halves[0] | halves[1] | halves[2] | halves[3]) == 0;
}

inline std::int32_t horizontal_min(LaneIntegers v) noexcept {
  LaneIntegers w = __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
  v = w < v ? w : v;
  w = __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5);
  v = w < v ? w : v;
  w = __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6);
  v = w < v ? w : v;
  return v[0];
}
inline std::int32_t horizontal_max(LaneIntegers v) noexcept {
  LaneIntegers w = __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
  v = w > v ? w : v;
  w = __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5);
  v = w > v ? w : v;
  w = __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6);
  v = w > v ? w : v;
  return v[0];
}

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
  y = y < -700.0 ? -700.0 : y;
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

}  // namespace ORGANSIM_KERNEL_LEVEL
}  // namespace organsim::multibeam
