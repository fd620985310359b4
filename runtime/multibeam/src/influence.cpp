#include "organsim/multibeam/influence.h"

#include <cmath>

namespace organsim::multibeam {

bool InfluenceFunction::set_points(const Eigen::Vector3d* points, std::uint32_t count) noexcept {
  count_ = 0;
  if (count == 0 || count > kMaxTools) return false;
  for (std::uint32_t i = 0; i < count; ++i) {
    if (!points[i].allFinite()) return false;
    points_[i] = points[i];
  }
  if (count == 1) {
    inverse_.setIdentity(1, 1);
    count_ = 1;
    return true;
  }
  Matrix distances(count, count);
  for (std::uint32_t i = 0; i < count; ++i)
    for (std::uint32_t j = 0; j < count; ++j) distances(i, j) = (points[i] - points[j]).norm();
  const Eigen::FullPivLU<Matrix> lu(distances);
  if (!lu.isInvertible()) return false;
  inverse_ = lu.inverse();
  if (!inverse_.allFinite()) return false;
  count_ = count;
  return true;
}

void normalize_influence(double* v, std::uint32_t count) noexcept {
  double norm = 0.0;
  for (std::uint32_t i = 0; i < count; ++i) norm += std::abs(v[i]);
  if (!(norm > 0.0)) {
    for (std::uint32_t i = 0; i < count; ++i) v[i] = 1.0 / count;
    return;
  }
  for (std::uint32_t i = 0; i < count; ++i) v[i] /= norm;
}

void InfluenceFunction::weights(const Eigen::Vector3d& p, double* weights) const noexcept {
  double distances[kMaxTools];
  for (std::uint32_t j = 0; j < count_; ++j) distances[j] = (p - points_[j]).norm();
  for (std::uint32_t i = 0; i < count_; ++i) {
    double sum = 0.0;
    for (std::uint32_t j = 0; j < count_; ++j) sum += inverse_(i, j) * distances[j];
    weights[i] = sum;
  }
  normalize_influence(weights, count_);
}

}  // namespace organsim::multibeam
