#include "test_models.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "organsim/model/beam_frame.h"
#include "organsim/organ/organ.h"

namespace organsim::testing {
namespace {

constexpr double kPi = 3.14159265358979323846;

model::Point3 add(const model::Point3& a, const model::Point3& b, double s) {
  return {a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]};
}

/// Section of the solid cylinder {0 ≤ x ≤ L, y² + z² ≤ r²} cut by the plane
/// through `centre` (inside the solid) with normal frame.x. The section is
/// convex, so its boundary is traced exactly along rays from `centre` (ray vs
/// cylinder wall and caps, in closed form) and integrated as a polygon.
model::BeamSection cylinder_section(const CylinderSpec& c, const model::Point3& centre, const model::BeamFrame& frame) {
  const unsigned n = c.section_polygon_vertices;
  std::vector<std::array<double, 2>> polygon(n);
  for (unsigned i = 0; i < n; ++i) {
    const double phi = 2.0 * kPi * i / n;
    const model::Point3 d = add({frame.y[0] * std::cos(phi), frame.y[1] * std::cos(phi), frame.y[2] * std::cos(phi)},
                                frame.z, std::sin(phi));
    double reach = std::numeric_limits<double>::infinity();
    const double a = d[1] * d[1] + d[2] * d[2];
    if (a > 1e-300) {
      const double b = 2.0 * (centre[1] * d[1] + centre[2] * d[2]);
      const double k = centre[1] * centre[1] + centre[2] * centre[2] - c.radius * c.radius;
      reach = (-b + std::sqrt(std::max(0.0, b * b - 4.0 * a * k))) / (2.0 * a);
    }
    if (d[0] > 0) reach = std::min(reach, (c.length - centre[0]) / d[0]);
    if (d[0] < 0) reach = std::min(reach, -centre[0] / d[0]);
    reach = std::max(reach, 0.0);
    polygon[i] = {reach * std::cos(phi), reach * std::sin(phi)};
  }
  double area = 0, first_y = 0, first_z = 0, second_yy = 0, second_zz = 0, second_yz = 0;
  for (unsigned i = 0; i < n; ++i) {
    const auto [y0, z0] = polygon[i];
    const auto [y1, z1] = polygon[(i + 1) % n];
    const double cross = y0 * z1 - y1 * z0;
    area += cross / 2.0;
    first_y += (y0 + y1) * cross / 6.0;
    first_z += (z0 + z1) * cross / 6.0;
    second_yy += (y0 * y0 + y0 * y1 + y1 * y1) * cross / 12.0;  // ∫ y² dA
    second_zz += (z0 * z0 + z0 * z1 + z1 * z1) * cross / 12.0;  // ∫ z² dA
    second_yz += (y0 * z1 + 2 * y0 * z0 + 2 * y1 * z1 + y1 * z0) * cross / 24.0;
  }
  model::BeamSection s;
  if (area <= 0) return s;
  s.area = area;
  s.centroid_y = first_y / area;
  s.centroid_z = first_z / area;
  s.i_yy = second_zz - area * s.centroid_z * s.centroid_z;
  s.i_zz = second_yy - area * s.centroid_y * s.centroid_y;
  s.i_yz = second_yz - area * s.centroid_y * s.centroid_z;
  // Saint-Venant's approximation, exact for circles and ellipses.
  s.torsion_j = std::pow(s.area, 4) / (4.0 * kPi * kPi * (s.i_yy + s.i_zz));
  return s;
}

}  // namespace

model::OrganModel make_cylinder_model(const CylinderSpec& c) {
  model::OrganModel m;
  m.provenance.program_version = "test";
  m.provenance.parameters["shape"] = "cylinder";
  const unsigned n = c.segments;
  // Vertices: ring k (0..rings) at x = k L / rings, then the two cap centres.
  for (unsigned k = 0; k <= c.rings; ++k)
    for (unsigned i = 0; i < n; ++i) {
      const double angle = 2.0 * kPi * i / n;
      m.surface_vertices.push_back({c.length * k / c.rings, c.radius * std::cos(angle), c.radius * std::sin(angle)});
      m.surface_texcoords.push_back({static_cast<double>(i) / n, static_cast<double>(k) / c.rings});
    }
  const auto near_cap = static_cast<std::uint32_t>(m.surface_vertices.size());
  m.surface_vertices.push_back({0.0, 0.0, 0.0});
  m.surface_vertices.push_back({c.length, 0.0, 0.0});
  m.surface_texcoords.push_back({0.5, 0.0});
  m.surface_texcoords.push_back({0.5, 1.0});
  const std::uint32_t far_cap = near_cap + 1;
  auto ring = [n](unsigned k, unsigned i) { return static_cast<std::uint32_t>(k * n + i % n); };
  for (unsigned k = 0; k < c.rings; ++k)
    for (unsigned i = 0; i < n; ++i) {
      // Outward: the side normal points away from the x axis.
      m.surface_triangles.push_back({ring(k, i), ring(k, i + 1), ring(k + 1, i + 1)});
      m.surface_triangles.push_back({ring(k, i), ring(k + 1, i + 1), ring(k + 1, i)});
    }
  for (unsigned i = 0; i < n; ++i) {
    m.surface_triangles.push_back({near_cap, ring(0, i + 1), ring(0, i)});
    m.surface_triangles.push_back({far_cap, ring(c.rings, i), ring(c.rings, i + 1)});
  }

  // Tetrahedra: each layer is a fan of triangular prisms around the axis; each
  // prism (axis a0 a1, rim b0 b1 at x0; same at x1) is cut into 3 positive tets.
  m.volume_vertices = m.surface_vertices;
  std::vector<std::uint32_t> axis(c.rings + 1);
  axis[0] = near_cap;
  axis[c.rings] = far_cap;
  for (unsigned k = 1; k < c.rings; ++k) {
    axis[k] = static_cast<std::uint32_t>(m.volume_vertices.size());
    m.volume_vertices.push_back({c.length * k / c.rings, 0.0, 0.0});
  }
  for (unsigned k = 0; k < c.rings; ++k)
    for (unsigned i = 0; i < n; ++i) {
      const std::uint32_t a = axis[k], b = ring(k, i), cc = ring(k, i + 1);
      const std::uint32_t d = axis[k + 1], e = ring(k + 1, i), f = ring(k + 1, i + 1);
      m.tetrahedra.push_back({a, b, cc, d});
      m.tetrahedra.push_back({b, cc, d, e});
      m.tetrahedra.push_back({cc, d, e, f});
    }
  for (model::Tetrahedron& t : m.tetrahedra) {
    const auto& p = m.volume_vertices;
    const model::Point3 &a = p[t[0]], &b = p[t[1]], &cc = p[t[2]], &d = p[t[3]];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {cc[0] - a[0], cc[1] - a[1], cc[2] - a[2]};
    const double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    const double det =
        u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
    if (det < 0) std::swap(t[2], t[3]);
  }

  m.fixed_points.push_back({0.0, 0.0, 0.0});
  m.material = model::liver_default_material();
  m.beams.stations_per_beam = c.stations;
  m.beams.sections.resize(m.surface_vertices.size() * c.stations);
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v) {
    model::BeamFrame frame;
    if (!model::make_beam_frame(m.fixed_points[0], m.surface_vertices[v], frame)) continue;  // the near cap centre
    for (std::uint32_t s = 0; s < c.stations; ++s) {
      const double t = (s + 0.5) / c.stations;
      const model::Point3 centre =
          add(m.fixed_points[0], {m.surface_vertices[v][0], m.surface_vertices[v][1], m.surface_vertices[v][2]}, t);
      m.beams.sections[v * c.stations + s] = cylinder_section(c, centre, frame);
    }
  }
  return m;
}

model::OrganModel make_sphere_model(std::size_t vertex_count, std::uint32_t stations) {
  model::OrganModel m;
  m.provenance.program_version = "test";
  const double radius = 0.08;
  // Latitude rings × longitude segments plus two poles ≈ vertex_count.
  const auto segments = static_cast<unsigned>(std::max(8.0, std::sqrt(2.0 * vertex_count)));
  const auto rings = static_cast<unsigned>(std::max<std::size_t>(3, (vertex_count - 2) / segments));
  m.surface_vertices.push_back({0.0, 0.0, radius});
  for (unsigned r = 1; r <= rings; ++r) {
    const double polar = kPi * r / (rings + 1);
    for (unsigned s = 0; s < segments; ++s) {
      const double azimuth = 2.0 * kPi * s / segments;
      m.surface_vertices.push_back({radius * std::sin(polar) * std::cos(azimuth),
                                    radius * std::sin(polar) * std::sin(azimuth), radius * std::cos(polar)});
    }
  }
  m.surface_vertices.push_back({0.0, 0.0, -radius});
  const auto south = static_cast<std::uint32_t>(m.surface_vertices.size() - 1);
  auto at = [segments](unsigned r, unsigned s) {
    return static_cast<std::uint32_t>(1 + (r - 1) * segments + s % segments);
  };
  for (unsigned s = 0; s < segments; ++s) {
    m.surface_triangles.push_back({0, at(1, s), at(1, s + 1)});
    m.surface_triangles.push_back({south, at(rings, s + 1), at(rings, s)});
  }
  for (unsigned r = 1; r < rings; ++r)
    for (unsigned s = 0; s < segments; ++s) {
      m.surface_triangles.push_back({at(r, s), at(r + 1, s), at(r + 1, s + 1)});
      m.surface_triangles.push_back({at(r, s), at(r + 1, s + 1), at(r, s + 1)});
    }
  // In the order organsim bake writes (the runtime's), like a baked model.
  organ::renumber_in_morton_order(m.surface_vertices, m.surface_triangles);
  m.volume_vertices = m.surface_vertices;
  m.volume_vertices.push_back({0.0, 0.0, 0.0});
  const auto centre = static_cast<std::uint32_t>(m.volume_vertices.size() - 1);
  for (const model::Triangle& t : m.surface_triangles) m.tetrahedra.push_back({centre, t[0], t[1], t[2]});
  m.fixed_points.push_back({0.0, 0.0, 0.0});
  m.material = model::liver_default_material();
  m.beams.stations_per_beam = stations;
  model::BeamSection section;
  section.area = kPi * 0.02 * 0.02;
  section.i_yy = section.i_zz = kPi * std::pow(0.02, 4) / 4.0;
  section.torsion_j = 2.0 * section.i_yy;
  m.beams.sections.assign(m.surface_vertices.size() * stations, section);
  return m;
}

void add_uniform_site_compliance(model::OrganModel& model, double compliance) {
  model.sites.young_modulus = model.material.young_modulus;
  model.sites.poisson_ratio = 0.49;
  model.sites.compliance.assign(model.surface_vertices.size(), {compliance, compliance, compliance, 0.0, 0.0, 0.0});
  model.sites.depth_curve = {{{0.0, 1.0}}, {{0.003, 1.5}}};
  model.sites.curve_tip_radius = 2.5e-3;
}

}  // namespace organsim::testing
