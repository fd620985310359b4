// Models with known geometry for tests, benchmarks and the demo, built without
// the pipeline so that runtime tests do not depend on it.
#pragma once

#include <cstdint>

#include "organsim/model/organ_model.h"

namespace organsim::testing {

/// A solid circular cylinder along +x from x = 0 to x = length, radius `radius`
/// (metres), fixed at the centre of the x = 0 cap. Its surface is a closed,
/// outward triangulation (`segments` around, `rings` along, cap centres); its
/// tetrahedra fill the same polygonal solid; its beam tables hold the sections
/// of the exact circular cylinder, traced as fine polygons in each beam's frame.
struct CylinderSpec {
  double radius = 0.03;
  double length = 0.15;
  unsigned segments = 24;
  unsigned rings = 12;
  std::uint32_t stations = 20;
  unsigned section_polygon_vertices = 720;  ///< boundary resolution of each integrated section
};

model::OrganModel make_cylinder_model(const CylinderSpec& spec);

/// A model with a large closed surface (a UV sphere with about `vertex_count`
/// vertices), tetrahedra from a fan to the centre, and constant beam tables —
/// for load and throughput benchmarks where only the sizes matter.
model::OrganModel make_sphere_model(std::size_t vertex_count, std::uint32_t stations);

/// Isotropic site compliances of `compliance` m/N at every surface vertex (the
/// reference's E, ν = 0.49) and a depth curve rising from 1 to 1.5 at 3 mm (tip
/// 2.5 mm): the fast models then give the site law's force (docs/matching.md).
void add_uniform_site_compliance(model::OrganModel& model, double compliance);

}  // namespace organsim::testing
