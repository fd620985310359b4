#include "organsim/tetrahedra/volume_matching.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

#include "organsim/geometry/model_measures.h"
#include "organsim/tetrahedra/sliver_removal.h"

namespace organsim::pipeline {
namespace {

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

constexpr double kRelativeTolerance = 1e-10;
constexpr int kNewtonIterations = 8;

/// Unit area-weighted normals of the vertices the triangles use (zero elsewhere).
std::vector<Eigen::Vector3d> vertex_normals(const std::vector<model::Point3>& vertices,
                                            const std::vector<model::Triangle>& triangles) {
  std::vector<Eigen::Vector3d> normals(vertices.size(), Eigen::Vector3d::Zero());
  for (const model::Triangle& t : triangles) {
    const Eigen::Vector3d a = vec(vertices[t[0]]);
    const Eigen::Vector3d area_vector = 0.5 * (vec(vertices[t[1]]) - a).cross(vec(vertices[t[2]]) - a);
    for (const std::uint32_t v : t) normals[v] += area_vector;
  }
  for (Eigen::Vector3d& n : normals)
    if (n.squaredNorm() > 0.0) n.normalize();
  return normals;
}

/// dV/dδ when every vertex moves by δ along its normal: Σ n_i · ∂V/∂x_i, where
/// ∂V/∂x_i is a third of the area vectors of the triangles around vertex i.
double volume_rate(const std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles,
                   const std::vector<Eigen::Vector3d>& normals) {
  double rate = 0.0;
  for (const model::Triangle& t : triangles) {
    const Eigen::Vector3d a = vec(vertices[t[0]]);
    const Eigen::Vector3d area_vector = 0.5 * (vec(vertices[t[1]]) - a).cross(vec(vertices[t[2]]) - a);
    for (const std::uint32_t v : t) rate += normals[v].dot(area_vector) / 3.0;
  }
  return rate;
}

void offset(std::vector<model::Point3>& vertices, const std::vector<model::Point3>& rest,
            const std::vector<Eigen::Vector3d>& normals, double distance) {
  for (std::size_t i = 0; i < vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) vertices[i][k] = rest[i][k] + distance * normals[i][k];
}

/// Newton on the common offset of the vertices whose `normals` are not zero.
VolumeMatch offset_to_volume(std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles,
                             const std::vector<Eigen::Vector3d>& normals, double target_m3) {
  VolumeMatch match;
  match.volume_before_m3 = geometry::enclosed_volume(vertices, triangles);
  if (!(match.volume_before_m3 > 0.0))
    throw std::invalid_argument(
        fmt::format("volume matching needs a closed, outward surface (it encloses {:.3g} m³)", match.volume_before_m3));
  if (!(target_m3 > 0.0 && std::isfinite(target_m3)))
    throw std::invalid_argument(
        fmt::format("volume matching needs a positive target volume (got {:.3g} m³)", target_m3));
  // The normals stay those of the rest surface: the offset is one number, found
  // by Newton on V(δ), a cubic in δ.
  const std::vector<model::Point3> rest = vertices;
  double volume = match.volume_before_m3;
  for (int iteration = 0; iteration < kNewtonIterations; ++iteration) {
    if (std::abs(volume - target_m3) <= kRelativeTolerance * target_m3) break;
    const double rate = volume_rate(vertices, triangles, normals);
    if (!(rate > 0.0)) break;
    match.offset_m += (target_m3 - volume) / rate;
    offset(vertices, rest, normals, match.offset_m);
    volume = geometry::enclosed_volume(vertices, triangles);
  }
  match.volume_after_m3 = volume;
  return match;
}

}  // namespace

VolumeMatch match_enclosed_volume(std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles,
                                  double target_m3) {
  return offset_to_volume(vertices, triangles, vertex_normals(vertices, triangles), target_m3);
}

std::vector<model::Triangle> boundary_triangles(const geometry::TetrahedralMesh& mesh) {
  // Outward faces of a positive tetrahedron (a, b, c, d), one opposite each corner.
  static constexpr int kOutward[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<std::uint32_t, 3>, std::pair<int, model::Triangle>> faces;
  for (const model::Tetrahedron& t : mesh.tetrahedra)
    for (const auto& f : kOutward) {
      const model::Triangle face{t[f[0]], t[f[1]], t[f[2]]};
      std::array<std::uint32_t, 3> key{face[0], face[1], face[2]};
      std::sort(key.begin(), key.end());
      auto [at, inserted] = faces.try_emplace(key, 0, face);
      ++at->second.first;
    }
  std::vector<model::Triangle> boundary;
  for (const auto& [key, uses] : faces)
    if (uses.first == 1) boundary.push_back(uses.second);
  return boundary;
}

VolumeMatch match_tetrahedra_volume(geometry::TetrahedralMesh& mesh, double target_m3) {
  const std::vector<model::Triangle> boundary = boundary_triangles(mesh);
  const std::vector<model::Point3> rest = mesh.vertices;
  std::vector<Eigen::Vector3d> normals = vertex_normals(rest, boundary);
  const auto quality = [](const std::vector<model::Point3>& v, const model::Tetrahedron& t) {
    return shape_quality_deg(v[t[0]], v[t[1]], v[t[2]], v[t[3]]);
  };
  // The shape quality that sliver removal reaches (15°: ρ ≤ 3 and angles ≥ 15°).
  constexpr double kKeptQualityDeg = 15.0;
  std::vector<double> quality_before(mesh.tetrahedra.size());
  for (std::size_t i = 0; i < mesh.tetrahedra.size(); ++i) quality_before[i] = quality(rest, mesh.tetrahedra[i]);
  // A boundary vertex moves by a fraction of a millimetre, far less than a
  // tetrahedron's height; where a flat boundary tetrahedron would lose shape
  // (below its own quality and 15°), its vertices stay and the others move a
  // little more.
  VolumeMatch match;
  for (int round = 0; round < 8; ++round) {
    mesh.vertices = rest;
    match = offset_to_volume(mesh.vertices, boundary, normals, target_m3);
    bool held = false;
    for (std::size_t i = 0; i < mesh.tetrahedra.size(); ++i) {
      const model::Tetrahedron& t = mesh.tetrahedra[i];
      if (quality(mesh.vertices, t) >= std::min(quality_before[i], kKeptQualityDeg)) continue;
      for (const std::uint32_t v : t)
        if (normals[v].squaredNorm() > 0.0) normals[v].setZero(), held = true;
    }
    if (!held) return match;
  }
  mesh.vertices = rest;  // no offset keeps every tetrahedron: leave the mesh as it was
  match = VolumeMatch{0.0, match.volume_before_m3, match.volume_before_m3};
  return match;
}

}  // namespace organsim::pipeline
