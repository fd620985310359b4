#include "organsim/geometry/tetrahedral_embedding.h"

#include <algorithm>
#include <array>
#include <stdexcept>

#include <Eigen/LU>

#include "organsim/geometry/closest_point.h"

namespace organsim::geometry {
namespace {

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

}  // namespace

TetrahedralBoundary tetrahedral_boundary(const std::vector<model::Tetrahedron>& tetrahedra) {
  struct Face {
    std::array<std::uint32_t, 3> sorted, corners;
    std::uint32_t owner;
  };
  // Each face of a positively oriented tetrahedron, oriented outward.
  constexpr int kFaceCorners[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::vector<Face> faces;
  faces.reserve(4 * tetrahedra.size());
  for (std::size_t e = 0; e < tetrahedra.size(); ++e)
    for (const auto& corners : kFaceCorners) {
      Face f;
      for (std::size_t k = 0; k < 3; ++k) f.corners[k] = tetrahedra[e][static_cast<std::size_t>(corners[k])];
      f.sorted = f.corners;
      std::sort(f.sorted.begin(), f.sorted.end());
      f.owner = static_cast<std::uint32_t>(e);
      faces.push_back(f);
    }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) {
    return a.sorted != b.sorted ? a.sorted < b.sorted : a.owner < b.owner;
  });
  TetrahedralBoundary boundary;
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].sorted == faces[i].sorted) ++j;
    if (j == i + 1) {
      boundary.faces.push_back(faces[i].corners);
      boundary.owners.push_back(faces[i].owner);
    }
    i = j;
  }
  return boundary;
}

Eigen::Vector4d tetrahedron_barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                                        const Eigen::Vector3d& x2, const Eigen::Vector3d& x3) {
  Eigen::Matrix3d edges;
  edges << x1 - x0, x2 - x0, x3 - x0;
  const Eigen::Vector3d w = edges.inverse() * (p - x0);
  return {1.0 - w.sum(), w[0], w[1], w[2]};
}

SurfaceEmbedding embed_surface_in_tetrahedra(const model::OrganModel& model, const TetrahedralBoundary& boundary) {
  if (model.tetrahedra.empty() || boundary.faces.empty())
    throw std::invalid_argument("the model has no tetrahedra: re-bake it with organsim bake, which meshes the volume");
  const SurfaceBvh tree(model.volume_vertices, boundary.faces);
  SurfaceEmbedding embedding;
  embedding.hosts.reserve(model.surface_vertices.size());
  embedding.weights.reserve(model.surface_vertices.size());
  for (const model::Point3& vertex : model.surface_vertices) {
    const Eigen::Vector3d p = vec(vertex);
    const model::Tetrahedron& host = model.tetrahedra[boundary.owners[tree.closest_point(p).triangle]];
    embedding.hosts.push_back(host);
    embedding.weights.push_back(
        tetrahedron_barycentric(p, vec(model.volume_vertices[host[0]]), vec(model.volume_vertices[host[1]]),
                                vec(model.volume_vertices[host[2]]), vec(model.volume_vertices[host[3]])));
  }
  return embedding;
}

}  // namespace organsim::geometry
