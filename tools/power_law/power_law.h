// The power law y = c·x^p that fits measured pairs best: the slope of a
// log-log plot, and how much of the spread of log y it explains. Shared by
// `organsim plot` (its fitted exponents) and `calibrate --evaluate` (what
// explains the reference's site-to-site spread). No VTK: plain arithmetic.
#pragma once

#include <string>
#include <vector>

namespace organsim::plot {

struct PowerLawFit {
  double exponent = 0.0;   ///< p, the least-squares slope of ln y on ln x
  double explained = 0.0;  ///< R² of that fit (1 when every y is the same)
};

/// Least squares of ln y on ln x. `what` names the data in error messages
/// (for example "series 'force'"). Throws std::invalid_argument when x and y
/// differ in length, a value is not positive, or there are fewer than two
/// distinct x.
PowerLawFit fit_power_law(const std::vector<double>& x, const std::vector<double>& y, const std::string& what);

}  // namespace organsim::plot
