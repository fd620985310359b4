// Where and how `calibrate` presses an organ: sites spread over its surface
// (seeded, reproducible) and, at each, a press straight in or tilted 45°.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "organsim/organ/organ.h"
#include "organsim/realtime/model_registry.h"
#include "static_press/static_press.h"

namespace organsim::cli {

/// Where a curve `calibrate` fits (the site law's depth curve, the grasp's
/// pull curve) has the reference pressed: its sites, and the reference's cells
/// there.
struct CurveSiteOptions {
  int sites = 6;  ///< 0: no curve
  std::uint32_t seed = 1;
  double refine_size_mm = -1.0;  ///< the reference's cells at each site: < 0 half the tip's radius; 0 the model's own
  std::string reference = realtime::reference_model().name;
  /// Processes the sites are shared among (site_jobs.h; the curve is the
  /// same whatever the number); 0: one per CPU.
  int jobs = 0;
  PressOptions press;

  /// mm: the reference's cells as used (`refine_size_mm`, its default resolved).
  double cells_mm() const { return refine_size_mm < 0.0 ? 0.5 * press.tuning.tip_radius * 1e3 : refine_size_mm; }
};

/// The model the reference presses at `site` (m) with: re-meshed with cells of
/// `cells_mm` within `radius_mm` of it (refined_reference.h), or the model
/// itself for cells of 0.
std::unique_ptr<organ::Organ> reference_at(const model::OrganModel& model, const Eigen::Vector3d& site, double cells_mm,
                                           double radius_mm);

/// `count` surface vertices (runtime numbering) spread by farthest-point
/// sampling from a start `seed` picks, among the vertices far enough from the
/// clamp ball (`o`'s fixed radius) that every model can take the press: a
/// quarter of the way from it to the farthest vertex. A vertex a tool of
/// `o`'s tip cannot press straight in (its shaft would pass through the organ
/// elsewhere: shaft_entry), or tilted 45° (site_press finds no side whose
/// shaft is clear, starting from either tangent), is not picked. Throws
/// std::runtime_error when there are fewer such vertices than `count`.
std::vector<std::uint32_t> press_sites(const organ::Organ& organ, int count, std::uint32_t seed, const PressOptions& o);

/// How a press at a site goes in.
enum class PressTilt : int {
  straight = 0,   ///< along the inward normal
  tangent_a = 1,  ///< 45° from it, towards the first tangent
  tangent_b = 2,  ///< 45° from it, towards the second
};

/// A press of `depth_mm` at surface vertex `site`, whose outward unit normal
/// is `normal`, tilted as asked. A tilted press whose tool (`o`'s tip) would
/// have its shaft through the organ elsewhere (shaft_entry) turns about the
/// normal, 45° at a time, to the first side the shaft is clear of it.
ToolSpec site_press(const organ::Organ& organ, std::uint32_t site, const Eigen::Vector3d& normal, PressTilt tilt,
                    double depth_mm, const PressOptions& o);

/// The press `tool` mirrored in the tangent plane: drawn out by its depth,
/// straight along the outward `normal` or tilted as the press was.
ToolSpec pulled_out(const ToolSpec& tool, const Eigen::Vector3d& normal);

/// Where surface vertex `site` (runtime numbering, as press_sites gives it)
/// lies at rest, m. The runtime numbers the surface in its own order
/// (organ::Organ), so a site indexes organ.model(), never the file's model.
Eigen::Vector3d site_point(const organ::Organ& organ, std::uint32_t site);

/// How far the organ runs from the surface point `at` (m) along the unit
/// `inward` direction before the line leaves it again (m): its thickness under
/// a press there. 0 where the line never leaves (an open surface).
double thickness_along(const organ::Organ& organ, const Eigen::Vector3d& at, const Eigen::Vector3d& inward);

/// What the organ rests on where the line from `at` (m) along `inward` (unit)
/// leaves it again, the far side of thickness_along's line: the support kind
/// of the surface vertex nearest that point (docs/supports.md); free where
/// the model has no supports or the line never leaves.
model::Supports::Kind support_behind(const organ::Organ& organ, const Eigen::Vector3d& at,
                                     const Eigen::Vector3d& inward);

/// The longest edge of the tetrahedra around the node nearest `at` (m): the
/// size of the FEM's cells there, m (0 without tetrahedra).
double cell_size_at(const organ::Organ& organ, const Eigen::Vector3d& at);

/// Every surface vertex's outward unit normal at rest.
std::vector<Eigen::Vector3d> rest_normals(const organ::Organ& organ);

}  // namespace organsim::cli
