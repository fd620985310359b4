// The FEM reference's compliance at every surface site of a baked organ
// (model::SiteCompliance; docs/matching.md): what lets the fast models give
// the reference's force wherever a tool touches.
//
// One factorization of the pressure-stabilized hyperelastic (PSH) model's
// stiffness at rest — its small-strain limit, the saddle-point matrix
// [K G; Gᵀ −C] — on the model's own tetrahedra, clamped as the FEM models
// clamp them, and one solve per boundary node and direction: the boundary's
// Green's function, kept between nodes closer than two patch radii. A site's
// compliance is that of a uniform traction over the boundary patch within
// the patch radius b of the site (lumped node areas as weights): the mean
// patch displacement per newton, C_patch. The patch is made wide enough for
// the tetrahedra to resolve (b = twice the median boundary edge), so C_patch
// holds the organ's compliance plus the patch's own local indentation, which
// is that of a uniform disk on a half-space (organ::disk_compliance, with the
// disk of the patch's area) and is taken off: what remains, C_organ, is how
// far the organ as a held body gives under a tool there, independent of the
// tool's size and of the mesh where the mesh resolves the patch. At run time
// the tip's own punch compliance is added back (organ/site_law.h).
//
// Deterministic: every solve is independent of the others, so the result is
// byte-identical whatever the number of threads.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "organsim/model/organ_model.h"

namespace organsim::pipeline {

struct SiteComplianceOptions {
  double fixed_radius = 0.010;   ///< m: the FEM models' clamp (fem::OrganFemOptions)
  double poisson_ratio = 0.49;   ///< the PSH reference's ν (fem::OrganFemOptions::psh_poisson_ratio)
  double stabilization = 100.0;  ///< the PSH reference's β
  double patch_radius = 0.0;     ///< m; 0: twice the median boundary edge
  /// m: the surface's curvature at a site is fitted to the surface vertices
  /// within this distance. 0: twice the default tip's radius (5 mm, the
  /// reach of a buried 2.5 mm tip's contact), or twice the median surface
  /// edge where that is longer, so that the fit holds two rings of vertices.
  double curvature_radius = 0.0;
  unsigned threads = 0;  ///< 0: one per hardware thread
  /// Also the compliances of the organ resting on the model's supports, where
  /// it has them (model::SiteCompliance::supported): a second factorization,
  /// of the stiffness with each contact pushed into (its foundation spring
  /// along the normal) and each attachment holding (fem::foundation_springs).
  bool supports = true;
  /// With the supports: each site's press settles which contacts hold it, as
  /// a tensionless foundation's do (the contacts a press moves away from
  /// their support carry nothing), instead of taking every contact as pressed.
  /// Exact (Woodbury's identity on the contacts' compliance among
  /// themselves, the set settled per site) and slow: a dense factorization of
  /// the released or the held contacts per site and round (docs/supports.md
  /// gives the times).
  bool settle_contacts = false;
};

struct SiteComplianceReport {
  double patch_radius = 0.0;                                ///< m, as used
  double curvature_radius = 0.0;                            ///< m, as used
  std::size_t boundary_nodes = 0;                           ///< solved (free boundary nodes within a patch)
  std::size_t unknowns = 0;                                 ///< of the factorized matrix (displacements and pressures)
  std::size_t factor_entries = 0;                           ///< below the diagonal of its LDLᵀ factor
  double factorization_seconds = 0.0, solve_seconds = 0.0;  ///< of both sets, with supports
  /// settle_contacts: sites whose press found no set of contacts that holds
  /// within the rounds allowed, or whose set could not be factorized (each
  /// keeps the set it reached, or releases nothing).
  std::size_t unsettled_sites = 0;
};

/// Per surface vertex of `model`, the surface's principal curvatures κ₁ ≥ κ₂
/// (1/m, convex positive; model::SiteCompliance::curvature): a quadric
/// fitted by least squares, in the vertex's tangent frame, to the surface
/// vertices within `radius` (m) whose normals face its side (less than 90°
/// from its own). A vertex with fewer than five such
/// neighbours (the quadric's unknowns) is taken as flat. Throws std::invalid_argument for a radius
/// that is not a positive length.
std::vector<std::array<double, 2>> site_curvatures(const model::OrganModel& model, double radius);

/// The site compliances of `model` (its surface, tetrahedra, fixed point and
/// E; on its supports too, options.supports), with the surface's curvatures (site_curvatures, over
/// options.curvature_radius). Throws std::invalid_argument with one line when the model has no
/// tetrahedra, the clamp does not hold it, or the options are out of range.
model::SiteCompliance compute_site_compliance(const model::OrganModel& model, const SiteComplianceOptions& options,
                                              SiteComplianceReport* report = nullptr);

}  // namespace organsim::pipeline
