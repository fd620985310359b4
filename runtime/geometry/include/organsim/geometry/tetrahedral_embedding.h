// The boundary of a tetrahedral mesh, and the organ surface embedded in it:
// the baked tetrahedra do not share the surface's vertices (the mesher places
// its own), so a model that simulates the tetrahedra carries each surface
// vertex along with one tetrahedron (FEM), or ties it to one (volumetric
// springs). SI units.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "organsim/model/organ_model.h"

namespace organsim::geometry {

/// The tetrahedron faces that no other tetrahedron shares, each with the
/// orientation it has in its tetrahedron (outward for positively oriented
/// tetrahedra), in the order of their sorted corner indices.
struct TetrahedralBoundary {
  std::vector<model::Triangle> faces;
  std::vector<std::uint32_t> owners;  ///< per face: the tetrahedron it belongs to
};

TetrahedralBoundary tetrahedral_boundary(const std::vector<model::Tetrahedron>& tetrahedra);

/// Weights (w₀..w₃) with Σ wᵢ xᵢ = p and Σ wᵢ = 1 for the tetrahedron with
/// corners x₀..x₃ (negative weights: p lies outside it).
Eigen::Vector4d tetrahedron_barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                                        const Eigen::Vector3d& x2, const Eigen::Vector3d& x3);

/// Each surface vertex of `model` in one tetrahedron: the owner of the
/// tetrahedral boundary face nearest the vertex. A vertex lies on or near the
/// boundary (both meshes approximate the same organ), so its weights are those
/// of a point in or just outside its host.
struct SurfaceEmbedding {
  std::vector<model::Tetrahedron> hosts;                                            ///< per surface vertex
  std::vector<Eigen::Vector4d, Eigen::aligned_allocator<Eigen::Vector4d>> weights;  ///< per surface vertex
};

/// Throws std::invalid_argument when the model has no tetrahedra.
SurfaceEmbedding embed_surface_in_tetrahedra(const model::OrganModel& model, const TetrahedralBoundary& boundary);

}  // namespace organsim::geometry
