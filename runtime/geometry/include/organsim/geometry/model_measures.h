// Geometric measures of surfaces, tetrahedra and whole models: the one place
// where area and volume are computed (`organsim info`, `poke`, the pipeline's
// quality report). SI units: metres, square metres, cubic metres.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "organsim/model/organ_model.h"

namespace organsim::geometry {

struct ModelMeasures {
  Eigen::Vector3d bounds_min = Eigen::Vector3d::Zero();  ///< of the surface vertices, m
  Eigen::Vector3d bounds_max = Eigen::Vector3d::Zero();  ///< m
  double surface_area = 0.0;                             ///< m²
  double surface_enclosed_volume = 0.0;  ///< signed, by the divergence theorem; > 0 for outward triangles, m³
  double tetrahedra_volume = 0.0;        ///< sum of signed tetrahedron volumes, m³ (0 without tetrahedra)
  double min_tetrahedron_volume = 0.0;   ///< smallest signed tetrahedron volume, m³ (< 0 means inverted)
};

/// Area of a triangle surface, m².
double surface_area(const std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles);

/// Signed volume of the tetrahedron (a, b, c, d): > 0 when (b−a)·((c−a)×(d−a)) > 0, m³.
double signed_tetrahedron_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                 const Eigen::Vector3d& d);

/// Signed volume enclosed by a closed triangle surface (divergence theorem;
/// > 0 for outward triangles), m³.
double enclosed_volume(const std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles);

/// The stretch of the edge from vertex `a` to vertex `b` of a surface moved
/// from `rest` to `now` (the same vertices): its length now over its length at
/// rest; 1 for an edge of no length at rest, which has no stretch to measure.
double edge_stretch(const std::vector<model::Point3>& rest, const std::vector<model::Point3>& now, std::uint32_t a,
                    std::uint32_t b);

/// The largest edge_stretch over the edges of `triangles` (1: no edge longer
/// than at rest).
double largest_edge_stretch(const std::vector<model::Point3>& rest, const std::vector<model::Point3>& now,
                            const std::vector<model::Triangle>& triangles);

/// Unit outward normal of a surface triangle of the model (rest state).
Eigen::Vector3d triangle_normal(const model::OrganModel& model, std::uint32_t triangle);

/// Measures a model; the model must be valid (see validate_organ_model).
ModelMeasures measure_model(const model::OrganModel& model);

}  // namespace organsim::geometry
