// The knot terms of the distortion's per-element records (vertex_kernels.h).
#include "organsim/vertex_kernels/vertex_kernels.h"

namespace organsim::vertex_kernels {

void add_knot_terms(float* records, std::uint32_t stations) noexcept {
  for (std::uint32_t e = 0; e < stations; ++e) {
    float* c = records + static_cast<std::size_t>(e) * kCoefficients;
    float* knot = c + kPolynomialCoefficients;
    if (e + 1 == stations) {
      for (std::uint32_t k = 0; k < kCoefficients - kPolynomialCoefficients; ++k) knot[k] = 0.0f;
      continue;
    }
    const float* d = c + kCoefficients;
    for (int k = 0; k < 3; ++k) {
      // This element's cubic at ξ = 1 + s in powers of s: Σc + (c1 + 2c2 + 3c3) s + (c2 + 3c3) s² + c3 s³.
      const double c1 = c[3 + k], c2 = c[6 + k], c3 = c[9 + k];
      knot[k] = static_cast<float>(d[3 + k] - (c1 + 2.0 * c2 + 3.0 * c3));
      knot[3 + k] = static_cast<float>(d[6 + k] - (c2 + 3.0 * c3));
      knot[6 + k] = static_cast<float>(d[9 + k] - c3);
      knot[9 + k] = static_cast<float>(static_cast<double>(d[15 + k]) - c[15 + k]);
    }
  }
}

}  // namespace organsim::vertex_kernels
