// The spring networks: the paper's flat grid and a baked organ's surface
// (construction rules in mass_spring.h).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "organsim/geometry/model_measures.h"
#include "organsim/geometry/tetrahedral_embedding.h"
#include "organsim/organ/organ.h"
#include "organsim/springs/network.h"

namespace organsim::springs {
namespace {

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

void add_spring(SpringNetwork& net, std::uint32_t a, std::uint32_t b, double stiffness, double damping,
                SpringKind kind) {
  if (a > b) std::swap(a, b);
  net.springs.a.push_back(a);
  net.springs.b.push_back(b);
  net.springs.rest_length.push_back((net.rest[a] - net.rest[b]).norm());
  net.springs.stiffness.push_back(stiffness);
  net.springs.damping.push_back(damping);
  net.springs.kind.push_back(kind);
}

void reserve_springs(Springs& s, std::size_t count) {
  s.a.reserve(count);
  s.b.reserve(count);
  s.rest_length.reserve(count);
  s.stiffness.reserve(count);
  s.damping.reserve(count);
  s.kind.reserve(count);
}

/// Every tetrahedron edge once (node indices offset by `base`), then four ties
/// per surface vertex to the corners of the tetrahedron it is embedded in.
void add_volume_springs(SpringNetwork& net, const model::OrganModel& model, std::size_t base, double edge_stiffness,
                        double edge_damping, double tie_stiffness, double tie_damping) {
  for (const model::Tetrahedron& t : model.tetrahedra)
    for (std::uint32_t corner : t)
      if (corner >= model.volume_vertices.size())
        throw std::invalid_argument("make_organ_network: a tetrahedron's vertex index is out of range");
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  edges.reserve(6 * model.tetrahedra.size());
  for (const model::Tetrahedron& t : model.tetrahedra)
    for (std::size_t i = 0; i < 4; ++i)
      for (std::size_t j = i + 1; j < 4; ++j) edges.emplace_back(std::min(t[i], t[j]), std::max(t[i], t[j]));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  const geometry::SurfaceEmbedding embedding =
      geometry::embed_surface_in_tetrahedra(model, geometry::tetrahedral_boundary(model.tetrahedra));
  reserve_springs(net.springs, net.springs.size() + edges.size() + 4 * embedding.hosts.size());
  const auto offset = static_cast<std::uint32_t>(base);
  for (const auto& [a, b] : edges)
    add_spring(net, offset + a, offset + b, edge_stiffness, edge_damping, SpringKind::volume);
  for (std::uint32_t v = 0; v < embedding.hosts.size(); ++v)
    for (std::uint32_t corner : embedding.hosts[v])
      add_spring(net, v, offset + corner, tie_stiffness, tie_damping, SpringKind::volume);
}

bool non_negative(double value) { return std::isfinite(value) && value >= 0.0; }
bool positive(double value) { return std::isfinite(value) && value > 0.0; }

}  // namespace

SpringNetwork make_grid_network(const GridOptions& o) {
  auto require = [](bool ok, const char* problem) {
    if (!ok) throw std::invalid_argument(std::string("make_grid_network: ") + problem);
  };
  require(o.columns >= 3, "columns must be at least 3");
  require(o.rows >= 3, "rows must be at least 3");
  require(static_cast<std::uint64_t>(o.columns) * o.rows <= (std::uint64_t{1} << 30), "the grid is too large");
  require(positive(o.spacing), "spacing must be positive and finite (m)");
  require(positive(o.mass), "mass must be positive and finite (kg)");
  require(non_negative(o.structural_stiffness) && non_negative(o.shear_stiffness) && non_negative(o.bending_stiffness),
          "stiffnesses must be non-negative and finite (N/m)");
  require(non_negative(o.structural_damping) && non_negative(o.shear_damping) && non_negative(o.bending_damping),
          "dampings must be non-negative and finite (N·s/m)");
  require(non_negative(o.body_factor), "body_factor must be non-negative and finite");

  const std::uint32_t n = o.columns, m = o.rows, count = n * m;
  const bool body = o.body_factor > 0.0;
  auto index = [n](std::uint32_t i, std::uint32_t j) { return i + n * j; };
  SpringNetwork net;
  net.surface_nodes = count;
  const std::size_t nodes = body ? 2 * std::size_t{count} : count;
  net.rest.reserve(nodes);
  for (std::uint32_t j = 0; j < m; ++j)
    for (std::uint32_t i = 0; i < n; ++i) net.rest.emplace_back(i * o.spacing, j * o.spacing, 0.0);
  if (body)
    for (std::uint32_t v = 0; v < count; ++v) net.rest.push_back(net.rest[v] - Eigen::Vector3d(0.0, 0.0, o.spacing));
  net.mass.assign(nodes, o.mass);
  net.fixed.assign(nodes, 0);
  for (std::uint32_t j = 0; j < m; ++j)
    for (std::uint32_t i = 0; i < n; ++i)
      if (o.fix_border && (i == 0 || i == n - 1 || j == 0 || j == m - 1)) net.fixed[index(i, j)] = 1;
  for (std::size_t v = count; v < nodes; ++v) net.fixed[v] = 1;

  net.triangles.reserve(2 * std::size_t{n - 1} * (m - 1));
  for (std::uint32_t j = 0; j + 1 < m; ++j)
    for (std::uint32_t i = 0; i + 1 < n; ++i) {
      net.triangles.push_back({index(i, j), index(i + 1, j), index(i + 1, j + 1)});
      net.triangles.push_back({index(i, j), index(i + 1, j + 1), index(i, j + 1)});
    }

  const std::size_t structural = 2 * std::size_t{count} - n - m, shear = 2 * std::size_t{n - 1} * (m - 1),
                    bending = std::size_t{n} * (m - 2) + std::size_t{m} * (n - 2);
  reserve_springs(net.springs, structural + shear + bending + (body ? count : 0));
  for (std::uint32_t j = 0; j < m; ++j)
    for (std::uint32_t i = 0; i < n; ++i) {
      if (i + 1 < n)
        add_spring(net, index(i, j), index(i + 1, j), o.structural_stiffness, o.structural_damping,
                   SpringKind::structural);
      if (j + 1 < m)
        add_spring(net, index(i, j), index(i, j + 1), o.structural_stiffness, o.structural_damping,
                   SpringKind::structural);
    }
  for (std::uint32_t j = 0; j + 1 < m; ++j)
    for (std::uint32_t i = 0; i + 1 < n; ++i) {
      add_spring(net, index(i, j), index(i + 1, j + 1), o.shear_stiffness, o.shear_damping, SpringKind::shear);
      add_spring(net, index(i + 1, j), index(i, j + 1), o.shear_stiffness, o.shear_damping, SpringKind::shear);
    }
  for (std::uint32_t j = 0; j < m; ++j)
    for (std::uint32_t i = 0; i < n; ++i) {
      if (i + 2 < n)
        add_spring(net, index(i, j), index(i + 2, j), o.bending_stiffness, o.bending_damping, SpringKind::bending);
      if (j + 2 < m)
        add_spring(net, index(i, j), index(i, j + 2), o.bending_stiffness, o.bending_damping, SpringKind::bending);
    }
  if (body)
    for (std::uint32_t v = 0; v < count; ++v)
      add_spring(net, v, count + v, o.body_factor * o.structural_stiffness, o.body_factor * o.structural_damping,
                 SpringKind::body);
  return net;
}

namespace {

void require(bool ok, const std::string& problem) {
  if (!ok) throw std::invalid_argument("make_organ_network: " + problem);
}

void check_organ_network_inputs(const model::OrganModel& model, const OrganNetworkOptions& o) {
  require(!model.surface_triangles.empty(), "the model has no surface triangles");
  require(non_negative(o.stiffness), "stiffness must be non-negative and finite (N/m)");
  require(non_negative(o.bending_factor), "bending_factor must be non-negative and finite");
  require(non_negative(o.damping), "damping must be non-negative and finite (N s/m)");
  require(non_negative(o.critical_fraction), "critical_fraction must be non-negative and finite");
  require(non_negative(o.body_factor), "body_factor must be non-negative and finite");
  require(non_negative(o.anchor_depth), "anchor_depth must be non-negative and finite (m)");
  require(non_negative(o.uniform_mass), "uniform_mass must be non-negative and finite (kg)");
  require(non_negative(o.clamp_radius), "clamp_radius must be non-negative and finite (m)");
  require(non_negative(o.volume_factor), "volume_factor must be non-negative and finite");
  require(!(o.volume_springs && o.area_weighted_mass), "area_weighted_mass does not combine with volume_springs");
  require(!o.volume_springs || !model.tetrahedra.empty(),
          "volume springs need the model's tetrahedra: re-bake it with organsim bake, which meshes the volume");
  const std::size_t vertex_count = model.surface_vertices.size();
  require(vertex_count <= (std::size_t{1} << 30), "the surface is too large");
  for (const model::Point3& p : model.surface_vertices)
    require(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]), "a surface vertex is not finite");
  for (const model::Triangle& t : model.surface_triangles) {
    require(t[0] < vertex_count && t[1] < vertex_count && t[2] < vertex_count,
            "a surface triangle's vertex index is out of range");
    require(t[0] != t[1] && t[1] != t[2] && t[0] != t[2], "a surface triangle repeats a vertex");
  }
}

/// The surface's edges as triangle sides (low, high, opposite vertex), sorted
/// so that the sides of one edge are adjacent.
struct SurfaceEdges {
  struct Side {
    std::uint32_t a, b, opposite;
  };
  std::vector<Side> sides;
  std::size_t edge_count = 0;
  std::size_t interior = 0;  ///< edges between two triangles with distinct far vertices (a bending spring each)
  double mean_length = 0.0;  ///< m

  bool first_side_of_edge(std::size_t s) const {
    return s == 0 || sides[s].a != sides[s - 1].a || sides[s].b != sides[s - 1].b;
  }
  /// Calls visit(s, e) for each edge's sides [s, e).
  template <typename Visit>
  void for_each_edge(Visit visit) const {
    for (std::size_t s = 0; s < sides.size();) {
      std::size_t e = s + 1;
      while (e < sides.size() && sides[e].a == sides[s].a && sides[e].b == sides[s].b) ++e;
      visit(s, e);
      s = e;
    }
  }
};

SurfaceEdges surface_edges(const model::OrganModel& model) {
  SurfaceEdges edges;
  edges.sides.reserve(3 * model.surface_triangles.size());
  for (const model::Triangle& t : model.surface_triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k], b = t[(k + 1) % 3];
      edges.sides.push_back({std::min(a, b), std::max(a, b), t[(k + 2) % 3]});
    }
  std::sort(edges.sides.begin(), edges.sides.end(), [](const SurfaceEdges::Side& l, const SurfaceEdges::Side& r) {
    return l.a != r.a ? l.a < r.a : l.b != r.b ? l.b < r.b : l.opposite < r.opposite;
  });
  double length_sum = 0.0;
  for (std::size_t s = 0; s < edges.sides.size(); ++s)
    if (edges.first_side_of_edge(s)) {
      length_sum +=
          (vec(model.surface_vertices[edges.sides[s].a]) - vec(model.surface_vertices[edges.sides[s].b])).norm();
      ++edges.edge_count;
    }
  edges.mean_length = length_sum / static_cast<double>(edges.edge_count);
  require(edges.mean_length > 0.0, "the surface edges have zero length");
  edges.for_each_edge([&](std::size_t s, std::size_t e) {
    if (e - s == 2 && edges.sides[s].opposite != edges.sides[s + 1].opposite) ++edges.interior;
  });
  return edges;
}

using Normals = std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>;

/// Each surface vertex's area (a third of each adjacent triangle's, m²) and
/// area-weighted normal (not normalized); the total area.
double vertex_areas_and_normals(const model::OrganModel& model, std::vector<double>& area, Normals& normal) {
  const std::size_t vertex_count = model.surface_vertices.size();
  area.assign(vertex_count, 0.0);
  normal.assign(vertex_count, Eigen::Vector3d::Zero());
  double total_area = 0.0;
  for (const model::Triangle& t : model.surface_triangles) {
    const Eigen::Vector3d a = vec(model.surface_vertices[t[0]]), b = vec(model.surface_vertices[t[1]]),
                          c = vec(model.surface_vertices[t[2]]);
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    const double third = cross.norm() / 6.0;
    for (int j = 0; j < 3; ++j) {
      area[t[j]] += third;
      normal[t[j]] += cross;
    }
    total_area += 3.0 * third;
  }
  for (std::size_t v = 0; v < vertex_count; ++v)
    require(area[v] > 0.0, "surface vertex " + std::to_string(v) + " lies on no (non-degenerate) triangle");
  return total_area;
}

/// The surface nodes' masses (kg): uniform_mass, or the organ's mass
/// (density × volume) shared equally or by area.
std::vector<double> surface_masses(const model::OrganModel& model, const OrganNetworkOptions& o,
                                   const std::vector<double>& area, double total_area) {
  const std::size_t vertex_count = model.surface_vertices.size();
  std::vector<double> mass(vertex_count, o.uniform_mass);
  if (o.uniform_mass != 0.0) return mass;
  const double density = model.material.density;
  require(std::isfinite(density) && density > 0.0, "the model's density must be positive to lump masses");
  double volume = 0.0;
  if (!model.tetrahedra.empty()) {
    for (const model::Tetrahedron& t : model.tetrahedra) {
      require(t[0] < model.volume_vertices.size() && t[1] < model.volume_vertices.size() &&
                  t[2] < model.volume_vertices.size() && t[3] < model.volume_vertices.size(),
              "a tetrahedron's vertex index is out of range");
      volume += geometry::signed_tetrahedron_volume(vec(model.volume_vertices[t[0]]), vec(model.volume_vertices[t[1]]),
                                                    vec(model.volume_vertices[t[2]]), vec(model.volume_vertices[t[3]]));
    }
  } else {
    volume = geometry::enclosed_volume(model.surface_vertices, model.surface_triangles);
  }
  require(std::isfinite(volume) && volume > 0.0, "the organ's volume must be positive to lump masses");
  // With volume springs the tetrahedral nodes are simulated too and take their shares.
  const std::size_t sharing = vertex_count + (o.volume_springs ? model.volume_vertices.size() : 0);
  for (std::size_t v = 0; v < vertex_count; ++v)
    mass[v] = density * volume * (o.area_weighted_mass ? area[v] / total_area : 1.0 / static_cast<double>(sharing));
  return mass;
}

/// The network's nodes: the surface, its anchors `depth` inside along the
/// normals (fixed; with body springs), the tetrahedral nodes (volume springs),
/// and those within clamp_radius of the fixed point fixed. Returns the index
/// of the first tetrahedral node.
std::size_t add_nodes(SpringNetwork& net, const model::OrganModel& model, const OrganNetworkOptions& o,
                      const std::vector<double>& mass, double mean_mass, const Normals& normal, double depth) {
  const std::size_t vertex_count = model.surface_vertices.size();
  const bool body = o.body_factor > 0.0;
  net.surface_nodes = vertex_count;
  const std::size_t nodes = body ? 2 * vertex_count : vertex_count;
  net.rest.reserve(nodes);
  for (const model::Point3& p : model.surface_vertices) net.rest.push_back(vec(p));
  if (body)
    for (std::size_t v = 0; v < vertex_count; ++v) {
      const double length = normal[v].norm();
      require(length > 0.0, "surface vertex " + std::to_string(v) + " has no normal (its triangles cancel)");
      net.rest.push_back(net.rest[v] - depth * normal[v] / length);
    }
  net.mass = mass;
  if (body) net.mass.insert(net.mass.end(), mass.begin(), mass.end());
  net.fixed.assign(nodes, 0);
  for (std::size_t v = vertex_count; v < nodes; ++v) net.fixed[v] = 1;
  const std::size_t volume_base = nodes;
  if (o.volume_springs) {
    for (const model::Point3& p : model.volume_vertices) {
      require(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]), "a tetrahedral node is not finite");
      net.rest.push_back(vec(p));
    }
    net.mass.resize(net.rest.size(), mean_mass);
    net.fixed.resize(net.rest.size(), 0);
  }
  if (o.clamp_radius > 0.0) {
    require(!model.fixed_points.empty(), "clamp_radius needs a fixed point");
    const Eigen::Vector3d centre = vec(model.fixed_points[0]);
    for (std::size_t v = 0; v < vertex_count; ++v)
      if (organ::within_clamp(net.rest[v], centre, o.clamp_radius)) net.fixed[v] = 1;
    for (std::size_t v = volume_base; v < net.rest.size(); ++v)
      if (organ::within_clamp(net.rest[v], centre, o.clamp_radius)) net.fixed[v] = 1;
  }
  return volume_base;
}

}  // namespace

SpringNetwork make_organ_network(const model::OrganModel& model, const OrganNetworkOptions& o) {
  check_organ_network_inputs(model, o);
  const std::size_t vertex_count = model.surface_vertices.size();
  const SurfaceEdges edges = surface_edges(model);
  const double k = o.stiffness > 0.0
                       ? o.stiffness
                       : model.material.young_modulus * model.material.spring_stiffness_scale * edges.mean_length;
  require(std::isfinite(k) && k > 0.0, "the structural spring constant is zero: set stiffness or the model's E");
  const double depth = o.anchor_depth > 0.0 ? o.anchor_depth : edges.mean_length;

  std::vector<double> area;
  Normals normal;
  const double total_area = vertex_areas_and_normals(model, area, normal);
  const std::vector<double> mass = surface_masses(model, o, area, total_area);
  double mean_mass = 0.0;
  for (double m : mass) mean_mass += m / static_cast<double>(vertex_count);
  const double d = o.damping > 0.0 ? o.damping : o.critical_fraction * 2.0 * std::sqrt(k * mean_mass);

  SpringNetwork net;
  const std::size_t volume_base = add_nodes(net, model, o, mass, mean_mass, normal, depth);
  net.triangles = model.surface_triangles;

  // Springs: structural edges, bending across interior edges, body, volume.
  const bool body = o.body_factor > 0.0;
  reserve_springs(net.springs, edges.edge_count + edges.interior + (body ? vertex_count : 0));
  for (std::size_t s = 0; s < edges.sides.size(); ++s)
    if (edges.first_side_of_edge(s)) add_spring(net, edges.sides[s].a, edges.sides[s].b, k, d, SpringKind::structural);
  const double kb = o.bending_factor * k;
  edges.for_each_edge([&](std::size_t s, std::size_t e) {
    if (e - s == 2 && edges.sides[s].opposite != edges.sides[s + 1].opposite)
      add_spring(net, edges.sides[s].opposite, edges.sides[s + 1].opposite, kb, o.bending_factor * d,
                 SpringKind::bending);
  });
  const auto ns = static_cast<std::uint32_t>(vertex_count);
  if (body)
    for (std::uint32_t v = 0; v < ns; ++v)
      add_spring(net, v, ns + v, o.body_factor * k, o.body_factor * d, SpringKind::body);
  if (o.volume_springs) add_volume_springs(net, model, volume_base, o.volume_factor * k, o.volume_factor * d, k, d);
  if (o.supports && model.supports.vertices.size() == vertex_count)
    for (std::uint32_t v = 0; v < ns; ++v) {
      const model::Supports::Kind kind = model.supports.kind(v);
      if (kind == model::Supports::Kind::kFree || net.fixed[v]) continue;
      net.supports.push_back(
          {v, model.supports.modulus(v) * area[v], normal[v].normalized(), kind == model::Supports::Kind::kContact});
    }
  return net;
}

}  // namespace organsim::springs
