#include "organsim/fem/tet_mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

namespace organsim::fem {

double signed_volume(const TetMesh& mesh, const Tetrahedron& t) noexcept {
  const Eigen::Vector3d& a = mesh.nodes[static_cast<std::size_t>(t[0])];
  return (mesh.nodes[static_cast<std::size_t>(t[1])] - a)
             .cross(mesh.nodes[static_cast<std::size_t>(t[2])] - a)
             .dot(mesh.nodes[static_cast<std::size_t>(t[3])] - a) /
         6.0;
}

Eigen::Vector3d bounding_box_size(const Points& nodes) noexcept {
  if (nodes.empty()) return Eigen::Vector3d::Zero();
  Eigen::Vector3d low = nodes.front(), high = nodes.front();
  for (const Eigen::Vector3d& p : nodes) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  return high - low;
}

namespace {

/// Splits the structured cells of a (ni × nj × nk)-node grid into six
/// tetrahedra each (Kuhn: one per path from corner 000 to 111 along the three
/// axes, in every order), with `node(i, j, k)` giving the node index (so that
/// periodic directions can wrap). Orients every tetrahedron positively.
void add_kuhn_cells(TetMesh& mesh, int cells_i, int cells_j, int cells_k,
                    const std::function<std::int32_t(int, int, int)>& node) {
  static constexpr int kAxisOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < cells_k; ++k)
    for (int j = 0; j < cells_j; ++j)
      for (int i = 0; i < cells_i; ++i)
        for (const auto& order : kAxisOrders) {
          int corner[3] = {i, j, k};
          Tetrahedron t;
          t[0] = node(corner[0], corner[1], corner[2]);
          for (int step = 0; step < 3; ++step) {
            ++corner[order[step]];
            t[static_cast<std::size_t>(step + 1)] = node(corner[0], corner[1], corner[2]);
          }
          if (signed_volume(mesh, t) < 0) std::swap(t[2], t[3]);
          mesh.tetrahedra.push_back(t);
        }
}

}  // namespace

TetMesh box_mesh(const Eigen::Vector3i& cells, const Eigen::Vector3d& size) {
  if ((cells.array() < 1).any() || (size.array() <= 0).any())
    throw std::invalid_argument("box_mesh: cells and size must be positive");
  std::array<std::vector<double>, 3> planes;
  for (int axis = 0; axis < 3; ++axis)
    for (int i = 0; i <= cells[axis]; ++i) planes[axis].push_back(size[axis] * i / cells[axis]);
  return box_mesh(planes[0], planes[1], planes[2]);
}

TetMesh box_mesh(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<double>& zs) {
  for (const std::vector<double>* planes : {&xs, &ys, &zs})
    if (planes->size() < 2 || !std::is_sorted(planes->begin(), planes->end(), std::less_equal<double>()) ||
        !std::all_of(planes->begin(), planes->end(), [](double c) { return std::isfinite(c); }))
      throw std::invalid_argument("box_mesh: each axis needs two or more finite, strictly increasing coordinates");
  TetMesh mesh;
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size()), nz = static_cast<int>(zs.size());
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) mesh.nodes.emplace_back(xs[i], ys[j], zs[k]);
  add_kuhn_cells(mesh, nx - 1, ny - 1, nz - 1,
                 [&](int i, int j, int k) { return static_cast<std::int32_t>(i + nx * (j + ny * k)); });
  return mesh;
}

TetMesh curved_tube(const TubeOptions& o) {
  if (o.rings < 2 || o.around < 3 || o.through < 1 || !(o.inner_radius > 0) || !(o.outer_radius > o.inner_radius) ||
      !(o.length > 0))
    throw std::invalid_argument("curved_tube: needs rings ≥ 2, around ≥ 3, through ≥ 1, 0 < inner < outer radius");
  TetMesh mesh;
  const double bend_radius = o.bend_angle > 0 ? o.length / o.bend_angle : std::numeric_limits<double>::infinity();
  const int layers = o.through + 1;
  const double pi = std::acos(-1.0);
  // Node (around a, ring r, layer l) has index a + around (r + rings l).
  for (int l = 0; l < layers; ++l)
    for (int r = 0; r < o.rings; ++r)
      for (int a = 0; a < o.around; ++a) {
        const double s = o.length * r / (o.rings - 1);  // arc length from the top
        const double theta = o.bend_angle > 0 ? s / bend_radius : 0.0;
        const Eigen::Vector3d axis = o.bend_angle > 0 ? Eigen::Vector3d(bend_radius * (1 - std::cos(theta)), 0,
                                                                        o.length - bend_radius * std::sin(theta))
                                                      : Eigen::Vector3d(0, 0, o.length - s);
        const Eigen::Vector3d in_plane(std::cos(theta), 0, std::sin(theta)), across(0, 1, 0);
        const double radius = o.inner_radius + (o.outer_radius - o.inner_radius) * l / o.through;
        const double phi = 2 * pi * a / o.around;
        mesh.nodes.push_back(axis + radius * (std::cos(phi) * in_plane + std::sin(phi) * across));
      }
  add_kuhn_cells(mesh, o.around, o.rings - 1, o.through, [&](int a, int r, int l) {
    return static_cast<std::int32_t>(a % o.around + o.around * (r + o.rings * l));
  });
  return mesh;
}

}  // namespace organsim::fem
