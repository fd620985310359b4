// Elementary functions written so that the compiler can vectorize the loops
// that call them (libm's exp is an opaque call that keeps a loop scalar), and
// a small lane type for loops whose vectorization the compiler does not find
// by itself (GCC/Clang vector extensions: eight floats, one AVX register or
// two SSE ones, chosen by the compiler for the target).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

// Included by kernels.cpp, which is compiled once per instruction set
// (vertex_kernels.h): each compilation names its own namespace, so that the linker
// never merges one level's copy of these inline functions with another's.
#ifndef ORGANSIM_KERNEL_LEVEL
#define ORGANSIM_KERNEL_LEVEL generic
#endif

namespace organsim::vertex_kernels {
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

/// Doubles as many as one register holds, so that the normals kernel's
/// dozen live vectors stay in registers (8 with AVX-512's 32 registers; 4
/// with AVX2's 16; 2 with SSE2).
#if defined(__AVX512F__)
constexpr std::size_t kDoubleLanes = 8;
#elif defined(__AVX2__)
constexpr std::size_t kDoubleLanes = 4;
#else
constexpr std::size_t kDoubleLanes = 2;
#endif
using DoubleLanes = double __attribute__((vector_size(kDoubleLanes * sizeof(double))));
static_assert(kLanes % kDoubleLanes == 0);

/// The x (or, from values + 1, y; values + 2, z) of the points
/// offset[l] / 16 of an xyz array in lane l, for kDoubleLanes offsets (as
/// organ::Organ::ring_rows holds them). AVX2's gather instruction is not used:
/// on the development machine (Sapphire Rapids class) it made the normals
/// kernel 25 % slower than four loads.
inline DoubleLanes gather(const double* values, const std::uint32_t* offset) noexcept {
#if defined(__AVX512F__)
  LaneIntegers lanes;
  std::memcpy(&lanes, offset, sizeof lanes);
  lanes = (lanes >> 4) * 3;  // offsets < 2³², so the shift's sign bit is 0
  // The masked form with every lane on: the plain one merges into an
  // "undefined" register that GCC 12 warns about.
  return __builtin_bit_cast(
      DoubleLanes, _mm512_mask_i32gather_pd(_mm512_setzero_pd(), 0xff, __builtin_bit_cast(__m256i, lanes), values, 8));
#else
  DoubleLanes lanes;
  for (std::size_t l = 0; l < kDoubleLanes; ++l) lanes[l] = values[3 * static_cast<std::size_t>(offset[l] >> 4)];
  return lanes;
#endif
}

inline Lanes square_root(Lanes v) noexcept {
#if defined(__AVX__)
  return __builtin_bit_cast(Lanes, _mm256_sqrt_ps(__builtin_bit_cast(__m256, v)));
#elif defined(__SSE2__)
  const __m128 low = _mm_sqrt_ps(__builtin_shufflevector(v, v, 0, 1, 2, 3));
  const __m128 high = _mm_sqrt_ps(__builtin_shufflevector(v, v, 4, 5, 6, 7));
  return __builtin_shufflevector(low, high, 0, 1, 2, 3, 4, 5, 6, 7);
#else
  Lanes root;
  for (std::size_t l = 0; l < kLanes; ++l) root[l] = __builtin_sqrtf(v[l]);
  return root;
#endif
}

/// Each lane of v clamped to [low, high] (one instruction each way; the
/// comparisons the vector extensions offer cost a blend too).
inline Lanes clamp_lanes(Lanes v, float low, float high) noexcept {
#if defined(__AVX__)
  const __m256 above = _mm256_max_ps(__builtin_bit_cast(__m256, v), _mm256_set1_ps(low));
  return __builtin_bit_cast(Lanes, _mm256_min_ps(above, _mm256_set1_ps(high)));
#elif defined(__SSE2__)
  const __m128 low_half =
      _mm_min_ps(_mm_max_ps(__builtin_shufflevector(v, v, 0, 1, 2, 3), _mm_set1_ps(low)), _mm_set1_ps(high));
  const __m128 high_half =
      _mm_min_ps(_mm_max_ps(__builtin_shufflevector(v, v, 4, 5, 6, 7), _mm_set1_ps(low)), _mm_set1_ps(high));
  return __builtin_shufflevector(low_half, high_half, 0, 1, 2, 3, 4, 5, 6, 7);
#else
  Lanes clamped;
  for (std::size_t l = 0; l < kLanes; ++l) clamped[l] = v[l] < low ? low : (v[l] > high ? high : v[l]);
  return clamped;
#endif
}
/// Each lane of v, or 0 where it is negative.
inline Lanes positive_part(Lanes v) noexcept {
#if defined(__AVX__)
  return __builtin_bit_cast(Lanes, _mm256_max_ps(__builtin_bit_cast(__m256, v), _mm256_setzero_ps()));
#elif defined(__SSE2__)
  const __m128 low_half = _mm_max_ps(__builtin_shufflevector(v, v, 0, 1, 2, 3), _mm_setzero_ps());
  const __m128 high_half = _mm_max_ps(__builtin_shufflevector(v, v, 4, 5, 6, 7), _mm_setzero_ps());
  return __builtin_shufflevector(low_half, high_half, 0, 1, 2, 3, 4, 5, 6, 7);
#else
  Lanes part;
  for (std::size_t l = 0; l < kLanes; ++l) part[l] = v[l] > 0.0f ? v[l] : 0.0f;
  return part;
#endif
}

inline DoubleLanes square_root(DoubleLanes v) noexcept {
#if defined(__AVX512F__)
  return __builtin_bit_cast(DoubleLanes,
                            _mm512_maskz_sqrt_pd(0xff, __builtin_bit_cast(__m512d, v)));  // maskz: see gather()
#elif defined(__AVX2__)
  return __builtin_bit_cast(DoubleLanes, _mm256_sqrt_pd(__builtin_bit_cast(__m256d, v)));
#elif defined(__SSE2__)
  return __builtin_bit_cast(DoubleLanes, _mm_sqrt_pd(__builtin_bit_cast(__m128d, v)));
#else
  return DoubleLanes{__builtin_sqrt(v[0]), __builtin_sqrt(v[1])};
#endif
}

/// Vertices packed as x, y, z, 0 in single precision (16 bytes each, one
/// load), two to a register with AVX, AVX-512 included (the normals kernel is
/// bound by its loads, not by the register's width), else one.
#if defined(__AVX__)
constexpr std::size_t kPackedVertices = 2;
#else
constexpr std::size_t kPackedVertices = 1;
#endif
using PackedLanes = float __attribute__((vector_size(kPackedVertices * 4 * sizeof(float))));
using Quad = float __attribute__((vector_size(4 * sizeof(float))));  ///< one packed vertex
static_assert(kLanes % kPackedVertices == 0);

/// The packed points at byte offsets offset[0 .. kPackedVertices) of `packed`.
inline PackedLanes load_packed(const float* packed, const std::uint32_t* offset) noexcept {
  Quad q[kPackedVertices];
  for (std::size_t k = 0; k < kPackedVertices; ++k)
    std::memcpy(&q[k], reinterpret_cast<const char*>(packed) + offset[k], sizeof q[k]);
#if defined(__AVX__)
  return __builtin_shufflevector(q[0], q[1], 0, 1, 2, 3, 4, 5, 6, 7);
#else
  return q[0];
#endif
}

/// kPackedVertices consecutive packed points from `first` on.
inline PackedLanes load_packed_run(const float* first) noexcept {
  PackedLanes lanes;
  std::memcpy(&lanes, first, sizeof lanes);
  return lanes;
}

/// Each vertex's (y, z, x, 0): a × b = yzx(a ∘ yzx(b) − yzx(a) ∘ b).
inline PackedLanes yzx(PackedLanes v) noexcept {
#if defined(__AVX__)
  return __builtin_shufflevector(v, v, 1, 2, 0, 3, 5, 6, 4, 7);
#else
  return __builtin_shufflevector(v, v, 1, 2, 0, 3);
#endif
}

/// The packed vertices of kLanes consecutive vertices.
constexpr std::size_t kPackedSlices = kLanes / kPackedVertices;
using PackedGroup = PackedLanes[kPackedSlices];

/// Scales each packed vertex of the group to unit length (a zero vector
/// stays zero): the squared lengths are gathered into one register, so that
/// the group costs one square root and one division.
inline void normalize(PackedGroup& group) noexcept {
  PackedLanes squared_in[kPackedSlices];  // each vertex's squared length in its lanes 0–2
  for (std::size_t k = 0; k < kPackedSlices; ++k) {
    const PackedLanes t = group[k] * group[k];
    squared_in[k] = t + yzx(t) + yzx(yzx(t));
  }
#if defined(__AVX__)
  const Quad low = __builtin_shufflevector(squared_in[0], squared_in[1], 0, 4, 8, 12);
  const Quad high = __builtin_shufflevector(squared_in[2], squared_in[3], 0, 4, 8, 12);
  const Lanes squared = __builtin_shufflevector(low, high, 0, 1, 2, 3, 4, 5, 6, 7);
#else
  Lanes squared;
  for (std::size_t k = 0; k < kPackedSlices; ++k) squared[k] = squared_in[k][0];
#endif
  const Lanes inverse = 1.0f / square_root(squared);  // ∞ where 0: not taken
  const Lanes scale = squared > 0.0f ? inverse : Lanes{};
#if defined(__AVX__)
  group[0] *= __builtin_shufflevector(scale, scale, 0, 0, 0, 0, 1, 1, 1, 1);
  group[1] *= __builtin_shufflevector(scale, scale, 2, 2, 2, 2, 3, 3, 3, 3);
  group[2] *= __builtin_shufflevector(scale, scale, 4, 4, 4, 4, 5, 5, 5, 5);
  group[3] *= __builtin_shufflevector(scale, scale, 6, 6, 6, 6, 7, 7, 7, 7);
#else
  for (std::size_t k = 0; k < kPackedSlices; ++k) group[k] *= scale[k];
#endif
}

/// The vertex k of v (its x, y, z, 0).
inline Quad packed_vertex(PackedLanes v, std::size_t k) noexcept {
  Quad quad;
  std::memcpy(&quad, reinterpret_cast<const char*>(&v) + sizeof quad * k, sizeof quad);
  return quad;
}

/// Stores the packed points of v as x, y, z doubles from `out` on, 3 per
/// point, plus a fourth double after the last point's z (the caller
/// overwrites it with the next point, or out has room).
inline void store_as_doubles(double* out, PackedLanes v) noexcept {
#if defined(__AVX__)
  const __m256 both = __builtin_bit_cast(__m256, v);
  _mm256_storeu_pd(out, _mm256_cvtps_pd(_mm256_castps256_ps128(both)));
  _mm256_storeu_pd(out + 3, _mm256_cvtps_pd(_mm256_extractf128_ps(both, 1)));
#elif defined(__SSE2__)
  const __m128 point = __builtin_bit_cast(__m128, v);
  _mm_storeu_pd(out, _mm_cvtps_pd(point));
  _mm_storeu_pd(out + 2, _mm_cvtps_pd(_mm_movehl_ps(point, point)));
#else
  for (std::size_t k = 0; k < kPackedVertices; ++k)
    for (std::size_t c = 0; c < 4; ++c) out[3 * k + c] = v[4 * k + c];
#endif
}

/// Whether any lane of a comparison's result (all bits set or none per lane) is set.
inline bool any_lane(LaneIntegers mask) noexcept {
#if defined(__AVX__)
  __m256i bits;
  std::memcpy(&bits, &mask, sizeof bits);
  return _mm256_testz_si256(bits, bits) == 0;
#elif defined(__SSE2__)
  __m128i low, high;
  std::memcpy(&low, &mask, sizeof low);
  std::memcpy(&high, reinterpret_cast<const char*>(&mask) + sizeof low, sizeof high);
  return _mm_movemask_epi8(_mm_or_si128(low, high)) != 0;
#else
  std::uint64_t quarters[4];
  std::memcpy(quarters, &mask, sizeof quarters);
  return (quarters[0] | quarters[1] | quarters[2] | quarters[3]) != 0;
#endif
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
}  // namespace organsim::vertex_kernels
