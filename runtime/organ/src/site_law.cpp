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

// The tip's indentation: Newton's iterations on a convex scalar function
// (six or so from the deepest start; the cap is never reached in practice).
constexpr int kIndentationIterations = 60;
constexpr double kIndentationTolerance = 1e-12;  // of the normal depth

/// A curve of pairs (x, value), x increasing: linear between the pairs, held
/// beyond the ends.
double curve_value(const std::vector<std::array<double, 2>>& c, double x) noexcept {
  if (x <= c.front()[0]) return c.front()[1];
  for (std::size_t i = 1; i < c.size(); ++i)
    if (x <= c[i][0]) {
      const double w = (x - c[i - 1][0]) / (c[i][0] - c[i - 1][0]);
      return (1.0 - w) * c[i - 1][1] + w * c[i][1];
    }
  return c.back()[1];
}

/// d value / dx of `curve_value` (0 beyond the ends).
double curve_slope(const std::vector<std::array<double, 2>>& c, double x) noexcept {
  for (std::size_t i = 1; i < c.size(); ++i)
    if (x >= c[i - 1][0] && x < c[i][0]) return (c[i][1] - c[i - 1][1]) / (c[i][0] - c[i - 1][0]);
  return 0.0;
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

double hertz_radius(double tip_radius, double first, double second) noexcept {
  const double concave_limit = -0.5 / tip_radius;
  return tip_radius / std::sqrt((1.0 + tip_radius * std::max(first, concave_limit)) *
                                (1.0 + tip_radius * std::max(second, concave_limit)));
}

bool SiteLaw::set(const Organ& organ, const geometry::SurfacePoint& at, double tip_radius, bool on_supports) noexcept {
  const model::OrganModel& m = organ.model();
  const model::SiteCompliance& sites = m.sites;
  if (sites.empty() || !(tip_radius > 0.0) || !std::isfinite(tip_radius) || at.triangle >= m.surface_triangles.size())
    return false;
  // Both interpolated from the vertices, so that the law is continuous across
  // the triangles' edges (a face's normal is not).
  const model::Triangle& t = m.surface_triangles[at.triangle];
  Eigen::Matrix3d compliance = Eigen::Matrix3d::Zero();
  for (int k = 0; k < 3; ++k) compliance += at.barycentric[k] * unpacked(sites.compliance[t[k]]);
  Eigen::Matrix3d lifted = compliance;
  const bool supported = on_supports && sites.supported.size() == m.surface_vertices.size();
  if (supported) {
    compliance.setZero();
    for (int k = 0; k < 3; ++k) compliance += at.barycentric[k] * unpacked(sites.supported[t[k]]);
  }
  const Eigen::Vector3d normal = organ.rest_normal_at(at);
  Eigen::Matrix3d stiffness;
  bool invertible = false;
  double determinant = 0.0;
  const Eigen::Matrix3d punch = punch_compliance(sites.young_modulus, sites.poisson_ratio, tip_radius, normal);
  (compliance + punch).computeInverseAndDetWithCheck(stiffness, determinant, invertible);
  if (!invertible || !stiffness.allFinite()) return false;
  stiffness_ = 0.5 * (stiffness + stiffness.transpose());
  organ_compliance_ = compliance;
  lifted_compliance_ = lifted;
  punch_compliance_ = punch;
  normal_ = normal;
  organ_normal_compliance_ = std::max(0.0, normal.dot(compliance * normal));
  radius_ = tip_radius;
  double first = 0.0, second = 0.0;
  if (sites.curvature.size() == m.surface_vertices.size())
    for (int k = 0; k < 3; ++k) {
      first += at.barycentric[k] * sites.curvature[t[k]][0];
      second += at.barycentric[k] * sites.curvature[t[k]][1];
    }
  hertz_radius_ = hertz_radius(tip_radius, first, second);
  buried_indentation_ = tip_radius * (tip_radius / hertz_radius_);  // bit-for-bit R on a flat
  poisson_ = sites.poisson_ratio;
  contact_modulus_ = sites.young_modulus / (1.0 - poisson_ * poisson_);
  shear_ = sites.young_modulus / (2.0 * (1.0 + poisson_));
  const bool own_curve = supported && !sites.supported_depth_curve.empty();
  const std::vector<std::array<double, 2>>& curve = own_curve ? sites.supported_depth_curve : sites.depth_curve;
  curve_ = curve.empty() ? nullptr : &curve;
  curve_depth_scale_ =
      curve_ ? (own_curve ? sites.supported_curve_tip_radius : sites.curve_tip_radius) / tip_radius : 1.0;
  pull_curve_ = sites.pull_curve.empty() ? nullptr : &sites.pull_curve;
  pull_distance_scale_ = pull_curve_ ? sites.pull_tip_radius / tip_radius : 1.0;
  return true;
}

double SiteLaw::tip_force(double indentation) const noexcept {
  if (!(indentation > 0.0)) return 0.0;
  if (indentation <= buried_indentation_)
    return 4.0 / 3.0 * contact_modulus_ * std::sqrt(hertz_radius_) * indentation * std::sqrt(indentation);
  // Hertz's force at δ_b = R²/R_e is 4/3 E* R³/R_e; its slope 2 E* R, the punch's.
  return contact_modulus_ * radius_ *
         (4.0 / 3.0 * radius_ * (radius_ / hertz_radius_) + 2.0 * (indentation - buried_indentation_));
}

double SiteLaw::tip_force_slope(double indentation) const noexcept {
  return 2.0 * contact_modulus_ * std::sqrt(hertz_radius_ * std::min(std::max(indentation, 0.0), buried_indentation_));
}

double SiteLaw::tip_indentation(double normal_depth) const noexcept {
  if (!(normal_depth > 0.0)) return 0.0;
  // h(δ) = δ + c_n F_tip(δ) − d_n is increasing and convex: Newton from δ = d_n
  // (where h ≥ 0) falls monotonically onto the root.
  double indentation = normal_depth;
  for (int iteration = 0; iteration < kIndentationIterations; ++iteration) {
    const double excess = indentation + organ_normal_compliance_ * tip_force(indentation) - normal_depth;
    const double step = excess / (1.0 + organ_normal_compliance_ * tip_force_slope(indentation));
    indentation = std::max(indentation - step, 0.0);
    if (!(step > kIndentationTolerance * normal_depth)) break;
  }
  return indentation;
}

SiteLaw::Secant SiteLaw::secant(double normal_depth, bool with_derivative) const noexcept {
  Secant s{Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero()};
  const double indentation = tip_indentation(normal_depth);
  const double force = tip_force(indentation);
  if (!(force > 0.0)) return s;
  const double contact_radius = std::sqrt(hertz_radius_ * std::min(indentation, buried_indentation_));
  const double along_normal = indentation / force;
  const double along_surface = (2.0 - poisson_) / (8.0 * shear_ * contact_radius);
  Eigen::Matrix3d stiffness;
  bool invertible = false;
  double determinant = 0.0;
  (organ_compliance_ + about_normal(along_normal, along_surface, normal_))
      .computeInverseAndDetWithCheck(stiffness, determinant, invertible);
  if (!invertible || !stiffness.allFinite()) return s;
  s.stiffness = 0.5 * (stiffness + stiffness.transpose());
  if (!with_derivative) return s;
  // d(δ/F)/dδ = (F − δF')/F²; Mindlin's along the surface ∝ 1/a, a = √(R_e δ).
  const double normal_slope = (force - indentation * tip_force_slope(indentation)) / (force * force);
  const double surface_slope = indentation < buried_indentation_ ? -along_surface / (2.0 * indentation) : 0.0;
  const double indentation_per_depth =
      1.0 / (1.0 + organ_normal_compliance_ * tip_force_slope(indentation));  // dδ/dd_n
  s.derivative =
      -indentation_per_depth * s.stiffness * about_normal(normal_slope, surface_slope, normal_) * s.stiffness;
  return s;
}

double SiteLaw::depth_factor(double depth) const noexcept {
  return curve_ ? curve_value(*curve_, depth * curve_depth_scale_) : 1.0;
}

double SiteLaw::depth_slope(double depth) const noexcept {
  return curve_ ? curve_slope(*curve_, depth * curve_depth_scale_) * curve_depth_scale_ : 0.0;
}

double SiteLaw::pull_softening(double pulled) const noexcept {
  return pull_curve_ ? curve_value(*pull_curve_, pulled * pull_distance_scale_) : 1.0;
}

double SiteLaw::pull_softening_slope(double pulled) const noexcept {
  return pull_curve_ ? curve_slope(*pull_curve_, pulled * pull_distance_scale_) * pull_distance_scale_ : 0.0;
}

Eigen::Matrix3d SiteLaw::held_stiffness(double softening) const noexcept {
  Eigen::Matrix3d stiffness;
  bool invertible = false;
  double determinant = 0.0;
  (lifted_compliance_ + softening * punch_compliance_)
      .computeInverseAndDetWithCheck(stiffness, determinant, invertible);
  if (!invertible || !stiffness.allFinite()) return Eigen::Matrix3d::Zero();
  return 0.5 * (stiffness + stiffness.transpose());
}

Eigen::Vector3d SiteLaw::force(const Eigen::Vector3d& d) const noexcept {
  return -depth_factor(d.norm()) * (secant(-normal_.dot(d), false).stiffness * d);
}

Eigen::Matrix3d SiteLaw::tangent(const Eigen::Vector3d& d) const noexcept {
  // F = −g(|d|) K(δ(d_n)) d with d_n = −n·d.
  const double depth = d.norm();
  const Secant s = secant(-normal_.dot(d), true);
  Eigen::Matrix3d t = depth_factor(depth) * (s.stiffness - (s.derivative * d) * normal_.transpose());
  if (depth > 0.0) t += depth_slope(depth) * (s.stiffness * d) * (d / depth).transpose();
  return 0.5 * (t + t.transpose());
}

Eigen::Vector3d SiteGrasp::force(const SiteLaw& law, const Eigen::Vector3d& displacement) const noexcept {
  const Eigen::Vector3d drawn = displacement - closed_at;
  return closing_force - law.held_stiffness(law.pull_softening(drawn.norm())) * drawn;
}

Eigen::Matrix3d SiteGrasp::tangent(const SiteLaw& law, const Eigen::Vector3d& displacement) const noexcept {
  // F = F_g − K(s(u)) w, w = d − d_g, u = |w|; dK/ds = −K C_punch K.
  const Eigen::Vector3d drawn = displacement - closed_at;
  const double pulled = drawn.norm();
  const Eigen::Matrix3d stiffness = law.held_stiffness(law.pull_softening(pulled));
  Eigen::Matrix3d t = stiffness;
  if (pulled > 0.0)
    t -= law.pull_softening_slope(pulled) * (stiffness * law.tip_compliance() * stiffness * drawn) *
         (drawn / pulled).transpose();
  return 0.5 * (t + t.transpose());
}

}  // namespace organsim::organ
