#include <cmath>

#include <gtest/gtest.h>

#include "vector_math.h"

namespace organsim::vertex_kernels {
namespace {

TEST(VectorMath, ExpMatchesLibmToTwoUlpsOverTheAttenuationRange) {
  double worst = 0.0;
  for (int i = 0; i <= 700000; ++i) {
    const double y = -i * 1e-3;
    const double expected = std::exp(y);
    worst = std::max(worst, std::abs(exp_nonpositive(y) - expected) / expected);
  }
  EXPECT_LT(worst, 4.5e-16);
  EXPECT_EQ(exp_nonpositive(0.0), 1.0);  // the action point moves by exactly the tool displacement
  EXPECT_EQ(exp_nonpositive(-1e-300), 1.0);
  EXPECT_NEAR(exp_nonpositive(-800.0), std::exp(-700.0), 1e-310);  // clamped, never NaN or denormal garbage
}

}  // namespace
}  // namespace organsim::vertex_kernels
