// The FEM reference's contact law at a surface site, from the model file's
// site compliances (model::SiteCompliance; docs/matching.md): the force the
// fast models (multi-beam, mass-spring) give the tool in place of their own,
// so that a trainee feels the accurate model's force at the fast models' rate.
//
// A rigid end of radius R pressed into the organ at a site by d (m) meets, in
// series, the organ's compliance as a held body C_organ (baked per vertex:
// how far the patch under the tool moves per newton) and the local
// indentation of the surface by the end (the tip's own compliance, which
// depends on R, E, ν and the surface's curvature there). The end is a
// hemisphere on a surface of principal curvatures κ₁, κ₂ (baked per vertex;
// flat where the file has none): pressed in by δ it touches a disk of radius
// a = √(R_e δ) (Hertz: normal force 4/3 E* √R_e δ^{3/2}, E* = E/(1 − ν²),
// R_e = √(R′R″) with 1/R′ = 1/R + κ₁, 1/R″ = 1/R + κ₂; R_e = R on a flat)
// until the disk reaches the tip's radius, at δ_b = R²/R_e; deeper, the
// contact stays a disk of radius R and stiffens as a rigid flat punch of that
// radius does (2 R E* per metre: Boussinesq; the two join with the same
// slope). On a convex rim the shallow contact is softer than on a flat, as
// a ball on a ball is. Along the surface the disk of radius a resists as
// Mindlin's, 8 G a/(2 − ν). The
// tip's indentation δ is the part of the press's normal depth d_n that the
// organ's normal compliance c_n does not take: d_n = δ + c_n F_tip(δ). Law:
// F = −K(δ) d, K(δ) = (C_organ + C_tip(δ))⁻¹, C_tip(δ) the tip's secant
// compliance (δ / F_tip(δ) along the normal, Mindlin's along the surface).
// The reference stiffens as the press deepens in other ways too (the shaft
// meets the organ, the material is hyperelastic): the model's depth curve g,
// fitted by `organsim calibrate` to the reference's presses, gives
// F = −g(|d|) K(δ) d. The curve is the reference's for the tip radius it was
// fitted with; a tip of another radius reads it at the same depth relative
// to its radius (d R_fit / R). A tool that does not press in (d_n ≤ 0)
// feels nothing: the contact holds no tension.
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

/// m: the radius of the sphere on a flat that touches as a tip of radius
/// `tip_radius` (m) touches a surface of principal curvatures `first` and
/// `second` (1/m, convex positive): √(R′R″), 1/R′ = 1/R + κ₁, 1/R″ = 1/R + κ₂
/// (Johnson, Contact Mechanics §4.2), a concave κ clipped at −1/(2R), where
/// the two bodies would start to conform. Exactly R on a flat.
double hertz_radius(double tip_radius, double first, double second) noexcept;

class SiteLaw {
 public:
  /// The law of a tip of radius `tip_radius` (m) touching the rest surface at
  /// `at` (its triangle and barycentric weights): the organ's compliance and
  /// the normal interpolated from the triangle's vertices (continuous across
  /// edges). False (nothing changed) when the organ has no site compliances
  /// or the tip is a point (a point has no finite indentation stiffness in an
  /// elastic body: the fast models then keep their own force). `on_supports`:
  /// a press meets the organ resting on its supports (the model's compliance
  /// on them, where it has one, and its depth curve on them, where it has
  /// that; docs/supports.md), while a patch held in the jaws is drawn off
  /// them and meets the organ held by its clamp.
  bool set(const Organ& organ, const geometry::SurfacePoint& at, double tip_radius, bool on_supports = false) noexcept;
  /// N/m: the law's stiffness with the tip buried (C_organ + the flat punch
  /// of radius R)⁻¹, the stiffest the law gets without a depth curve.
  const Eigen::Matrix3d& stiffness() const noexcept { return stiffness_; }
  /// Force on the tool (N) when the touched point is displaced by `d` (m).
  Eigen::Vector3d force(const Eigen::Vector3d& d) const noexcept;
  /// −∂F/∂d at `d` (N/m), symmetrized: what the 1 kHz loop renders around d.
  Eigen::Matrix3d tangent(const Eigen::Vector3d& d) const noexcept;
  /// g(|d|) (1 without a depth curve).
  double depth_factor(double depth) const noexcept;
  /// The softening s(u) of a patch held in the jaws and drawn `pulled` (m)
  /// since they closed: the model's pull curve read at u R_fit / R (1
  /// without a pull curve: the bonded punch).
  double pull_softening(double pulled) const noexcept;
  /// ds/du at `pulled` (1/m).
  double pull_softening_slope(double pulled) const noexcept;
  /// N/m: the held patch's stiffness (C_organ + s C_punch)⁻¹ for a softening
  /// `softening` of the tip's punch (zero where that is singular); C_organ
  /// is the organ's held by its clamp, also on supports (lifted off them).
  Eigen::Matrix3d held_stiffness(double softening) const noexcept;
  /// m/N: the bonded punch of the tip's radius, C_punch.
  const Eigen::Matrix3d& tip_compliance() const noexcept { return punch_compliance_; }
  /// m: the tip's own indentation δ when the press's depth along the inward
  /// normal is `normal_depth` (m): d_n = δ + c_n F_tip(δ).
  double tip_indentation(double normal_depth) const noexcept;
  /// N: the tip's normal force when it indents the surface by δ (m).
  double tip_force(double indentation) const noexcept;

 private:
  struct Secant {
    Eigen::Matrix3d stiffness;   ///< K(δ), N/m
    Eigen::Matrix3d derivative;  ///< dK/dd_n = ∂K/∂δ · dδ/dd_n, N/m²
  };
  Secant secant(double normal_depth, bool with_derivative) const noexcept;
  double tip_force_slope(double indentation) const noexcept;     // dF_tip/dδ, N/m
  double depth_slope(double depth) const noexcept;               // g'(|d|), 1/m
  Eigen::Matrix3d organ_compliance_ = Eigen::Matrix3d::Zero();   // m/N, as pressed
  Eigen::Matrix3d lifted_compliance_ = Eigen::Matrix3d::Zero();  // m/N, off the supports
  Eigen::Matrix3d punch_compliance_ = Eigen::Matrix3d::Zero();   // m/N
  Eigen::Vector3d normal_ = Eigen::Vector3d::UnitZ();            // outward, unit
  double organ_normal_compliance_ = 0.0;                         // nᵀ C_organ n, m/N
  double radius_ = 0.0, contact_modulus_ = 0.0, shear_ = 0.0, poisson_ = 0.0;
  double hertz_radius_ = 0.0;        // R_e, m
  double buried_indentation_ = 0.0;  // δ_b = R²/R_e, m
  Eigen::Matrix3d stiffness_ = Eigen::Matrix3d::Zero();
  const std::vector<std::array<double, 2>>* curve_ = nullptr;
  double curve_depth_scale_ = 1.0;  // R_fit / R: the curve is read at d R_fit / R
  const std::vector<std::array<double, 2>>* pull_curve_ = nullptr;
  double pull_distance_scale_ = 1.0;  // R_fit / R of the pull curve
};

/// A matched site held in a grasper's jaws (docs/realtime.md#grasping). The
/// jaws close where the tool had displaced the site by `closed_at`; from then
/// on they hold the patch under the tip both ways: the force goes on from the
/// law's force there, F = F(d_g) − K_h(u) (d − d_g), u = |d − d_g|, with K_h
/// the held patch's stiffness (C_organ + s(u) C_punch)⁻¹: a held patch of the
/// tip's radius neither grows as a press's contact disk does nor lets go
/// when pulled, and softens as the jaws draw it out (the model's pull curve s,
/// fitted by `organsim calibrate --pull`; the bonded punch, s = 1, without).
struct SiteGrasp {
  bool held = false;
  Eigen::Vector3d closed_at = Eigen::Vector3d::Zero();      ///< m: d_g
  Eigen::Vector3d closing_force = Eigen::Vector3d::Zero();  ///< N: F(d_g)

  void close(const SiteLaw& law, const Eigen::Vector3d& displacement) noexcept {
    held = true;
    closed_at = displacement;
    closing_force = law.force(displacement);
  }
  void open() noexcept { held = false; }
  /// N on the tool at `displacement` (m).
  Eigen::Vector3d force(const SiteLaw& law, const Eigen::Vector3d& displacement) const noexcept;
  /// −∂F/∂d at `displacement` (N/m), symmetrized: what the 1 kHz loop renders.
  Eigen::Matrix3d tangent(const SiteLaw& law, const Eigen::Vector3d& displacement) const noexcept;
};

}  // namespace organsim::organ
