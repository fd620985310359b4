#include "organsim/pipeline/sliver_removal.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace organsim::pipeline {
namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }
model::Point3 point(const Eigen::Vector3d& v) { return {v[0], v[1], v[2]}; }

double signed_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                     const Eigen::Vector3d& d) {
  return (b - a).cross(c - a).dot(d - a) / 6.0;
}

// Circumradius over shortest edge (0.612 for a regular tetrahedron).
double radius_edge_ratio(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                         const Eigen::Vector3d& d, double volume) {
  const Eigen::Vector3d u = b - a, v = c - a, w = d - a;
  const double radius =
      (u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u) + w.squaredNorm() * u.cross(v)).norm() /
      (12.0 * volume);
  const double shortest = std::sqrt(std::min({u.squaredNorm(), v.squaredNorm(), w.squaredNorm(), (c - b).squaredNorm(),
                                              (d - b).squaredNorm(), (d - c).squaredNorm()}));
  return radius / shortest;
}

// The quality of a positively oriented tetrahedron, in degrees: its smallest
// dihedral angle, or less when its radius-edge ratio ρ exceeds 3 (the
// tetrahedra stage's goal), as kRatioScale / ρ so that ρ = 3 reads as the
// sliver bound's 15°; -1 when it is inverted or flat.
constexpr double kRatioScale = 45.0;
double quality(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  const double volume = signed_volume(a, b, c, d);
  if (!(volume > 0.0)) return -1.0;
  return std::min(min_dihedral_deg(point(a), point(b), point(c), point(d)),
                  kRatioScale / radius_edge_ratio(a, b, c, d, volume));
}

// Faces and edges as sorted vertex indices packed into one key (vertex
// indices below 2^21 for faces: two million tetrahedron vertices).
std::uint64_t face_key(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  std::array<std::uint64_t, 3> v{a, b, c};
  std::sort(v.begin(), v.end());
  return (v[0] << 42) | (v[1] << 21) | v[2];
}
std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return a < b ? (std::uint64_t{a} << 32) | b : (std::uint64_t{b} << 32) | a;
}

constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};  // face opposite corner i

class Slivers {
 public:
  Slivers(geometry::TetrahedralMesh& mesh, const SliverRemovalOptions& options) : mesh_(mesh), options_(options) {}

  SliverRemovalReport run() {
    SliverRemovalReport report;
    measure(report.min_dihedral_before_deg, report.slivers_before);
    report.peeled = peel();
    report.moves = smooth();
    measure(report.min_dihedral_after_deg, report.slivers_after);
    return report;
  }

 private:
  double tet_quality(const model::Tetrahedron& t) const {
    const auto& v = mesh_.vertices;
    return quality(vec(v[t[0]]), vec(v[t[1]]), vec(v[t[2]]), vec(v[t[3]]));
  }

  void measure(double& smallest, std::size_t& below) const {
    smallest = 180.0;
    below = 0;
    for (const model::Tetrahedron& t : mesh_.tetrahedra) {
      const double q = tet_quality(t);
      smallest = std::min(smallest, q);
      below += q < options_.min_dihedral_deg;
    }
  }

  // Removes boundary slivers: two faces on the boundary, sharing the edge ab;
  // the other two faces (sharing cd) become the boundary, which stays a
  // 2-manifold when cd is not a boundary edge already.
  std::size_t peel() {
    std::unordered_map<std::uint64_t, int> face_uses, boundary_edge_faces;
    for (const model::Tetrahedron& t : mesh_.tetrahedra)
      for (const auto& f : kFaces) ++face_uses[face_key(t[f[0]], t[f[1]], t[f[2]])];
    auto on_boundary = [&](std::uint64_t key) { return face_uses[key] == 1; };
    for (const auto& [key, uses] : face_uses)
      if (uses == 1) {
        const auto a = static_cast<std::uint32_t>(key >> 42), b = static_cast<std::uint32_t>((key >> 21) & 0x1fffff),
                   c = static_cast<std::uint32_t>(key & 0x1fffff);
        ++boundary_edge_faces[edge_key(a, b)];
        ++boundary_edge_faces[edge_key(b, c)];
        ++boundary_edge_faces[edge_key(a, c)];
      }

    std::vector<bool> removed(mesh_.tetrahedra.size(), false);
    std::size_t peeled = 0;
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t i = 0; i < mesh_.tetrahedra.size(); ++i) {
        const model::Tetrahedron& t = mesh_.tetrahedra[i];
        if (removed[i] || tet_quality(t) >= options_.min_dihedral_deg) continue;
        int boundary[4], count = 0;
        for (int f = 0; f < 4; ++f)
          if (on_boundary(face_key(t[kFaces[f][0]], t[kFaces[f][1]], t[kFaces[f][2]]))) boundary[count++] = f;
        if (count != 2) continue;
        // The faces opposite corners c and d are on the boundary: they share edge ab.
        const std::uint32_t c = t[boundary[0]], d = t[boundary[1]];
        if (boundary_edge_faces[edge_key(c, d)] != 0) continue;
        for (const auto& f : kFaces) {
          const std::uint64_t key = face_key(t[f[0]], t[f[1]], t[f[2]]);
          const int before = face_uses[key]--;
          const int sign = before == 1 ? -1 : +1;  // a boundary face leaves the boundary, an inner one joins it
          boundary_edge_faces[edge_key(t[f[0]], t[f[1]])] += sign;
          boundary_edge_faces[edge_key(t[f[1]], t[f[2]])] += sign;
          boundary_edge_faces[edge_key(t[f[0]], t[f[2]])] += sign;
        }
        removed[i] = true;
        ++peeled;
        changed = true;
      }
    }
    std::size_t kept = 0;
    for (std::size_t i = 0; i < mesh_.tetrahedra.size(); ++i)
      if (!removed[i]) mesh_.tetrahedra[kept++] = mesh_.tetrahedra[i];
    mesh_.tetrahedra.resize(kept);
    return peeled;
  }

  // Moves interior vertices of the remaining slivers.
  std::size_t smooth() {
    const std::size_t n = mesh_.vertices.size();
    // Vertex → tetrahedra, and which vertices are on the boundary.
    std::vector<std::uint32_t> offsets(n + 1, 0), incident;
    for (const model::Tetrahedron& t : mesh_.tetrahedra)
      for (std::uint32_t v : t) ++offsets[v + 1];
    for (std::size_t v = 0; v < n; ++v) offsets[v + 1] += offsets[v];
    incident.resize(offsets[n]);
    std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (std::uint32_t i = 0; i < mesh_.tetrahedra.size(); ++i)
      for (std::uint32_t v : mesh_.tetrahedra[i]) incident[fill[v]++] = i;
    std::unordered_map<std::uint64_t, int> face_uses;
    for (const model::Tetrahedron& t : mesh_.tetrahedra)
      for (const auto& f : kFaces) ++face_uses[face_key(t[f[0]], t[f[1]], t[f[2]])];
    // Boundary vertices: their outward normal (sum of the boundary faces'
    // area vectors), the centroid of their boundary neighbours and the mean
    // length of their boundary edges.
    std::vector<bool> on_boundary(n, false);
    std::vector<Eigen::Vector3d> outward(n, Eigen::Vector3d::Zero()), ring_sum(n, Eigen::Vector3d::Zero());
    std::vector<double> edge_sum(n, 0.0);
    std::vector<int> ring_count(n, 0);
    std::unordered_map<std::uint64_t, std::vector<Eigen::Vector3d>> edge_normals;  // of the boundary faces at an edge
    std::vector<Eigen::Vector3d> face_normals;  // unit, outward: per boundary face, three times (per corner)
    std::vector<std::uint32_t> face_corner;
    for (const model::Tetrahedron& t : mesh_.tetrahedra)
      for (int corner = 0; corner < 4; ++corner) {
        const auto& f = kFaces[corner];
        if (face_uses[face_key(t[f[0]], t[f[1]], t[f[2]])] != 1) continue;
        const Eigen::Vector3d q[3] = {vec(mesh_.vertices[t[f[0]]]), vec(mesh_.vertices[t[f[1]]]),
                                      vec(mesh_.vertices[t[f[2]]])};
        Eigen::Vector3d area = (q[1] - q[0]).cross(q[2] - q[0]);
        if (area.dot(vec(mesh_.vertices[t[corner]]) - q[0]) > 0.0) area = -area;
        for (int k = 0; k < 3; ++k) edge_normals[edge_key(t[f[k]], t[f[(k + 1) % 3]])].push_back(area.normalized());
        for (int k = 0; k < 3; ++k) {
          const std::uint32_t v = t[f[k]];
          face_normals.push_back(area.normalized());
          face_corner.push_back(v);
          on_boundary[v] = true;
          outward[v] += area;
          for (int j = 1; j < 3; ++j) {  // each boundary edge is met twice per vertex: halves
            ring_sum[v] += 0.5 * q[(k + j) % 3];
            edge_sum[v] += 0.5 * (q[(k + j) % 3] - q[k]).norm();
          }
          ring_count[v] += 1;
        }
      }

    // A boundary vertex may slide only where the boundary is smooth: every
    // boundary face around it within 30° of its normal (not a corner or crease).
    std::vector<bool> may_slide(on_boundary);
    for (std::size_t k = 0; k < face_corner.size(); ++k) {
      const std::uint32_t v = face_corner[k];
      if (face_normals[k].dot(outward[v].normalized()) < std::cos(30.0 / kDegrees)) may_slide[v] = false;
    }
    // A vertex on a crease line (two crease edges meet there: the boundary
    // faces on either side differ by more than 30°; a field-of-view cut makes
    // such lines) may slide along the crease instead, towards either
    // neighbour on it: the crease keeps its place to first order.
    std::vector<std::vector<std::uint32_t>> crease_neighbours(n);
    for (const auto& [key, normals] : edge_normals)
      if (normals.size() == 2 && normals[0].dot(normals[1]) < std::cos(30.0 / kDegrees)) {
        const auto a = static_cast<std::uint32_t>(key >> 32), b = static_cast<std::uint32_t>(key & 0xffffffffu);
        crease_neighbours[a].push_back(b);
        crease_neighbours[b].push_back(a);
      }
    for (std::vector<std::uint32_t>& on_crease : crease_neighbours) std::sort(on_crease.begin(), on_crease.end());

    // The worst quality around v if it stood at `at`.
    auto worst_around = [&](std::uint32_t v, const Eigen::Vector3d& at) {
      double worst = 180.0;
      for (std::uint32_t k = offsets[v]; k < offsets[v + 1]; ++k) {
        const model::Tetrahedron& t = mesh_.tetrahedra[incident[k]];
        Eigen::Vector3d p[4];
        for (int c = 0; c < 4; ++c) p[c] = t[c] == v ? at : vec(mesh_.vertices[t[c]]);
        worst = std::min(worst, quality(p[0], p[1], p[2], p[3]));
        if (worst < 0.0) break;
      }
      return worst;
    };

    // A tetrahedron none of whose vertices could move is tried again only
    // after a vertex of it moved for another one: the pattern search is
    // costly, and nothing else changes what it would find.
    std::vector<int> last_moved(n, -1), stuck_since(mesh_.tetrahedra.size(), -1);
    std::size_t moves = 0;
    for (int pass = 0; pass < options_.passes; ++pass) {
      bool moved = false;
      for (std::size_t i = 0; i < mesh_.tetrahedra.size(); ++i) {
        const model::Tetrahedron& t = mesh_.tetrahedra[i];
        if (stuck_since[i] >= 0 &&
            std::none_of(t.begin(), t.end(), [&](std::uint32_t v) { return last_moved[v] >= stuck_since[i]; }))
          continue;
        const std::size_t moves_before = moves;
        // Interior vertices first; boundary ones slide only if that was not enough.
        for (int turn = 0; turn < 8; ++turn) {
          if (tet_quality(t) >= options_.min_dihedral_deg) break;
          const int corner = turn % 4;
          const std::uint32_t v = t[corner];
          const bool on_crease_line = on_boundary[v] && !may_slide[v] && crease_neighbours[v].size() == 2;
          if (on_boundary[v] != (turn >= 4) || (on_boundary[v] && !may_slide[v] && !on_crease_line)) continue;
          const Eigen::Vector3d here = vec(mesh_.vertices[v]);
          if (on_crease_line) {
            double best = worst_around(v, here);
            Eigen::Vector3d best_at = here;
            for (const std::uint32_t u : crease_neighbours[v])
              for (const double fraction : {0.25, 0.125, 0.0625}) {
                const Eigen::Vector3d candidate = here + fraction * (vec(mesh_.vertices[u]) - here);
                const double q = worst_around(v, candidate);
                if (q > best + 1e-9) best = q, best_at = candidate;
              }
            if (best_at != here) {
              mesh_.vertices[v] = point(best_at);
              last_moved[v] = pass;
              ++moves;
              moved = true;
            }
            continue;
          }
          // Towards the centroid of its neighbours...
          Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
          int neighbours = 0;
          for (std::uint32_t k = offsets[v]; k < offsets[v + 1]; ++k)
            for (std::uint32_t u : mesh_.tetrahedra[incident[k]])
              if (u != v) {
                centroid += vec(mesh_.vertices[u]);
                ++neighbours;
              }
          centroid /= neighbours;
          // ... or away from the sliver's face opposite v, to the height of a
          // regular tetrahedron on that face.
          const Eigen::Vector3d f0 = vec(mesh_.vertices[t[kFaces[corner][0]]]),
                                f1 = vec(mesh_.vertices[t[kFaces[corner][1]]]),
                                f2 = vec(mesh_.vertices[t[kFaces[corner][2]]]);
          Eigen::Vector3d normal = (f1 - f0).cross(f2 - f0);
          if ((here - f0).dot(normal) < 0.0) normal = -normal;
          normal.normalize();
          const double edge = ((f1 - f0).norm() + (f2 - f1).norm() + (f0 - f2).norm()) / 3.0;
          const double lift = std::sqrt(2.0 / 3.0) * edge - (here - f0).dot(normal);
          Eigen::Vector3d towards_centroid = centroid - here, away = lift * normal;
          if (on_boundary[v]) {
            // A boundary vertex slides in its tangent plane, towards the
            // centroid of its boundary ring or along the projected lift, by at
            // most a quarter of its edges: the boundary keeps its shape to
            // second order.
            const Eigen::Vector3d n_out = outward[v].normalized();
            const double reach = 0.25 * edge_sum[v] / ring_count[v];
            towards_centroid = ring_sum[v] / ring_count[v] - here;
            towards_centroid -= towards_centroid.dot(n_out) * n_out;
            away -= away.dot(n_out) * n_out;
            for (Eigen::Vector3d* d : {&towards_centroid, &away})
              if (d->norm() > reach) *d *= reach / d->norm();
          }
          const double current = worst_around(v, here);
          double best = current;
          Eigen::Vector3d best_at = here;
          const auto try_move = [&](const Eigen::Vector3d& candidate) {
            const double q = worst_around(v, candidate);
            if (q > best + 1e-9) {
              best = q;
              best_at = candidate;
            }
          };
          for (const double step : {1.0, 0.5, 0.25, 0.125}) {
            try_move(here + step * towards_centroid);
            try_move(here + step * away);
          }
          // Where neither direction helps (the sliver's other vertices lie on
          // creases and cannot move), a pattern search: the 26 directions of
          // a cube's faces, edges and corners at a tenth and a twentieth of
          // the sliver's edges, in the tangent plane for a boundary vertex.
          if (best < options_.min_dihedral_deg) {
            const Eigen::Vector3d n_out =
                on_boundary[v] ? Eigen::Vector3d(outward[v].normalized()) : Eigen::Vector3d::Zero();
            for (const double fraction : {0.1, 0.05})
              for (int dx = -1; dx <= 1; ++dx)
                for (int dy = -1; dy <= 1; ++dy)
                  for (int dz = -1; dz <= 1; ++dz) {
                    if (dx == 0 && dy == 0 && dz == 0) continue;
                    Eigen::Vector3d direction(dx, dy, dz);
                    direction -= direction.dot(n_out) * n_out;
                    if (direction.norm() < 1e-6) continue;
                    try_move(here + fraction * edge * direction.normalized());
                  }
          }
          if (best_at != here) {
            mesh_.vertices[v] = point(best_at);
            last_moved[v] = pass;
            ++moves;
            moved = true;
          }
        }
        if (moves == moves_before) stuck_since[i] = pass;
      }
      if (!moved) break;
    }
    return moves;
  }

  geometry::TetrahedralMesh& mesh_;
  SliverRemovalOptions options_;
};

}  // namespace

double min_dihedral_deg(const model::Point3& a, const model::Point3& b, const model::Point3& c, const model::Point3& d) {
  static constexpr int kEdges[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2}, {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  const Eigen::Vector3d p[4] = {vec(a), vec(b), vec(c), vec(d)};
  // The smallest angle has the largest cosine: one arc cosine, not six.
  double largest_cosine = -1.0;
  for (const auto& e : kEdges) {
    // The angle at edge (e0, e1) between the faces towards e2 and e3.
    const Eigen::Vector3d axis = (p[e[1]] - p[e[0]]).normalized();
    Eigen::Vector3d u = p[e[2]] - p[e[0]], w = p[e[3]] - p[e[0]];
    u -= u.dot(axis) * axis;
    w -= w.dot(axis) * axis;
    const double nu = u.norm(), nw = w.norm();
    if (!(nu > 0.0 && nw > 0.0)) return 0.0;
    largest_cosine = std::max(largest_cosine, std::clamp(u.dot(w) / (nu * nw), -1.0, 1.0));
  }
  return std::acos(largest_cosine) * kDegrees;
}

double shape_quality_deg(const model::Point3& a, const model::Point3& b, const model::Point3& c, const model::Point3& d) {
  return quality(vec(a), vec(b), vec(c), vec(d));
}

SliverRemovalReport remove_slivers(geometry::TetrahedralMesh& mesh, const SliverRemovalOptions& options) {
  return Slivers(mesh, options).run();
}

}  // namespace organsim::pipeline
