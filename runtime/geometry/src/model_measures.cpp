#include "organsim/geometry/model_measures.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace organsim::geometry {
namespace {

Eigen::Vector3d as_vector(const model::Point3& p) { return {p[0], p[1], p[2]}; }

}  // namespace

double surface_area(const std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles) {
  double area = 0.0;
  for (const model::Triangle& t : triangles) {
    const Eigen::Vector3d a = as_vector(vertices[t[0]]);
    area += 0.5 * (as_vector(vertices[t[1]]) - a).cross(as_vector(vertices[t[2]]) - a).norm();
  }
  return area;
}

double signed_tetrahedron_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                 const Eigen::Vector3d& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

double enclosed_volume(const std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles) {
  double volume = 0.0;
  for (const model::Triangle& t : triangles)
    volume += as_vector(vertices[t[0]]).dot(as_vector(vertices[t[1]]).cross(as_vector(vertices[t[2]]))) / 6.0;
  return volume;
}

double edge_stretch(const std::vector<model::Point3>& rest, const std::vector<model::Point3>& now, std::uint32_t a,
                    std::uint32_t b) {
  const double before = (as_vector(rest[a]) - as_vector(rest[b])).squaredNorm();
  return before > 0.0 ? std::sqrt((as_vector(now[a]) - as_vector(now[b])).squaredNorm() / before) : 1.0;
}

double largest_edge_stretch(const std::vector<model::Point3>& rest, const std::vector<model::Point3>& now,
                            const std::vector<model::Triangle>& triangles) {
  double largest = 1.0;
  for (const model::Triangle& t : triangles)
    for (int e = 0; e < 3; ++e) largest = std::max(largest, edge_stretch(rest, now, t[e], t[(e + 1) % 3]));
  return largest;
}

Eigen::Vector3d triangle_normal(const model::OrganModel& model, std::uint32_t triangle) {
  const model::Triangle& t = model.surface_triangles[triangle];
  const Eigen::Vector3d a = as_vector(model.surface_vertices[t[0]]);
  return (as_vector(model.surface_vertices[t[1]]) - a).cross(as_vector(model.surface_vertices[t[2]]) - a).normalized();
}

ModelMeasures measure_model(const model::OrganModel& model) {
  ModelMeasures m;
  m.bounds_min.setConstant(std::numeric_limits<double>::infinity());
  m.bounds_max.setConstant(-std::numeric_limits<double>::infinity());
  for (const model::Point3& p : model.surface_vertices) {
    m.bounds_min = m.bounds_min.cwiseMin(as_vector(p));
    m.bounds_max = m.bounds_max.cwiseMax(as_vector(p));
  }
  m.surface_area = surface_area(model.surface_vertices, model.surface_triangles);
  m.surface_enclosed_volume = enclosed_volume(model.surface_vertices, model.surface_triangles);
  if (!model.tetrahedra.empty()) m.min_tetrahedron_volume = std::numeric_limits<double>::infinity();
  for (const model::Tetrahedron& t : model.tetrahedra) {
    const double volume =
        signed_tetrahedron_volume(as_vector(model.volume_vertices[t[0]]), as_vector(model.volume_vertices[t[1]]),
                                  as_vector(model.volume_vertices[t[2]]), as_vector(model.volume_vertices[t[3]]));
    m.tetrahedra_volume += volume;
    m.min_tetrahedron_volume = std::min(m.min_tetrahedron_volume, volume);
  }
  return m;
}

}  // namespace organsim::geometry
