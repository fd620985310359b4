// A rigid tool tip pressed into an elastic body: frictionless unilateral
// contact on the body's nodes, solved exactly with Lagrange multipliers on an
// active set. The reference a finite tool's force is measured against: a tip
// of finite size has a finite indentation stiffness, which a refined mesh
// converges to, where a point load's does not.
//
// Small strain, linear elasticity: the stiffness K of the free degrees of
// freedom is factorized once. Each node i of the active set A is held on the
// tip's surface by one constraint nᵢ·uᵢ = bᵢ (nᵢ the tip's outward normal at
// the node, the direction its contact force pushes), whose multiplier λᵢ is
// that force (N). The multipliers solve the condensed system
//     (Nᵀ K⁻¹ N) λ = b,   u = K⁻¹ N λ,
// one solve with K's factor per active node. A node whose λᵢ pulls (< 0)
// leaves A, a node inside the tip joins it, and (finite kinematics) a sphere's
// normals follow the displaced nodes, until nothing changes. The force on the
// tool is −Σ λᵢ nᵢ.
// Verified against Hertz (sphere) and Boussinesq (flat punch):
// tests/runtime/fem/rigid_tip_contact_test.cpp, docs/fem.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "organsim/fem/factorization.h"
#include "organsim/fem/material.h"
#include "organsim/fem/static_solver.h"
#include "organsim/fem/tet_mesh.h"

namespace organsim::fem {

/// The tool's end, where it is pressed to.
struct RigidTip {
  enum class Shape : std::uint8_t {
    sphere,      ///< the hemispherical end of a probe: a ball of `radius` around `centre`
    flat_punch,  ///< a cylinder of `radius` whose flat end, through `centre`, faces along `axis`
  };
  Shape shape = Shape::sphere;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< m
  Eigen::Vector3d axis = -Eigen::Vector3d::UnitZ();  ///< unit, the pressing direction (into the body)
  double radius = 2.5e-3;                            ///< m

  /// How far point y lies outside the tip (m; negative inside) and the tip's
  /// outward unit normal there; a flat punch's face only counts within its
  /// radius of the axis (elsewhere: +∞).
  double gap(const Eigen::Vector3d& y, Eigen::Vector3d& normal) const noexcept;
};

/// Where the gap is measured.
enum class ContactKinematics : std::uint8_t {
  /// At the displaced nodes, along the tip's normal there: what the organ
  /// models do; a node drawn sideways under a sphere meets it deeper.
  finite,
  /// Hertz's and Boussinesq's linear theory: along the pressing axis, at the
  /// nodes' undeformed place across it (the sideways displacement ignored).
  /// Their closed forms are for this problem; at d/R = 0.1 with ν = 0.3 the
  /// finite gap gives about 4 % more force.
  small,
};

struct ContactProblem {
  TetMesh mesh;
  Material material;                            ///< linear only
  std::vector<std::int32_t> fixed;              ///< nodes held in all three components
  std::vector<PrescribedDisplacement> rollers;  ///< components held at zero (symmetry planes); values must be 0
  std::vector<std::int32_t> candidates;         ///< nodes that may touch the tip (the boundary's); empty: every node
  ContactKinematics kinematics = ContactKinematics::finite;
};

struct ContactSolution {
  bool converged = false;
  std::string error;                                ///< one line when not converged
  Eigen::VectorXd displacements;                    ///< 3 per node, m
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< N, on the tool: −Σ λᵢ nᵢ
  std::vector<std::int32_t> active;                 ///< nodes in contact at the end
  int iterations = 0;                               ///< active-set passes
};

/// Throws std::invalid_argument for a material other than linear, an index
/// out of range, a roller with a non-zero value, or a tip with a non-positive
/// radius or a non-unit axis.
ContactSolution press_rigid_tip(const ContactProblem& problem, const RigidTip& tip,
                                FactorizationFactory factory = nullptr);

}  // namespace organsim::fem
