// Picks the widest compiled kernel set (vertex_kernels.h) that this CPU runs.
#include "organsim/vertex_kernels/vertex_kernels.h"

#include <cstdlib>
#include <cstring>

namespace organsim::vertex_kernels {

// The levels the build compiled kernels.cpp for: x86-64-v4, v3 and the
// baseline in the portable x86-64 build (ORGANSIM_KERNELS_PER_LEVEL), else one
// for the target.
#define ORGANSIM_DECLARE_LEVEL(level)                                                             \
  namespace level {                                                                               \
  void build_weights(const WeightJob& job, std::size_t first, std::size_t last) noexcept;         \
  void distort(const DistortionJob& job, std::size_t first, std::size_t last) noexcept;           \
  void normals(const NormalsJob& job, std::size_t first, std::size_t last) noexcept;              \
  void packed_normals(const PackedNormalsJob& job, std::size_t first, std::size_t last) noexcept; \
  }
#if defined(ORGANSIM_KERNELS_PER_LEVEL)
ORGANSIM_DECLARE_LEVEL(x86_64_v4)
ORGANSIM_DECLARE_LEVEL(x86_64_v3)
ORGANSIM_DECLARE_LEVEL(x86_64_v1)
#else
ORGANSIM_DECLARE_LEVEL(native)
#endif
#undef ORGANSIM_DECLARE_LEVEL

RunnableSets runnable() noexcept {
  RunnableSets sets{};
#if defined(ORGANSIM_KERNELS_PER_LEVEL)
  __builtin_cpu_init();
#if defined(__clang__)
  const bool v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi2");
  const bool v4 = v3 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                  __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl") &&
                  __builtin_cpu_supports("avx512cd");
#else
  const bool v4 = __builtin_cpu_supports("x86-64-v4");
  const bool v3 = __builtin_cpu_supports("x86-64-v3");
#endif
  if (v4)
    sets.set[sets.count++] = {"x86-64-v4", x86_64_v4::build_weights, x86_64_v4::distort, x86_64_v4::normals,
                              x86_64_v4::packed_normals};
  if (v3)
    sets.set[sets.count++] = {"x86-64-v3", x86_64_v3::build_weights, x86_64_v3::distort, x86_64_v3::normals,
                              x86_64_v3::packed_normals};
  sets.set[sets.count++] = {"x86-64", x86_64_v1::build_weights, x86_64_v1::distort, x86_64_v1::normals,
                            x86_64_v1::packed_normals};
#else
  sets.set[sets.count++] = {"native", native::build_weights, native::distort, native::normals, native::packed_normals};
#endif
  return sets;
}

const KernelSet& selected() noexcept {
  // ORGANSIM_SIMD=x86-64-v3 (or x86-64) caps the level, so that a machine
  // with AVX-512 measures what one with AVX2 only (or SSE2) gets.
  static const KernelSet set = [] {
    const RunnableSets sets = runnable();
    const char* cap = std::getenv("ORGANSIM_SIMD");
    for (std::size_t i = 0; cap != nullptr && i < sets.count; ++i)
      if (std::strcmp(sets.set[i].level, cap) == 0) return sets.set[i];
    return sets.set[0];
  }();
  return set;
}

}  // namespace organsim::vertex_kernels
