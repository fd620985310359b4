#include "press_plan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "refined_reference.h"

namespace organsim::cli {
namespace {

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

/// The first tangent at a vertex of outward unit `normal`: the side a tilted
/// press starts from, the same at every call.
Eigen::Vector3d first_tangent(const Eigen::Vector3d& normal) {
  Eigen::Index least = 0;
  normal.cwiseAbs().minCoeff(&least);
  return normal.cross(Eigen::Vector3d::Unit(least)).normalized();
}

/// A tool that touches at `at` (mm) and is moved by `by` (mm), with its
/// command-line spelling.
ToolSpec tool_spec(const Eigen::Vector3d& at, const Eigen::Vector3d& by) {
  return {fmt::format("{:.2f},{:.2f},{:.2f}/{:.3f},{:.3f},{:.3f}", at[0], at[1], at[2], by[0], by[1], by[2]), at, by};
}

/// A press of `depth_mm` at surface vertex `site` along `toward` (a unit
/// tangent, or zero for straight in) less the outward unit `normal`.
ToolSpec press_along(const organ::Organ& organ, std::uint32_t site, const Eigen::Vector3d& normal,
                     const Eigen::Vector3d& toward, double depth_mm) {
  return tool_spec(site_point(organ, site) * 1e3, depth_mm * (toward - normal).normalized());
}

/// A press 45° from the inward normal, turned about it from the side
/// `first_side` radians from first_tangent(normal), 45° at a time, to the
/// first side whose shaft press() takes (shaft_entry); none where no side's is.
std::optional<ToolSpec> clear_tilt(const organ::Organ& organ, std::uint32_t site, const Eigen::Vector3d& normal,
                                   double first_side, double depth_mm, const PressOptions& o) {
  constexpr int kSides = 8;
  const Eigen::Vector3d tangent = first_tangent(normal);
  for (int side = 0; side < kSides; ++side) {
    const double turn = first_side + 2.0 * M_PI * side / kSides;
    const ToolSpec tool =
        press_along(organ, site, normal, std::cos(turn) * tangent + std::sin(turn) * normal.cross(tangent), depth_mm);
    if (std::isinf(shaft_entry(organ, tool, o))) return tool;
  }
  return std::nullopt;
}

constexpr double kFirstSide[] = {0.0, 0.5 * M_PI};  ///< where tangent_a's and tangent_b's turns start

}  // namespace

std::vector<std::uint32_t> press_sites(const organ::Organ& organ, int count, std::uint32_t seed,
                                       const PressOptions& o) {
  const std::vector<model::Point3>& vertices = organ.model().surface_vertices;
  const double clamp_radius = o.tuning.models.of<fem::OrganFemOptions>().fixed_radius;
  double farthest = 0.0;
  for (const model::Point3& v : vertices) farthest = std::max(farthest, (point(v) - organ.fixed_point()).norm());
  const double nearest_allowed = clamp_radius + 0.25 * (farthest - clamp_radius);
  std::vector<std::uint32_t> candidates;
  for (std::uint32_t v = 0; v < vertices.size(); ++v)
    if ((point(vertices[v]) - organ.fixed_point()).norm() >= nearest_allowed) candidates.push_back(v);
  // A site in a hollow, whose straight or tilted press would need its shaft
  // through the organ elsewhere, is never picked; it stays a candidate so that
  // the others are the sites they were before the rule. Every side a tilted
  // press may turn to is tried, so a site picked has a press of every kind.
  const std::vector<Eigen::Vector3d> normals = rest_normals(organ);
  std::vector<bool> reachable(candidates.size());
  std::size_t reachable_count = 0;
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    const std::uint32_t v = candidates[c];
    reachable[c] = std::isinf(shaft_entry(organ, press_along(organ, v, normals[v], Eigen::Vector3d::Zero(), 1.0), o));
    for (const double first_side : kFirstSide)
      reachable[c] = reachable[c] && clear_tilt(organ, v, normals[v], first_side, 1.0, o).has_value();
    reachable_count += reachable[c];
  }
  if (reachable_count < static_cast<std::size_t>(count))
    throw std::runtime_error(
        fmt::format("the organ has {} surface vertices away from the clamp that a tool can press "
                    "straight in and tilted 45°, fewer than the {} presses asked for",
                    reachable_count, count));
  std::mt19937 random(seed);
  std::size_t start = random() % candidates.size();
  while (!reachable[start]) start = (start + 1) % candidates.size();
  std::vector<std::uint32_t> sites{candidates[start]};
  std::vector<double> distance(candidates.size(), std::numeric_limits<double>::infinity());
  while (sites.size() < static_cast<std::size_t>(count)) {
    const Eigen::Vector3d last = point(vertices[sites.back()]);
    std::size_t best = candidates.size();
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      distance[c] = std::min(distance[c], (point(vertices[candidates[c]]) - last).norm());
      if (reachable[c] && (best == candidates.size() || distance[c] > distance[best])) best = c;
    }
    sites.push_back(candidates[best]);
  }
  return sites;
}

ToolSpec site_press(const organ::Organ& organ, std::uint32_t site, const Eigen::Vector3d& normal, PressTilt tilt,
                    double depth_mm, const PressOptions& o) {
  if (tilt == PressTilt::straight) return press_along(organ, site, normal, Eigen::Vector3d::Zero(), depth_mm);
  const std::optional<ToolSpec> tool =
      clear_tilt(organ, site, normal, kFirstSide[tilt == PressTilt::tangent_a ? 0 : 1], depth_mm, o);
  // No side is clear (a site press_sites does not pick): the press reports where the shaft enters.
  return tool ? *tool : press_along(organ, site, normal, first_tangent(normal), depth_mm);
}

std::unique_ptr<organ::Organ> reference_at(const model::OrganModel& model, const Eigen::Vector3d& site, double cells_mm,
                                           double radius_mm) {
  if (cells_mm <= 0.0) return std::make_unique<organ::Organ>(model);
  return std::make_unique<organ::Organ>(refined_at(model, site, cells_mm, radius_mm));
}

ToolSpec pulled_out(const ToolSpec& tool, const Eigen::Vector3d& normal) {
  return tool_spec(tool.point_mm, tool.displacement_mm - 2.0 * tool.displacement_mm.dot(normal) * normal);
}

Eigen::Vector3d site_point(const organ::Organ& organ, std::uint32_t site) {
  return point(organ.model().surface_vertices[site]);
}

double thickness_along(const organ::Organ& organ, const Eigen::Vector3d& at, const Eigen::Vector3d& inward) {
  // From just inside, so that the site's own triangles do not count, to
  // beyond the far side of the bounding box.
  Eigen::AlignedBox3d box;
  for (const model::Point3& v : organ.model().surface_vertices) box.extend(point(v));
  const double start = 1e-6 * box.diagonal().norm(), end = 2.0 * box.diagonal().norm();
  geometry::SegmentHit hit;
  if (!organ.surface_tree().first_crossing(at + start * inward, at + end * inward, false, hit)) return 0.0;
  return start + hit.along * (end - start);
}

model::Supports::Kind support_behind(const organ::Organ& organ, const Eigen::Vector3d& at,
                                     const Eigen::Vector3d& inward) {
  const model::OrganModel& m = organ.model();
  if (m.supports.empty()) return model::Supports::Kind::kFree;
  Eigen::AlignedBox3d box;
  for (const model::Point3& v : m.surface_vertices) box.extend(point(v));
  const double start = 1e-6 * box.diagonal().norm(), end = 2.0 * box.diagonal().norm();
  geometry::SegmentHit hit;
  if (!organ.surface_tree().first_crossing(at + start * inward, at + end * inward, false, hit))
    return model::Supports::Kind::kFree;
  Eigen::Index corner = 0;
  hit.barycentric.maxCoeff(&corner);
  return m.supports.kind(m.surface_triangles[hit.triangle][static_cast<std::size_t>(corner)]);
}

double cell_size_at(const organ::Organ& organ, const Eigen::Vector3d& at) {
  const model::OrganModel& m = organ.model();
  std::size_t nearest = 0;
  for (std::size_t v = 1; v < m.volume_vertices.size(); ++v)
    if ((point(m.volume_vertices[v]) - at).squaredNorm() < (point(m.volume_vertices[nearest]) - at).squaredNorm())
      nearest = v;
  double longest = 0.0;
  for (const model::Tetrahedron& t : m.tetrahedra)
    if (std::find(t.begin(), t.end(), nearest) != t.end())
      for (std::size_t a = 0; a < 4; ++a)
        for (std::size_t b = a + 1; b < 4; ++b)
          longest = std::max(longest, (point(m.volume_vertices[t[a]]) - point(m.volume_vertices[t[b]])).norm());
  return longest;
}

std::vector<Eigen::Vector3d> rest_normals(const organ::Organ& organ) {
  std::vector<model::Point3> normals(organ.vertex_count());
  organ::compute_vertex_normals(organ, organ.model().surface_vertices.data(), normals.data(), 0, organ.vertex_count());
  std::vector<Eigen::Vector3d> result;
  result.reserve(normals.size());
  for (const model::Point3& n : normals) result.push_back(point(n));
  return result;
}

}  // namespace organsim::cli
