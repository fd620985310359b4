// The FEM reference of a press by a tool of finite size, on tetrahedra
// refined under the tool: a tip of radius R needs cells of about R/2 under it
// before its force stops depending on the mesh (docs/fem.md#a-tool-of-finite-size).
#pragma once

#include <Eigen/Core>

#include "organsim/model/organ_model.h"

namespace organsim::cli {

/// The model with its surface re-meshed (pipeline/tetrahedra.h): cells of
/// `size_mm` within `radius_mm` of `site` (m), growing back to the model's
/// own tetrahedron size away from it, with its clamp refined as the bake
/// refined it (its meshing record; 8 mm and no clamp refinement when it has
/// none). Surface, clamp and material are the model's; the beam
/// tables are dropped (a reference is a FEM model). Throws std::runtime_error
/// when the surface cannot be meshed.
model::OrganModel refined_at(const model::OrganModel& model, const Eigen::Vector3d& site, double size_mm,
                             double radius_mm);

}  // namespace organsim::cli
