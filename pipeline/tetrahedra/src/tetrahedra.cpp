#include "organsim/tetrahedra/tetrahedra.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polyhedral_mesh_domain_3.h>
#include <CGAL/Random.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/make_mesh_3.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include <fmt/format.h>

#include "organsim/geometry/model_measures.h"
#include "organsim/tetrahedra/connected_part.h"
#include "organsim/tetrahedra/sliver_removal.h"
#include "organsim/tetrahedra/volume_matching.h"

namespace organsim::pipeline {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalSurface = CGAL::Surface_mesh<Kernel::Point_3>;
using Domain = CGAL::Polyhedral_mesh_domain_3<CgalSurface, Kernel>;
// Sequential: the parallel mesher's result depends on thread scheduling.
using Triangulation = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using Complex = CGAL::Mesh_complex_3_in_triangulation_3<Triangulation>;
using Criteria = CGAL::Mesh_criteria_3<Triangulation>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kMillimetre = 1e-3;
// Optimization: our own sliver removal (sliver_removal.h), bounded by rounds
// and angles, never by time (a time limit would make the mesh depend on the
// machine's speed). Mesh_3's optimizers are not used: its sliver perturber's
// result depends on memory addresses (two runs gave different meshes), and
// one Lloyd iteration plus sliver exudation cost 0.7–1.0 s on the DICOM liver
// (18k tetrahedra) and left slivers whose four vertices lie on the boundary,
// which only flips fix. Refinement, then flips, peeling and vertex moves:
// 0.5 + 0.5–0.8 s there, every dihedral angle above 15° and every
// radius–edge ratio below 3. The bound is a little above 15° (ρ = 3 reads as
// 15°) so that a last-bit difference cannot leave a tetrahedron just past it.
constexpr double kSliverBoundDeg = 15.5;

/// Mesh_3 works in millimetres so that its criteria read as the user gave them.
CgalSurface to_cgal(const geometry::SurfaceMesh& surface) {
  CgalSurface mesh;
  std::vector<CgalSurface::Vertex_index> ids;
  ids.reserve(surface.vertices.size());
  for (const model::Point3& p : surface.vertices)
    ids.push_back(mesh.add_vertex({p[0] / kMillimetre, p[1] / kMillimetre, p[2] / kMillimetre}));
  for (const model::Triangle& t : surface.triangles)
    if (mesh.add_face(ids[t[0]], ids[t[1]], ids[t[2]]) == CgalSurface::null_face())
      throw std::runtime_error(
          "the surface cannot be meshed: it is not an oriented 2-manifold; rebuild it from a cleaner mask");
  return mesh;
}

void check_options(const TetrahedraOptions& o) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(o.tet_size_mm))
    throw std::runtime_error(fmt::format("--tet-size must be positive (got {})", o.tet_size_mm));
  if (!positive(o.facet_distance_mm))
    throw std::runtime_error(fmt::format("--facet-distance must be positive (got {} mm)", o.facet_distance_mm));
  if (!(o.facet_angle_deg > 0.0 && o.facet_angle_deg <= 30.0))
    throw std::runtime_error(fmt::format(
        "the facet angle must lie in (0, 30] degrees, where Mesh_3 terminates (got {})", o.facet_angle_deg));
  for (const LocalRefinement& r : o.refinements)
    if (!std::isfinite(r.centre[0]) || !std::isfinite(r.centre[1]) || !std::isfinite(r.centre[2]) ||
        !(r.radius_mm >= 0.0 && std::isfinite(r.radius_mm)) || !positive(r.size_mm))
      throw std::runtime_error(
          fmt::format("a refinement needs a finite centre, a radius of 0 or more and a positive size (got radius {} "
                      "mm, size {} mm)",
                      r.radius_mm, r.size_mm));
  if (!(o.radius_edge_ratio >= 2.0 && std::isfinite(o.radius_edge_ratio)))
    throw std::runtime_error(fmt::format(
        "the radius-edge ratio bound must be at least 2, where Mesh_3 terminates (got {})", o.radius_edge_ratio));
}

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

/// Mesh_3's sizing field (mm): the mesh's size, smaller around each
/// refinement, for the cells and the boundary facets alike.
class GradedSize {
 public:
  using FT = Kernel::FT;
  explicit GradedSize(const TetrahedraOptions& o) : uniform_(o.tet_size_mm) {
    for (const LocalRefinement& r : o.refinements)
      refinements_.push_back({vec(r.centre) / kMillimetre, r.radius_mm, r.size_mm});
  }
  template <typename Index>
  FT operator()(const Kernel::Point_3& p, int /*dimension*/, const Index& /*index*/) const {
    const Eigen::Vector3d at(p.x(), p.y(), p.z());
    double size = uniform_;
    for (const Refinement& r : refinements_)
      size = std::min(size, r.size + kRefinementGrading * std::max(0.0, (at - r.centre).norm() - r.radius));
    return size;
  }

 private:
  struct Refinement {
    Eigen::Vector3d centre;  // mm
    double radius, size;     // mm
  };
  double uniform_;
  std::vector<Refinement> refinements_;
};

/// Mesh_3 visits cells in an order that depends on memory addresses, so the
/// same mesh comes out in different orders from run to run. Sorting vertices by
/// position and tetrahedra by their (rotated) indices gives one order.
void canonicalize(geometry::TetrahedralMesh& mesh) {
  std::vector<std::uint32_t> order(mesh.vertices.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return mesh.vertices[a] < mesh.vertices[b]; });
  std::vector<std::uint32_t> new_index(order.size());
  std::vector<model::Point3> vertices(order.size());
  for (std::uint32_t i = 0; i < order.size(); ++i) {
    new_index[order[i]] = i;
    vertices[i] = mesh.vertices[order[i]];
  }
  mesh.vertices = std::move(vertices);
  for (model::Tetrahedron& t : mesh.tetrahedra) {
    for (std::uint32_t& v : t) v = new_index[v];
    // Smallest index first, by even permutations only (they keep the orientation).
    const auto smallest = std::min_element(t.begin(), t.end()) - t.begin();
    if (smallest == 1) t = {t[1], t[0], t[3], t[2]};
    if (smallest == 2) t = {t[2], t[3], t[0], t[1]};
    if (smallest == 3) t = {t[3], t[2], t[1], t[0]};
    while (t[1] > t[2] || t[1] > t[3]) t = {t[0], t[2], t[3], t[1]};
  }
  std::sort(mesh.tetrahedra.begin(), mesh.tetrahedra.end());
}

}  // namespace

LocalRefinement clamp_refinement(const model::Point3& fixed_point, double clamp_radius_m, double size_mm) {
  return {fixed_point, clamp_radius_m / kMillimetre, size_mm};
}

geometry::TetrahedralMesh make_tetrahedra(const geometry::SurfaceMesh& surface, const TetrahedraOptions& options) {
  check_options(options);
  const CgalSurface input = to_cgal(surface);
  CGAL::Random random(0);
  Domain domain(input, &random);
  namespace p = CGAL::parameters;
  // A uniform size where nothing is refined: Mesh_3 takes a constant faster
  // than a field, and the mesh stays what it was before refinements existed.
  const Complex complex = [&] {
    if (options.refinements.empty()) {
      const Criteria criteria(p::facet_angle = options.facet_angle_deg, p::facet_size = options.tet_size_mm,
                              p::facet_distance = options.facet_distance_mm,
                              p::cell_radius_edge_ratio = options.radius_edge_ratio,
                              p::cell_size = options.tet_size_mm);
      // Mesh_3's own optimizers are not used (see above): refinement only.
      return CGAL::make_mesh_3<Complex>(domain, criteria, p::no_perturb(), p::no_exude());
    }
    const GradedSize size(options);
    const Criteria criteria(p::facet_angle = options.facet_angle_deg, p::facet_size = size,
                            p::facet_distance = options.facet_distance_mm,
                            p::cell_radius_edge_ratio = options.radius_edge_ratio, p::cell_size = size);
    return CGAL::make_mesh_3<Complex>(domain, criteria, p::no_perturb(), p::no_exude());
  }();

  geometry::TetrahedralMesh mesh;
  std::unordered_map<Triangulation::Vertex_handle, std::uint32_t> index;
  for (auto cell = complex.cells_in_complex_begin(); cell != complex.cells_in_complex_end(); ++cell) {
    model::Tetrahedron tet{};
    for (int corner = 0; corner < 4; ++corner) {
      const auto vertex = cell->vertex(corner);
      auto [at, inserted] = index.try_emplace(vertex, static_cast<std::uint32_t>(mesh.vertices.size()));
      if (inserted) {
        const auto& p = vertex->point();
        mesh.vertices.push_back({CGAL::to_double(p.x()) * kMillimetre, CGAL::to_double(p.y()) * kMillimetre,
                                 CGAL::to_double(p.z()) * kMillimetre});
      }
      tet[corner] = at->second;
    }
    const auto& v = mesh.vertices;
    if (geometry::signed_tetrahedron_volume(vec(v[tet[0]]), vec(v[tet[1]]), vec(v[tet[2]]), vec(v[tet[3]])) < 0)
      std::swap(tet[2], tet[3]);
    mesh.tetrahedra.push_back(tet);
  }
  if (mesh.tetrahedra.empty())
    throw std::runtime_error(
        fmt::format("meshing failure: CGAL Mesh_3 produced no tetrahedra for a {}-triangle surface; check that the "
                    "organ is larger than --tet-size ({} mm)",
                    surface.triangles.size(), options.tet_size_mm));
  if (options.optimize) remove_slivers(mesh, {kSliverBoundDeg, 20});
  keep_largest_connected_part(mesh);
  // Boundary facets are chords of the surface (within facet_distance of it):
  // where the organ is convex they cut inside, a thin layer of lost volume.
  match_tetrahedra_volume(mesh, geometry::enclosed_volume(surface.vertices, surface.triangles));
  canonicalize(mesh);
  return mesh;
}

TetrahedralQuality measure_quality(const geometry::TetrahedralMesh& mesh) {
  TetrahedralQuality q;
  q.tetrahedra = mesh.tetrahedra.size();
  if (mesh.tetrahedra.empty()) return q;
  q.min_dihedral_deg = 180.0;
  q.min_volume_m3 = std::numeric_limits<double>::infinity();
  static constexpr int kEdges[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                       {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  double ratio_sum = 0.0;
  for (const model::Tetrahedron& t : mesh.tetrahedra) {
    const Eigen::Vector3d p[4] = {vec(mesh.vertices[t[0]]), vec(mesh.vertices[t[1]]), vec(mesh.vertices[t[2]]),
                                  vec(mesh.vertices[t[3]])};
    const double volume = geometry::signed_tetrahedron_volume(p[0], p[1], p[2], p[3]);
    q.total_volume_m3 += volume;
    q.min_volume_m3 = std::min(q.min_volume_m3, volume);
    double shortest = std::numeric_limits<double>::infinity();
    for (const auto& e : kEdges) {
      // Dihedral angle at edge (a, b) between the faces (a, b, c) and (a, b, d).
      const Eigen::Vector3d axis = (p[e[1]] - p[e[0]]).normalized();
      Eigen::Vector3d u = p[e[2]] - p[e[0]], w = p[e[3]] - p[e[0]];
      u -= u.dot(axis) * axis;
      w -= w.dot(axis) * axis;
      const double angle = std::atan2(u.cross(w).norm(), u.dot(w)) * 180.0 / kPi;
      q.min_dihedral_deg = std::min(q.min_dihedral_deg, angle);
      q.max_dihedral_deg = std::max(q.max_dihedral_deg, angle);
      shortest = std::min(shortest, (p[e[1]] - p[e[0]]).norm());
    }
    // Circumradius: |a² (b×c) + b² (c×a) + c² (a×b)| / (12 V) with edges from p0.
    const Eigen::Vector3d a = p[1] - p[0], b = p[2] - p[0], c = p[3] - p[0];
    const double radius =
        (a.squaredNorm() * b.cross(c) + b.squaredNorm() * c.cross(a) + c.squaredNorm() * a.cross(b)).norm() /
        (12.0 * std::abs(volume));
    const double ratio = radius / shortest;
    q.max_radius_edge_ratio = std::max(q.max_radius_edge_ratio, ratio);
    ratio_sum += ratio;
  }
  q.mean_radius_edge_ratio = ratio_sum / static_cast<double>(mesh.tetrahedra.size());
  return q;
}

std::vector<std::string> tetrahedra_quality_warnings(const TetrahedralQuality& q) {
  std::vector<std::string> warnings;
  if (q.tetrahedra == 0) return warnings;
  if (q.min_dihedral_deg < kMinDihedralGoalDeg)
    warnings.push_back(fmt::format(
        "the smallest dihedral angle is {:.2f}° (goal {:.0f}°): the FEM models will be stiffer there and solve slower; "
        "try another --tet-size or a smoother mask (--closing)",
        q.min_dihedral_deg, kMinDihedralGoalDeg));
  if (q.max_radius_edge_ratio > kMaxRadiusEdgeGoal)
    warnings.push_back(fmt::format(
        "the largest radius-edge ratio is {:.2f} (goal {:.0f}): a badly shaped tetrahedron; try another --tet-size or "
        "a smoother mask (--closing)",
        q.max_radius_edge_ratio, kMaxRadiusEdgeGoal));
  return warnings;
}

}  // namespace organsim::pipeline
