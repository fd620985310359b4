// A straight 3-D frame beam clamped at one end: the structural core of the
// multi-beam model (Nakaguchi et al., SPIE Medical Imaging 2006; Ushiki et al.,
// multi-beam paper, eqs. 1–3; docs/multibeam.md#references).
//
// The beam lies along its local x axis from the clamp (node 0, x = 0) to the tip
// (node N, x = L), cut into N equal elements; element e has the constant section
// `sections[e]` (the baked station at its midpoint). Each node has six degrees of
// freedom in the local frame: displacements (u, v, w) along (x, y, z), metres,
// and rotations (θx, θy, θz), radians. Element stiffness: axial E·A, torsion G·J,
// bending with the full section tensor [[∫y², ∫yz], [∫yz, ∫z²]] (so I_yz ≠ 0
// bends out of the load plane), Euler–Bernoulli or Timoshenko (shear area κA).
// With centroid offsets on, each element's elastic axis runs through its
// section centroid (c_y, c_z) and is tied rigidly to the nodes on the reference
// axis (an eccentric beam), so an axial push off the centroid also bends.
//
// build() assembles and factorizes once per contact (block-tridiagonal
// elimination, 6×6 blocks); afterwards the tip force for a tip displacement is
// one 3×3 product and every node's displacement is one 6×3 product. build() and
// every accessor allocate nothing; the constructor allocates for `max_elements`.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "organsim/model/organ_model.h"
#include "organsim/multibeam/status.h"

namespace organsim::multibeam {

enum class BeamTheory : std::uint8_t {
  euler_bernoulli,  ///< no shear deformation (the paper's choice)
  timoshenko,       ///< shear deformation with shear area κA
};

/// Elastic constants of the beam's material.
struct BeamElasticity {
  double young_modulus = 0.0;      ///< E, Pa
  double shear_modulus = 0.0;      ///< G = E / (2(1 + ν)), Pa
  double shear_coefficient = 0.0;  ///< κ of the shear area κA (Timoshenko only)

  /// E, G and Cowper's κ = 6(1 + ν)/(7 + 6ν) (exact for a solid circle, within a
  /// few percent for the compact sections of an organ).
  static BeamElasticity from(double young_modulus, double poisson_ratio) noexcept;
};

struct BeamBuildOptions {
  BeamTheory theory = BeamTheory::euler_bernoulli;
  bool centroid_offsets = true;  ///< eccentric elements through the section centroids
};

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using NodeResponse = Eigen::Matrix<double, 6, 3>;  ///< node [u; θ] per unit tip displacement

class ClampedBeam {
 public:
  /// Reserves room for beams of up to `max_elements` elements.
  explicit ClampedBeam(std::uint32_t max_elements);

  /// Assembles and factorizes a beam of `element_count` elements of length
  /// `length` (m). Sections with a smaller area or inertia than 10⁻³ of the
  /// beam's largest are raised to that floor (a section plane that barely grazes
  /// the organ must not make the beam singular). Returns not_finite for a bad
  /// length or section, singular_beam when the factorization fails.
  /// `foundation`, when given: per node 1..N (entry n − 1), the translational
  /// stiffness (N/m, local frame, symmetric positive semi-definite) of what
  /// the node's section rests on: a beam on an elastic foundation lumped at
  /// its nodes (Winkler's; EI d⁴w/dx⁴ + k w = q for a uniform one).
  Status build(const model::BeamSection* sections, std::uint32_t element_count, double length,
               const BeamElasticity& elasticity, const BeamBuildOptions& options,
               const Eigen::Matrix3d* foundation = nullptr) noexcept;

  bool built() const noexcept { return built_; }
  std::uint32_t element_count() const noexcept { return elements_; }
  double length() const noexcept { return length_; }

  /// Tip stiffness for tip translations with the tip rotations free (local
  /// frame, N/m): the force the tip needs to move by d is tip_stiffness() · d.
  const Eigen::Matrix3d& tip_stiffness() const noexcept { return tip_stiffness_; }
  /// The full 6×6 stiffness of the tip node (translations and rotations; N/m,
  /// N/rad, N·m/m, N·m/rad), everything else free.
  const Matrix6d& tip_stiffness_6x6() const noexcept { return tip_full_; }
  /// Node n's displacement and rotation [u; θ] (local frame) for a unit tip
  /// displacement along x, y and z (the columns); node 0 is the clamp (zero).
  const NodeResponse& node_response(std::uint32_t node) const noexcept { return response_[node]; }

 private:
  std::uint32_t capacity_;
  std::uint32_t elements_ = 0;
  double length_ = 0.0;
  bool built_ = false;
  Eigen::Matrix3d tip_stiffness_;
  Matrix6d tip_full_;
  std::vector<Matrix6d, Eigen::aligned_allocator<Matrix6d>> diagonal_;  // K_nn, n = 1..N
  std::vector<Matrix6d, Eigen::aligned_allocator<Matrix6d>> upper_;     // K_{n,n+1}
  std::vector<Matrix6d, Eigen::aligned_allocator<Matrix6d>> carry_;     // G_n: u_n = G_n u_{n+1}
  std::vector<NodeResponse, Eigen::aligned_allocator<NodeResponse>> response_;
};

/// The 12×12 stiffness of one element of length h (local frame, DOFs
/// [u v w θx θy θz] of its first then its second node). Exposed for tests.
Eigen::Matrix<double, 12, 12> element_stiffness(const model::BeamSection& section, double h,
                                                const BeamElasticity& elasticity,
                                                const BeamBuildOptions& options) noexcept;

}  // namespace organsim::multibeam
