// Stage 3 of the pipeline: the organ surface from the mask (flying edges,
// windowed-sinc smoothing, decimation to a target size and a gentle Laplacian
// pass that takes off the spikes decimation leaves), in metres, patient frame, closed, manifold and outward oriented.
#pragma once

#include <cstddef>
#include <vector>

#include "organsim/geometry/meshes.h"
#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

struct SurfaceOptions {
  std::size_t target_vertices = 3000;  ///< decimate to about this many vertices
  int smoothing_iterations = 20;       ///< windowed sinc, of the contour
  double smoothing_passband = 0.05;    ///< windowed sinc pass band (smaller: smoother)
  long block_factor = 0;  ///< contour the means of blocks of n³ voxels (1–4); 0: chosen from target_vertices
};

/// The surface encloses the mask's volume (voxel count × voxel volume, of the
/// part the surface keeps when down-sampling parts a thin bridge) to 1e-10:
/// contouring, smoothing and decimation bias it by a thin layer, which one
/// common offset along the vertex normals removes (volume_matching.h).
/// Throws std::runtime_error with one line when the mask is empty or the
/// result is not a closed manifold (each edge shared by exactly two triangles),
/// std::invalid_argument for a block factor outside 0–4.
/// Area and volume: organsim/geometry/model_measures.h.
geometry::SurfaceMesh extract_surface(const MaskImage& mask, const SurfaceOptions& options);

/// Spherical texture coordinates about the vertices' centroid: u from the
/// azimuth, v from the polar angle, both in [0, 1].
std::vector<model::TexCoord> spherical_texture_coordinates(const std::vector<model::Point3>& vertices);

}  // namespace organsim::pipeline
