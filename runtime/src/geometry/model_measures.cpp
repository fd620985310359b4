#include "organsim/geometry/model_measures.h"

#include <limits>

namespace organsim {
namespace {

Eigen::Vector3d as_vector(const Point3& p) { return {p[0], p[1], p[2]}; }

}  // namespace

double enclosed_volume(const std::vector<Point3>& vertices, const std::vector<Triangle>& triangles) {
  double volume = 0.0;
  for (const Triangle& t : triangles)
    volume += as_vector(vertices[t[0]]).dot(as_vector(vertices[t[1]]).cross(as_vector(vertices[t[2]]))) / 6.0;
  return volume;
}

Eigen::Vector3d triangle_normal(const OrganModel& model, std::uint32_t triangle) {
  const Triangle& t = model.surface_triangles[triangle];
  const Eigen::Vector3d a = as_vector(model.surface_vertices[t[0]]);
  return (as_vector(model.surface_vertices[t[1]]) - a).cross(as_vector(model.surface_vertices[t[2]]) - a).normalized();
}

ModelMeasures measure_model(const OrganModel& model) {
  ModelMeasures m;
  m.bounds_min.setConstant(std::numeric_limits<double>::infinity());
  m.bounds_max.setConstant(-std::numeric_limits<double>::infinity());
  for (const Point3& p : model.surface_vertices) {
    m.bounds_min = m.bounds_min.cwiseMin(as_vector(p));
    m.bounds_max = m.bounds_max.cwiseMax(as_vector(p));
  }
  for (const Triangle& t : model.surface_triangles) {
    const Eigen::Vector3d a = as_vector(model.surface_vertices[t[0]]);
    const Eigen::Vector3d b = as_vector(model.surface_vertices[t[1]]);
    const Eigen::Vector3d c = as_vector(model.surface_vertices[t[2]]);
    m.surface_area += 0.5 * (b - a).cross(c - a).norm();
  }
  m.surface_enclosed_volume = enclosed_volume(model.surface_vertices, model.surface_triangles);
  if (!model.tetrahedra.empty()) m.min_tetrahedron_volume = std::numeric_limits<double>::infinity();
  for (const Tetrahedron& t : model.tetrahedra) {
    const Eigen::Vector3d a = as_vector(model.volume_vertices[t[0]]);
    const double volume = (as_vector(model.volume_vertices[t[1]]) - a)
                              .dot((as_vector(model.volume_vertices[t[2]]) - a)
                                       .cross(as_vector(model.volume_vertices[t[3]]) - a)) /
                          6.0;
    m.tetrahedra_volume += volume;
    m.min_tetrahedron_volume = std::min(m.min_tetrahedron_volume, volume);
  }
  return m;
}

}  // namespace organsim
