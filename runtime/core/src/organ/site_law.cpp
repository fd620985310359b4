#include "organsim/organ/site_law.h"

#include <cmath>

#include <Eigen/LU>

#include "organsim/organ/organ.h"

namespace organsim::organ {
namespace {

Eigen::Matrix3d about_normal(double along_normal, double along_surface, const Eigen::Vector3d& normal) {
  return along_surface * Eigen::Matrix3d::Identity() + (along_normal - along_surface) * normal * normal.transpose();
}

Eigen::Matrix3d unpacked(const std::array<double, 6>& c) {
  Eigen::Matrix3d m;
  m << c[0], c[3], c[4], c[3], c[1], c[5], c[4], c[5], c[2];
  return m;
}

}  // namespace

Eigen::Matrix3d punch_compliance(double young, double poisson, double radius, const Eigen::Vector3d& normal) noexcept {
  const double shear = young / (2.0 * (1.0 + poisson));
  return about_normal((1.0 - poisson) / (4.0 * shear * radius), (2.0 - poisson) / (8.0 * shear * radius), normal);
}

Eigen::Matrix3d disk_compliance(double young, double poisson, double radius, const Eigen::Vector3d& normal) noexcept {
  const double shear = young / (2.0 * (1.0 + poisson));
  const double scale = 1.0 / (3.0 * M_PI * M_PI * shear * radius);
  return about_normal(8.0 * (1.0 - poisson) * scale, 4.0 * (2.0 - poisson) * scale, normal);
}

bool SiteLaw::set(const Organ& organ, const geometry::SurfacePoint& at, double tip_radius) noexcept {
  const model::OrganModel& m = organ.model();
  const model::SiteCompliance& sites = m.sites;
  if (sites.empty() || !(tip_radius > 0.0) || !std::isfinite(tip_radius) || at.triangle >= m.surface_triangles.size())
    return false;
  // Both interpolated from the vertices, so that the law is continuous across
  // the triangles' edges (a face's normal is not).
  const model::Triangle& t = m.surface_triangles[at.triangle];
  Eigen::Matrix3d compliance = Eigen::Matrix3d::Zero();
  for (int k = 0; k < 3; ++k) compliance += at.barycentric[k] * unpacked(sites.compliance[t[k]]);
  compliance += punch_compliance(sites.young_modulus, sites.poisson_ratio, tip_radius, organ.rest_normal_at(at));
  Eigen::Matrix3d stiffness;
  bool invertible = false;
  double determinant = 0.0;
  compliance.computeInverseAndDetWithCheck(stiffness, determinant, invertible);
  if (!invertible || !stiffness.allFinite()) return false;
  stiffness_ = 0.5 * (stiffness + stiffness.transpose());
  curve_ = sites.depth_curve.empty() ? nullptr : &sites.depth_curve;
  curve_depth_scale_ = curve_ ? sites.curve_tip_radius / tip_radius : 1.0;
  return true;
}

double SiteLaw::depth_factor(double depth) const noexcept {
  if (!curve_) return 1.0;
  const std::vector<std::array<double, 2>>& c = *curve_;
  const double x = depth * curve_depth_scale_;
  if (x <= c.front()[0]) return c.front()[1];
  for (std::size_t i = 1; i < c.size(); ++i)
    if (x <= c[i][0]) {
      const double w = (x - c[i - 1][0]) / (c[i][0] - c[i - 1][0]);
      return (1.0 - w) * c[i - 1][1] + w * c[i][1];
    }
  return c.back()[1];
}

double SiteLaw::depth_slope(double depth) const noexcept {
  if (!curve_) return 0.0;
  const std::vector<std::array<double, 2>>& c = *curve_;
  const double x = depth * curve_depth_scale_;
  for (std::size_t i = 1; i < c.size(); ++i)
    if (x >= c[i - 1][0] && x < c[i][0]) return (c[i][1] - c[i - 1][1]) / (c[i][0] - c[i - 1][0]) * curve_depth_scale_;
  return 0.0;
}

Eigen::Vector3d SiteLaw::force(const Eigen::Vector3d& d) const noexcept {
  return -depth_factor(d.norm()) * (stiffness_ * d);
}

Eigen::Matrix3d SiteLaw::tangent(const Eigen::Vector3d& d) const noexcept {
  const double depth = d.norm();
  Eigen::Matrix3d t = depth_factor(depth) * stiffness_;
  if (depth > 0.0) t += depth_slope(depth) * (stiffness_ * d) * (d / depth).transpose();
  return 0.5 * (t + t.transpose());
}

}  // namespace organsim::organ
