// The power-law fit shared by `organsim plot` and `calibrate --evaluate`
// (tools/power_law/power_law.h): exact on an exact power law, R² below 1 by the
// amount the scatter leaves unexplained, and bad data refused by name.
#include "power_law/power_law.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace organsim::plot {
namespace {

TEST(PowerLaw, AnExactPowerLawIsFoundExactlyAndExplainsEverything) {
  const std::vector<double> x{1.0, 2.0, 5.0, 10.0, 30.0};
  std::vector<double> y;
  for (double v : x) y.push_back(3.0 * std::pow(v, -1.44));
  const PowerLawFit fit = fit_power_law(x, y, "series 'exact'");
  EXPECT_NEAR(fit.exponent, -1.44, 1e-12);
  EXPECT_NEAR(fit.explained, 1.0, 1e-12);
}

TEST(PowerLaw, ScatterLowersTheExplainedShareAsRSquaredDoes) {
  // ln y = 2 ln x ± 1 alternately at ln x = 0, 1, 2, 3: slope 2 − 0.4 = 1.6
  // (least squares), and R² = 1 − SS_res / SS_tot computed by hand.
  const std::vector<double> lx{0.0, 1.0, 2.0, 3.0}, ly{1.0, 1.0, 5.0, 5.0};
  std::vector<double> x, y;
  for (std::size_t i = 0; i < lx.size(); ++i) x.push_back(std::exp(lx[i])), y.push_back(std::exp(ly[i]));
  const PowerLawFit fit = fit_power_law(x, y, "series 'scatter'");
  EXPECT_NEAR(fit.exponent, 1.6, 1e-12);
  double ss_res = 0.0, ss_tot = 0.0;
  for (std::size_t i = 0; i < lx.size(); ++i) {
    const double predicted = 3.0 + 1.6 * (lx[i] - 1.5);
    ss_res += (ly[i] - predicted) * (ly[i] - predicted);
    ss_tot += (ly[i] - 3.0) * (ly[i] - 3.0);
  }
  EXPECT_NEAR(fit.explained, 1.0 - ss_res / ss_tot, 1e-12);
  EXPECT_LT(fit.explained, 1.0);
}

TEST(PowerLaw, BadDataIsRefusedNamingWhatAndWhere) {
  auto message = [](const std::vector<double>& x, const std::vector<double>& y) {
    try {
      fit_power_law(x, y, "series 'force'");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({1, 2, 3}, {1, 0, 3}).find("series 'force' has a value that is not positive at point 2"),
            std::string::npos);
  EXPECT_NE(message({1, 2}, {1, 2, 3}).find("different lengths"), std::string::npos);
  EXPECT_NE(message({2, 2, 2}, {1, 2, 3}).find("needs two different x"), std::string::npos);
}

}  // namespace
}  // namespace organsim::plot
