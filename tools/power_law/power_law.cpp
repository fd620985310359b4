#include "power_law.h"

#include <cmath>
#include <cstddef>
#include <stdexcept>

namespace organsim::plot {

PowerLawFit fit_power_law(const std::vector<double>& x, const std::vector<double>& y, const std::string& what) {
  if (x.size() != y.size()) throw std::invalid_argument("power law fit: " + what + " has x and y of different lengths");
  const std::size_t n = x.size();
  double mean_x = 0.0, mean_y = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!(x[i] > 0.0) || !(y[i] > 0.0))
      throw std::invalid_argument("power law fit: " + what + " has a value that is not positive at point " +
                                  std::to_string(i + 1));
    mean_x += std::log(x[i]);
    mean_y += std::log(y[i]);
  }
  if (n > 0) mean_x /= static_cast<double>(n), mean_y /= static_cast<double>(n);
  double xx = 0.0, xy = 0.0, yy = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = std::log(x[i]) - mean_x, dy = std::log(y[i]) - mean_y;
    xx += dx * dx;
    xy += dx * dy;
    yy += dy * dy;
  }
  if (!(xx > 0.0)) throw std::invalid_argument("power law fit: " + what + " needs two different x to fit");
  return {xy / xx, yy > 0.0 ? xy * xy / (xx * yy) : 1.0};
}

}  // namespace organsim::plot
