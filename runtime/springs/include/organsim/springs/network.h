// Spring networks for the mass-spring model (He et al.; docs/springs.md): the
// springs as parallel arrays, the paper's flat quad grid, and a baked organ's
// surface (with optional volume springs on its tetrahedra). Both with virtual
// body springs that tie each surface node to a fixed interior anchor
// (make_grid_network and make_organ_network say where the anchors are).
// Built once, before a simulation (allocates, throws on bad input).
// Units: metres, kilograms, seconds, newtons.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "organsim/model/organ_model.h"

namespace organsim::springs {

enum class SpringKind : std::uint8_t { structural, shear, bending, body, volume };

/// Springs as parallel arrays (one entry per spring).
struct Springs {
  std::vector<std::uint32_t> a, b;  ///< node indices, a < b
  std::vector<double> rest_length;  ///< l⁰, m
  std::vector<double> stiffness;    ///< k, N/m
  std::vector<double> damping;      ///< d, N·s/m (along the spring)
  std::vector<SpringKind> kind;
  std::size_t size() const noexcept { return a.size(); }
};

/// A node resting on, or attached to, what surrounds the organ
/// (docs/supports.md): a Winkler foundation of stiffness K at the node's rest
/// place. An attachment holds both ways (the force −K u for a displacement
/// u); a contact pushes back only while the node moves into it along the
/// outward normal n (−K ⟨u·n⟩₊ n), so a lifted node leaves it.
struct NodeSupport {
  std::uint32_t node = 0;
  double stiffness = 0.0;                             ///< K: the foundation modulus times the node's area, N/m
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, outward
  bool unilateral = false;                            ///< a contact (true) or an attachment

  /// N: the support's force on its node displaced by `u` (m) from rest.
  Eigen::Vector3d force(const Eigen::Vector3d& u) const noexcept {
    if (!unilateral) return -stiffness * u;
    const double into = u.dot(normal);
    return into > 0.0 ? Eigen::Vector3d(-stiffness * into * normal) : Eigen::Vector3d::Zero();
  }
  /// N/m: −∂force/∂u at `u` (0 on a contact that lets go).
  Eigen::Matrix3d stiffness_at(const Eigen::Vector3d& u) const noexcept {
    if (!unilateral) return stiffness * Eigen::Matrix3d::Identity();
    return u.dot(normal) > 0.0 ? Eigen::Matrix3d(stiffness * normal * normal.transpose()) : Eigen::Matrix3d::Zero();
  }
};

/// A network: nodes [0, surface_nodes) are the simulated surface (in the
/// order of the mesh they were built from); after them come the body springs'
/// anchors, which never move, and an organ's tetrahedral nodes when it has
/// volume springs.
struct SpringNetwork {
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> rest;  ///< (N) rest positions, m
  std::vector<double> mass;         ///< (N) kg (anchors: any positive value; they do not move)
  std::vector<std::uint8_t> fixed;  ///< (N) 1: the node never moves (anchors, clamped nodes)
  std::size_t surface_nodes = 0;
  std::vector<model::Triangle> triangles;  ///< surface triangles (for output and collision), may be empty
  Springs springs;
  std::vector<NodeSupport> supports;  ///< nodes on a foundation (docs/supports.md), at most one entry per node
};

/// The paper's experiment grid.
struct GridOptions {
  std::uint32_t columns = 15, rows = 15;  ///< N along x, M along y (≥ 3 each)
  double spacing = 0.010;                 ///< m; vertex (i, j) at (i·spacing, j·spacing, 0), index i + N·j
  double mass = 0.01;                     ///< kg per vertex
  double structural_stiffness = 2.0, shear_stiffness = 2.0, bending_stiffness = 1.2;  ///< N/m
  double structural_damping = 0.4, shear_damping = 0.4, bending_damping = 0.24;       ///< N·s/m
  /// Body springs: one per vertex, from the vertex to an anchor one `spacing`
  /// below it (−z), rest length `spacing`, stiffness body_factor × the
  /// structural stiffness and damping body_factor × the structural damping;
  /// 0 leaves them out.
  double body_factor = 2.0;
  bool fix_border = true;  ///< fix every vertex with i ∈ {0, N−1} or j ∈ {0, M−1}
};

/// Structural (i,j)–(i+1,j), (i,j)–(i,j+1); shear (i,j)–(i+1,j+1), (i+1,j)–(i,j+1);
/// bending (i,j)–(i+2,j), (i,j)–(i,j+2); rest lengths from the flat grid.
/// Springs in that order (structural, shear, bending, body). Nodes: the N·M
/// vertices, then (body_factor > 0) the anchors, anchor of vertex v at N·M + v,
/// fixed, with `mass`. Triangles: each cell (i,j) as (i,j)(i+1,j)(i+1,j+1) and
/// (i,j)(i+1,j+1)(i,j+1), counter-clockwise seen from +z (the anchors lie at −z).
/// Throws std::invalid_argument naming the bad option.
SpringNetwork make_grid_network(const GridOptions& options);

/// A baked organ's surface as a network.
struct OrganNetworkOptions {
  double stiffness = 0.0;  ///< structural spring constant, N/m; 0: from E as k = E·ℓ̄ (ℓ̄ the mean edge length)
  double bending_factor = 0.6;  ///< bending springs: this × the structural constant (the paper's 1.2 / 2)
  /// Structural spring damping d, N·s/m; 0: `critical_fraction` × the critical
  /// damping 2·√(k·m̄) of one structural spring on the mean surface node mass m̄.
  /// Bending and body springs get d scaled like their constants (the paper's
  /// c : k = 0.4 : 2 for every kind). Proportional to k instead (the paper's
  /// 0.2 s) an organ's light nodes would be damped at rates of 10⁴–10⁵ 1/s, far
  /// beyond any explicit integrator's reach.
  double damping = 0.0;
  double critical_fraction = 0.1;
  double body_factor =
      2.0;  ///< body springs: this × the structural constant and damping; 0 leaves them (and the anchors) out
  double anchor_depth = 0.0;  ///< m; 0: the mean edge length
  /// Volumetric springs (the model's tetrahedra): the tetrahedral nodes are
  /// simulated too, every tetrahedron edge is a spring (volume_factor × k and
  /// d), and since the baked tetrahedra do not share the surface's vertices,
  /// each surface vertex is tied by four springs (k, d) to the corners of the
  /// tetrahedron it is embedded in (geometry/tetrahedral_embedding.h).
  bool volume_springs = false;
  double volume_factor = 1.0;
  /// kg per node; 0: the organ's mass ρ·V (ρ the model's density; V the
  /// tetrahedra's volume, or the volume the surface encloses when the model has
  /// no tetrahedra) shared among the surface nodes: equally, or with
  /// `area_weighted_mass` in proportion to their vertex areas (a third of the
  /// area of every triangle at the vertex). Equal shares are the default: on a
  /// decimated liver surface the vertex areas span a factor of about 400, and the
  /// lightest node sets the explicit integrators' largest stable step.
  double uniform_mass = 0.0;
  bool area_weighted_mass = false;
  double clamp_radius = 0.0;  ///< m; surface nodes within this of the first fixed point are fixed (0: none)
  /// The model's supports (docs/supports.md) as a foundation on the surface
  /// nodes: each supported free vertex a NodeSupport of stiffness k A (k its
  /// foundation modulus, A its area) along its area-weighted normal, a
  /// contact unilateral, an attachment not. A model without supports has none.
  bool supports = false;
};

/// Nodes: the model's surface vertices in order, then (body_factor > 0) one
/// anchor per surface vertex, anchor i at surface_nodes + i, fixed, with its
/// vertex's mass, then (volume_springs) the tetrahedral nodes in order, which
/// move; with masses from ρV, every surface and tetrahedral node gets an equal
/// share. Springs, in this order: every surface edge once as a
/// structural spring (k, d); for each edge shared by exactly
/// two triangles, a bending spring between the two vertices opposite it
/// (bending_factor·k, bending_factor·d; edges on a border or on
/// more than two triangles get none); per surface vertex a body spring to its
/// anchor, `anchor_depth` inside along the inward area-weighted vertex normal
/// (−Σ of the adjacent triangles' (b − a) × (c − a), normalized), rest length
/// anchor_depth, body_factor × the structural constant and damping. Anchors of
/// thin parts may lie outside the organ: choose anchor_depth below half the
/// thickness; then (volume_springs) every tetrahedron edge once, in the
/// order of its sorted node pair, and per surface vertex the four ties to its
/// host tetrahedron's corners (kind volume). The clamp fixes tetrahedral nodes
/// within clamp_radius too. Rest lengths are the rest distances. Every spring
/// has a < b.
/// Throws std::invalid_argument on a model without surface triangles, a
/// surface vertex on no triangle, bad indices, bad options, a zero structural
/// constant (stiffness 0 and E = 0), a non-positive density or volume when the
/// masses come from them, clamp_radius > 0 without fixed points, or
/// volume_springs on a model without tetrahedra or with area_weighted_mass.
SpringNetwork make_organ_network(const model::OrganModel& model, const OrganNetworkOptions& options);

}  // namespace organsim::springs
