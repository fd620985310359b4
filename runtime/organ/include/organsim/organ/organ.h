// The immutable runtime form of an organ that every deformation model and the
// engine share: the model file's contents (surface, tetrahedra when present,
// beam tables when present) with the surface vertices in Morton order, plus
// what every contact and every frame needs: a closest-point tree over the rest
// surface, the vertex one-rings for normals, and the rest positions as padded
// coordinate arrays for the per-vertex kernels. A model's own extras (the
// multi-beam model's beam tables and elastic constants, the FEM's system) are
// built by that model from this organ. Built once at load (allocates, may
// throw); shared read-only by every thread.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "organsim/geometry/closest_point.h"
#include "organsim/model/organ_model.h"

namespace organsim::organ {

/// The order Organ gives surface vertices: along a Morton (Z-order) curve
/// over their bounding box (21 bits per axis, ties by index); order[new] = old.
/// organsim bake writes models in this order, so that loading one renumbers
/// (and copies) nothing.
std::vector<std::uint32_t> morton_order(const std::vector<model::Point3>& vertices);

/// Renumbers a surface into morton_order (the triangles follow), as organsim
/// bake writes it.
void renumber_in_morton_order(std::vector<model::Point3>& vertices, std::vector<model::Triangle>& triangles);

class Organ {
 public:
  /// Takes a valid model (see validate_organ_model). Throws std::invalid_argument
  /// with a one-line reason when it has no surface or no fixed point. The
  /// surface vertices are renumbered along a Morton (Z-order) curve, so that
  /// neighbours in memory are neighbours in space (vector loops then mostly
  /// share one beam element, and threads write disjoint memory); model() is the
  /// renumbered model (its beam tables, when present, follow) and
  /// file_vertex_index() maps back to the file's numbering.
  explicit Organ(model::OrganModel model);
  Organ(const Organ&) = delete;  // the tree refers into the model's arrays
  Organ& operator=(const Organ&) = delete;

  const model::OrganModel& model() const noexcept { return model_; }
  std::size_t vertex_count() const noexcept { return model_.surface_vertices.size(); }
  /// The model file's first fixed point (m): where the organ is held.
  const Eigen::Vector3d& fixed_point() const noexcept { return fixed_point_; }
  /// True when the model carries beam tables (the multi-beam model needs them).
  bool has_beam_tables() const noexcept { return !model_.beams.empty(); }
  /// True when the model carries tetrahedra (the FEM models need them).
  bool has_tetrahedra() const noexcept { return !model_.tetrahedra.empty(); }
  const geometry::SurfaceBvh& surface_tree() const noexcept { return tree_; }

  /// The one-rings in the layout the normals kernels read. Vertices go in
  /// groups of kPadding (the last group padded with the last vertex); group g
  /// is the rows ring_rows()[kPadding r .. kPadding (r + 1)) for r in
  /// [ring_row_offsets()[g], ring_row_offsets()[g + 1]), one entry per vertex
  /// of the group, each 16 × a vertex index (the byte offset of its point in
  /// an array of x, y, z, w floats). Vertex v's column is a cyclic sequence
  /// p_1 .. p_D with Σ_j (p_j − v) × (p_j+1 − v) (indices mod D) twice v's
  /// area-weighted normal: the neighbours counter-clockwise seen from outside
  /// where v's ring is closed, else a, b, v for each of its triangles
  /// (v, a, b); padded to the group's longest sequence with its last entry
  /// (terms that are zero).
  const std::vector<std::uint32_t>& ring_row_offsets() const noexcept { return ring_row_offsets_; }
  const std::vector<std::uint32_t>& ring_rows() const noexcept { return ring_rows_; }
  /// Each vertex's unit normal at rest (compute_vertex_normals of the rest shape).
  const std::vector<model::Point3>& rest_normals() const noexcept { return rest_normals_; }
  /// The outward unit normal of the rest surface at a point of it: the
  /// vertices' normals interpolated (so that it is continuous across the
  /// triangles' edges and defined at a vertex, where a face's normal is not);
  /// the triangle's own normal where they cancel. What a contact's friction
  /// cone and release plane are about (docs/realtime.md#contact-rule).
  Eigen::Vector3d rest_normal_at(const geometry::SurfacePoint& at) const noexcept;
  /// file_vertex_index()[v]: the model file's index of surface vertex v.
  const std::vector<std::uint32_t>& file_vertex_index() const noexcept { return file_index_; }
  /// Rest positions (m) as three coordinate arrays, padded with kPadding
  /// copies of the last vertex so that vector loops may read whole registers
  /// past the end.
  const double* rest_x() const noexcept { return rest_[0].data(); }
  const double* rest_y() const noexcept { return rest_[1].data(); }
  const double* rest_z() const noexcept { return rest_[2].data(); }
  static constexpr std::size_t kPadding = 8;

 private:
  std::vector<std::uint32_t> file_index_;  // declared before model_: filled while model_ is built
  model::OrganModel model_;
  Eigen::Vector3d fixed_point_;
  geometry::SurfaceBvh tree_;
  std::vector<std::uint32_t> ring_row_offsets_;
  std::vector<std::uint32_t> ring_rows_;
  std::vector<double> rest_[3];
  std::vector<model::Point3> rest_normals_;
};

/// Area-weighted vertex normals (unit; zero for an isolated vertex) of the
/// surface with vertex positions `positions` for vertices [first, last): the
/// normalized sum of the incident triangles' cross products, which around a
/// closed ring n_0..n_k−1 is Σ n_j × n_j+1 (the centre cancels), so each
/// neighbour is read once. Eight vertices at a time (Organ::ring_rows).
/// Allocates nothing; ranges may run on different threads.
void compute_vertex_normals(const Organ& organ, const model::Point3* positions, model::Point3* normals,
                            std::size_t first, std::size_t last) noexcept;

/// The clamp every model holds the organ by: a point (m) within `radius` (m)
/// of the model's fixed point is held in place (the FEM models' nodes, the
/// mass-spring model's nodes with volume springs).
inline bool within_clamp(const Eigen::Vector3d& point, const Eigen::Vector3d& fixed_point, double radius) noexcept {
  return (point - fixed_point).norm() <= radius;
}

/// The instruction set the per-vertex kernels (distortion, normals) run with:
/// "x86-64-v4" (AVX-512), "x86-64-v3" (AVX2, FMA) or "x86-64" in the portable
/// build, the widest this CPU has; "native" in a build for one CPU.
const char* vertex_kernel_level() noexcept;

}  // namespace organsim::organ
