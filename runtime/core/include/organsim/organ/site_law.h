// The FEM reference's contact law at a surface site, from the model file's
// site compliances (model::SiteCompliance; docs/matching.md): the force the
// fast models (multi-beam, mass-spring) give the tool in place of their own,
// so that a trainee feels the accurate model's force at the fast models' rate.
//
// A rigid end of radius R pressed into the organ at a site by d (m) meets, in
// series, the organ's compliance as a held body C_organ (baked per vertex:
// how far the patch under the tool moves per newton) and the local
// indentation of the patch by the end, C_tip(R) (a rigid circular punch of
// radius R on a half-space: Boussinesq normal to the surface, Mindlin along
// it). Linear law: F = −K d, K = (C_organ + C_tip)⁻¹. The reference stiffens
// as the press deepens (the tip buries, the shaft meets the organ, the
// material is hyperelastic): the model's depth curve g, fitted by `organsim
// calibrate` to the reference's presses, gives F = −g(|d|) K d. The curve is
// the reference's for the tip radius it was fitted with; a tip of another
// radius reads it at the same depth relative to its radius (d R_fit / R).
//
// Everything here is noexcept and allocation-free: the engine's models call
// it on the deformation thread.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "organsim/geometry/closest_point.h"
#include "organsim/model/organ_model.h"

namespace organsim::organ {

class Organ;

/// Compliance (m/N) of a rigid circular punch of radius `radius` (m) on a
/// half-space of Young's modulus `young` (Pa) and Poisson's ratio `poisson`,
/// whose outward normal is `normal` (unit): (1 − ν)/(4 G a) along the normal
/// (Boussinesq), (2 − ν)/(8 G a) along the surface (Mindlin), G = E/(2(1 + ν)).
Eigen::Matrix3d punch_compliance(double young, double poisson, double radius, const Eigen::Vector3d& normal) noexcept;

/// Mean displacement per unit force (m/N) of a uniform traction over a disk
/// of radius `radius` (m) on the same half-space: 8(1 − ν)/(3π² G b) along the
/// normal and 4(2 − ν)/(3π² G b) along the surface (Boussinesq's and
/// Cerruti's point solutions averaged over the disk twice).
Eigen::Matrix3d disk_compliance(double young, double poisson, double radius, const Eigen::Vector3d& normal) noexcept;

class SiteLaw {
 public:
  /// The law of a tip of radius `tip_radius` (m) touching the rest surface at
  /// `at` (its triangle and barycentric weights): the compliance interpolated
  /// from the triangle's vertices plus the tip's punch compliance about the
  /// normal interpolated from their rest normals (continuous across edges). False (nothing changed) when the organ has no site
  /// compliances or the tip is a point (a point has no finite indentation
  /// stiffness in an elastic body: the fast models then keep their own force).
  bool set(const Organ& organ, const geometry::SurfacePoint& at, double tip_radius) noexcept;
  /// K (N/m): the law's stiffness at small depth.
  const Eigen::Matrix3d& stiffness() const noexcept { return stiffness_; }
  /// Force on the tool (N) when the touched point is displaced by `d` (m).
  Eigen::Vector3d force(const Eigen::Vector3d& d) const noexcept;
  /// −∂F/∂d at `d` (N/m), symmetrized: what the 1 kHz loop renders around d.
  Eigen::Matrix3d tangent(const Eigen::Vector3d& d) const noexcept;
  /// g(|d|) (1 without a depth curve).
  double depth_factor(double depth) const noexcept;

 private:
  double depth_slope(double depth) const noexcept;  // g'(|d|), 1/m
  Eigen::Matrix3d stiffness_ = Eigen::Matrix3d::Zero();
  const std::vector<std::array<double, 2>>* curve_ = nullptr;
  double curve_depth_scale_ = 1.0;  // R_fit / R: the curve is read at d R_fit / R
};

}  // namespace organsim::organ
