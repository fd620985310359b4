#include "organsim/tetrahedra/sliver_removal.h"

#include "tetrahedron_faces.h"

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

// Rounds of peeling, flips and vertex moves; the most tetrahedra around an
// edge that edge removal takes (Klingner and Shewchuk found larger rings
// rarely help; up to 16 made no difference on our livers).
constexpr int kRounds = 4;
constexpr std::size_t kLargestRing = 7;
constexpr std::size_t kLargestCavity = 16;  // tetrahedra a vertex insertion replaces

class Slivers {
 public:
  Slivers(geometry::TetrahedralMesh& mesh, const SliverRemovalOptions& options) : mesh_(mesh), options_(options) {}

  SliverRemovalReport run() {
    SliverRemovalReport report;
    measure(report.min_dihedral_before_deg, report.slivers_before);
    // Peeling the slivers lying on the boundary, then flips, which reconnect
    // what vertex moves cannot fix, keep the boundary and cost little; a
    // corner is peeled only where no flip helped (peeling cuts the organ).
    // Then the moves, with fewer slivers to work on. A move may make a sliver
    // of a tetrahedron on the boundary, or open new flips: rounds go on while
    // peeling or flipping still does something.
    for (int round = 0; round < kRounds; ++round) {
      std::size_t peeled = peel(Corners::kept);
      const std::size_t flips = flip();
      peeled += peel(Corners::peeled);
      report.peeled += peeled;
      report.flips += flips;
      if (round > 0 && peeled == 0 && flips == 0) break;
      report.moves += smooth();
    }
    report.insertions = insertions_;
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
  // 2-manifold when cd is not a boundary edge already. Also removes slivers
  // at a corner of the boundary (three faces on it), whose apex is then unused.
  enum class Corners { kept, peeled };
  std::size_t peel(Corners corners) {
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

    std::unordered_map<std::uint64_t, int> edge_uses;
    for (const model::Tetrahedron& t : mesh_.tetrahedra)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) ++edge_uses[edge_key(t[a], t[b])];
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
        if (count == 2) {
          // The faces opposite corners c and d are on the boundary: they share edge ab.
          const std::uint32_t c = t[boundary[0]], d = t[boundary[1]];
          if (boundary_edge_faces[edge_key(c, d)] != 0) continue;
        } else if (count == 3 && corners == Corners::peeled) {
          // A corner: three boundary faces meet at the apex, and no other
          // tetrahedron has an edge from the apex to this one's base (where
          // one touches the apex, the boundary is pinched there, and the peel
          // undoes that); the base becomes the boundary.
          const int apex = 6 - boundary[0] - boundary[1] - boundary[2];
          if (std::any_of(t.begin(), t.end(),
                          [&](std::uint32_t u) { return u != t[apex] && edge_uses[edge_key(t[apex], u)] != 1; }))
            continue;
        } else {
          continue;
        }
        for (const auto& f : kFaces) {
          const std::uint64_t key = face_key(t[f[0]], t[f[1]], t[f[2]]);
          const int before = face_uses[key]--;
          const int sign = before == 1 ? -1 : +1;  // a boundary face leaves the boundary, an inner one joins it
          boundary_edge_faces[edge_key(t[f[0]], t[f[1]])] += sign;
          boundary_edge_faces[edge_key(t[f[1]], t[f[2]])] += sign;
          boundary_edge_faces[edge_key(t[f[0]], t[f[2]])] += sign;
        }
        for (int a = 0; a < 4; ++a)
          for (int b = a + 1; b < 4; ++b) --edge_uses[edge_key(t[a], t[b])];
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

  // Topological moves on the tetrahedra left below the bound (Klingner and
  // Shewchuk's edge removal and face swaps): where all four vertices of a
  // sliver are pinned to the boundary, no move of them helps, but the same
  // vertices connected differently can. Only interior edges and faces are
  // flipped: the boundary's triangles and the volume stay exactly as they were.
  // A flip is made when it raises the worst quality of the tetrahedra it replaces.
  std::size_t flip() {
    std::vector<model::Tetrahedron>& tets = mesh_.tetrahedra;
    const std::vector<model::Point3>& v = mesh_.vertices;
    std::vector<std::vector<std::uint32_t>> around(v.size());
    for (std::uint32_t i = 0; i < tets.size(); ++i)
      for (std::uint32_t corner : tets[i]) around[corner].push_back(i);
    std::vector<bool> alive(tets.size(), true);
    auto live_tets_with = [&](std::uint32_t a, std::uint32_t b) {
      std::vector<std::uint32_t> with;
      for (std::uint32_t i : around[a])
        if (alive[i] && std::find(tets[i].begin(), tets[i].end(), b) != tets[i].end()) with.push_back(i);
      return with;
    };
    auto positive_quality = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
      return quality(vec(v[a]), vec(v[b]), vec(v[c]), vec(v[d]));
    };

    struct Candidate {
      std::vector<std::uint32_t> removed;
      std::vector<model::Tetrahedron> added;
      double worst_added = -1.0;
    };
    // The tetrahedra around interior edge ab, and the closed ring r_0..r_{m-1}
    // of their other vertices (each (a, b, r_i, r_{i+1}) positive); empty where
    // ab lies on the boundary (an open ring) or has more than kLargestRing.
    auto ring_around = [&](std::uint32_t a, std::uint32_t b, std::vector<std::uint32_t>& ring_tets,
                           std::vector<std::uint32_t>& ring) {
      ring.clear();
      ring_tets = live_tets_with(a, b);
      const std::size_t m = ring_tets.size();
      if (m < 3 || m > kLargestRing) return false;
      std::unordered_map<std::uint32_t, std::uint32_t> next;
      for (std::uint32_t i : ring_tets) {
        std::uint32_t other[2], k = 0;
        for (std::uint32_t corner : tets[i])
          if (corner != a && corner != b) other[k++] = corner;
        if (signed_volume(vec(v[a]), vec(v[b]), vec(v[other[0]]), vec(v[other[1]])) < 0.0)
          std::swap(other[0], other[1]);
        if (!next.emplace(other[0], other[1]).second) return false;
      }
      ring.push_back(std::min_element(next.begin(), next.end())->first);
      for (std::size_t k = 1; k < m; ++k) {
        const auto at = next.find(ring.back());
        if (at == next.end()) return false;  // open: ab lies on the boundary
        ring.push_back(at->second);
      }
      const auto closing = next.find(ring.back());
      return closing != next.end() && closing->second == ring.front();
    };
    auto worst_of = [&](const std::vector<std::uint32_t>& indices) {
      double worst = 180.0;
      for (std::uint32_t i : indices) worst = std::min(worst, tet_quality(tets[i]));
      return worst;
    };
    // Removing interior edge ab: a triangulation of its ring, here each fan of
    // it, gives 2(m − 2) tetrahedra (r_i, r_j, r_k, b) and (r_j, r_i, r_k, a),
    // valid when all are positively oriented.
    auto remove_edge = [&](std::uint32_t a, std::uint32_t b, Candidate& best) {
      std::vector<std::uint32_t> ring_tets, ring;
      if (!ring_around(a, b, ring_tets, ring)) return;
      const std::size_t m = ring.size();
      const double worst_removed = worst_of(ring_tets);
      for (std::size_t apex = 0; apex < (m == 3 ? 1 : m); ++apex) {
        Candidate c;
        c.worst_added = 180.0;
        for (std::size_t j = 1; j + 1 < m && c.worst_added > worst_removed; ++j) {
          const std::uint32_t ri = ring[apex], rj = ring[(apex + j) % m], rk = ring[(apex + j + 1) % m];
          for (const model::Tetrahedron& t : {model::Tetrahedron{ri, rj, rk, b}, model::Tetrahedron{rj, ri, rk, a}}) {
            c.worst_added = std::min(c.worst_added, positive_quality(t[0], t[1], t[2], t[3]));
            c.added.push_back(t);
          }
        }
        if (c.worst_added > worst_removed + 1e-9 && c.worst_added > best.worst_added) {
          c.removed = ring_tets;
          best = std::move(c);
        }
      }
    };
    // The tetrahedron across the face opposite `corner` of tetrahedron i (i itself on the boundary).
    auto neighbour_across = [&](std::uint32_t i, int corner) {
      const model::Tetrahedron& t = tets[i];
      const std::uint32_t c = t[kFaces[corner][2]];
      for (std::uint32_t j : live_tets_with(t[kFaces[corner][0]], t[kFaces[corner][1]]))
        if (j != i && std::find(tets[j].begin(), tets[j].end(), c) != tets[j].end()) return j;
      return i;
    };
    // Inserting a new vertex p into a cavity (a set of tetrahedra): p and each
    // face of the cavity's hull make a new tetrahedron, valid when all are
    // positively oriented (p sees every hull face from inside). p is interior,
    // so it is free to go where its tetrahedra are best: a compass search from
    // `start`. The last resort where the vertices of a sliver are pinned to
    // the boundary and no flip helps; the boundary's triangles stay as they were.
    auto insert_vertex = [&](std::vector<std::uint32_t> cavity, const Eigen::Vector3d& start, Candidate& best,
                             Eigen::Vector3d& best_at) {
      std::sort(cavity.begin(), cavity.end());
      cavity.erase(std::unique(cavity.begin(), cavity.end()), cavity.end());
      if (cavity.size() > kLargestCavity) return;
      std::unordered_map<std::uint64_t, std::pair<int, std::array<std::uint32_t, 3>>> faces;
      for (std::uint32_t i : cavity)
        for (int corner = 0; corner < 4; ++corner) {
          const model::Tetrahedron& t = tets[i];
          std::array<std::uint32_t, 3> f{t[kFaces[corner][0]], t[kFaces[corner][1]], t[kFaces[corner][2]]};
          if (signed_volume(vec(v[f[0]]), vec(v[f[1]]), vec(v[f[2]]), vec(v[t[corner]])) < 0.0) std::swap(f[1], f[2]);
          auto& [uses, oriented] = faces[face_key(f[0], f[1], f[2])];
          ++uses;
          oriented = f;
        }
      std::vector<std::array<std::uint32_t, 3>> hull;
      for (const auto& [key, face] : faces)
        if (face.first == 1) hull.push_back(face.second);
      std::sort(hull.begin(), hull.end());  // the map's order is not the same from one library to another
      const double worst_removed = worst_of(cavity);
      auto worst_at = [&](const Eigen::Vector3d& p) {
        double worst = 180.0;
        for (std::size_t k = 0; k < hull.size() && worst > worst_removed; ++k)
          worst = std::min(worst, quality(vec(v[hull[k][0]]), vec(v[hull[k][1]]), vec(v[hull[k][2]]), p));
        return worst;
      };
      double reach = 0.0;
      for (const auto& f : hull)
        for (std::uint32_t corner : f) reach = std::max(reach, (vec(v[corner]) - start).norm());
      Eigen::Vector3d at = start;
      double worst = worst_at(at);
      for (double step = 0.25 * reach; step > 0.02 * reach; step *= 0.5)
        for (bool improved = true; improved;) {
          improved = false;
          for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dz = -1; dz <= 1; ++dz) {
                if (dx == 0 && dy == 0 && dz == 0) continue;
                const Eigen::Vector3d candidate = at + step * Eigen::Vector3d(dx, dy, dz).normalized();
                const double q = worst_at(candidate);
                if (q > worst + 1e-9) worst = q, at = candidate, improved = true;
              }
        }
      if (!(worst > worst_removed + 1e-9 && worst > best.worst_added)) return;
      const auto p = static_cast<std::uint32_t>(v.size());  // the index the new vertex will get
      best = Candidate{cavity, {}, worst};
      for (const auto& f : hull) best.added.push_back({f[0], f[1], f[2], p});
      best_at = at;
    };
    // Swapping interior face abc, shared with the tetrahedron on its other
    // side (apex e), for the three tetrahedra around the new edge de.
    auto swap_face = [&](std::uint32_t i, int corner, Candidate& best) {
      const model::Tetrahedron& t = tets[i];
      const std::uint32_t d = t[corner], a = t[kFaces[corner][0]], b = t[kFaces[corner][1]], c = t[kFaces[corner][2]];
      const std::uint32_t other = neighbour_across(i, corner);
      if (other == i) return;  // a boundary face
      std::uint32_t e = 0;
      for (std::uint32_t corner_e : tets[other])
        if (corner_e != a && corner_e != b && corner_e != c) e = corner_e;
      const double worst_removed = std::min(tet_quality(t), tet_quality(tets[other]));
      std::array<std::uint32_t, 3> ring{a, b, c};
      if (signed_volume(vec(v[d]), vec(v[e]), vec(v[a]), vec(v[b])) < 0.0) ring = {a, c, b};
      Candidate swap;
      swap.worst_added = 180.0;
      for (int k = 0; k < 3; ++k) {
        const model::Tetrahedron added{d, e, ring[k], ring[(k + 1) % 3]};
        swap.worst_added = std::min(swap.worst_added, positive_quality(added[0], added[1], added[2], added[3]));
        swap.added.push_back(added);
      }
      if (swap.worst_added > worst_removed + 1e-9 && swap.worst_added > best.worst_added) {
        swap.removed = {i, other};
        best = std::move(swap);
      }
    };

    static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    std::size_t flips = 0;
    const std::size_t most_flips = 4 * tets.size();
    for (std::size_t i = 0; i < tets.size() && flips < most_flips; ++i) {
      if (!alive[i] || tet_quality(tets[i]) >= options_.min_dihedral_deg) continue;
      Candidate best;
      const model::Tetrahedron t = tets[i];
      for (const auto& e : kEdges) remove_edge(t[e[0]], t[e[1]], best);
      for (int corner = 0; corner < 4; ++corner) swap_face(static_cast<std::uint32_t>(i), corner, best);
      Eigen::Vector3d new_vertex;
      bool inserted = false;
      if (best.added.empty()) {
        const Eigen::Vector3d centroid = (vec(v[t[0]]) + vec(v[t[1]]) + vec(v[t[2]]) + vec(v[t[3]])) / 4.0;
        for (const auto& e : kEdges) {
          const Eigen::Vector3d midpoint = 0.5 * (vec(v[t[e[0]]]) + vec(v[t[e[1]]]));
          insert_vertex(live_tets_with(t[e[0]], t[e[1]]), 0.5 * (midpoint + centroid), best, new_vertex);
        }
        std::vector<std::uint32_t> star{static_cast<std::uint32_t>(i)};
        for (int corner = 0; corner < 4; ++corner)
          star.push_back(neighbour_across(static_cast<std::uint32_t>(i), corner));
        insert_vertex(star, centroid, best, new_vertex);
        inserted = !best.added.empty();
      }
      if (best.added.empty()) continue;
      if (inserted) {
        mesh_.vertices.push_back(point(new_vertex));
        around.emplace_back();
        ++insertions_;
      }
      for (std::uint32_t j : best.removed) alive[j] = false;
      for (const model::Tetrahedron& added : best.added) {
        const auto index = static_cast<std::uint32_t>(tets.size());
        tets.push_back(added);
        alive.push_back(true);
        for (std::uint32_t corner : added) around[corner].push_back(index);
      }
      ++flips;
    }
    std::size_t kept = 0;
    for (std::size_t i = 0; i < tets.size(); ++i)
      if (alive[i]) tets[kept++] = tets[i];
    tets.resize(kept);
    return flips;
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
  std::size_t insertions_ = 0;
};

}  // namespace

double min_dihedral_deg(const model::Point3& a, const model::Point3& b, const model::Point3& c,
                        const model::Point3& d) {
  const Eigen::Vector3d p[4] = {vec(a), vec(b), vec(c), vec(d)};
  // The dihedral angle at the edge shared by the faces opposite corners k and
  // l is π less the angle between their outward normals: cos θ = −n_k·n_l.
  // The smallest angle has the largest cosine: one arc cosine, not six.
  Eigen::Vector3d normal[4];
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d& f0 = p[kFaces[k][0]];
    normal[k] = (p[kFaces[k][1]] - f0).cross(p[kFaces[k][2]] - f0);
    const double length = normal[k].norm();
    if (!(length > 0.0)) return 0.0;
    normal[k] /= normal[k].dot(p[k] - f0) > 0.0 ? -length : length;
  }
  double largest_cosine = -1.0;
  for (int k = 0; k < 4; ++k)
    for (int l = k + 1; l < 4; ++l) largest_cosine = std::max(largest_cosine, -normal[k].dot(normal[l]));
  return std::acos(std::clamp(largest_cosine, -1.0, 1.0)) * kDegrees;
}

double shape_quality_deg(const model::Point3& a, const model::Point3& b, const model::Point3& c,
                         const model::Point3& d) {
  return quality(vec(a), vec(b), vec(c), vec(d));
}

SliverRemovalReport remove_slivers(geometry::TetrahedralMesh& mesh, const SliverRemovalOptions& options) {
  return Slivers(mesh, options).run();
}

}  // namespace organsim::pipeline
