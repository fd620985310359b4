#include "pull_curve_fit.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

#include "command_line/command_line.h"
#include "organsim/organ/site_law.h"
#include "press_plan.h"
#include "site_jobs.h"

namespace organsim::cli {
namespace {

/// The softening whose held-patch law gives `reference` newtons when the
/// jaws, closed at `bite` (m), have drawn the site to `displacement` (m):
/// bisection on ln s, the law's |F| falling as s grows. Clipped to
/// (0, SiteCompliance::kMaxSoftening].
double matching_softening(const organ::SiteLaw& law, const organ::SiteGrasp& grasp, const Eigen::Vector3d& displacement,
                          double reference) {
  const Eigen::Vector3d drawn = displacement - grasp.closed_at;
  auto force = [&](double s) { return (grasp.closing_force - law.held_stiffness(s) * drawn).norm(); };
  double low = std::log(1e-3), high = std::log(model::SiteCompliance::kMaxSoftening);
  if (force(std::exp(low)) <= reference) return std::exp(low);
  if (force(std::exp(high)) >= reference) return std::exp(high);
  for (int iteration = 0; iteration < 60; ++iteration) {
    const double middle = 0.5 * (low + high);
    (force(std::exp(middle)) > reference ? low : high) = middle;
  }
  return std::exp(0.5 * (low + high));
}

/// A pull as the fast models hold it: the site law where the tool touches,
/// the jaws closed after the bite, and the tool's displacement (m).
struct HeldPull {
  organ::SiteLaw law;
  organ::SiteGrasp grasp;
  Eigen::Vector3d displacement = Eigen::Vector3d::Zero();
  bool matched = false;
};

HeldPull held_pull(const organ::Organ& organ, const ToolSpec& tool, const PullCurveOptions& o) {
  HeldPull h;
  const geometry::SurfacePoint touched = organ.surface_tree().closest_point(tool.point_mm * 1e-3);
  h.matched = h.law.set(organ, touched, o.press.tuning.tip_radius);
  if (h.matched) h.grasp.close(h.law, -o.bite_mm * 1e-3 * organ.rest_normal_at(touched));
  h.displacement = tool.displacement_mm * 1e-3;
  return h;
}

}  // namespace

PullCurveFit fit_pull_curve(const model::OrganModel& model, const PullCurveOptions& o) {
  PullCurveFit fit;
  const double radius_mm = o.press.tuning.tip_radius * 1e3;
  if (model.sites.empty() || !(radius_mm > 0.0) || o.sites <= 0 || !(o.bite_mm > 0.0)) return fit;
  const organ::Organ organ(model);
  const std::vector<Eigen::Vector3d> normals = rest_normals(organ);
  const std::vector<std::uint32_t> sites = press_sites(organ, o.sites, o.seed, o.press);
  fit.refine_size_mm = o.cells_mm();
  // As `calibrate --evaluate --pull` refines: its pulls at the curve's sites
  // meet the same reference.
  const double refine_radius_mm = *std::max_element(o.distances_mm.begin(), o.distances_mm.end()) + 2.0 * radius_mm;
  PressOptions grasped = o.press;
  grasped.grasp_bite_mm = o.bite_mm;  // press(): a bite, the jaws closed, the move
  // Per site: its pulls and, for each that solved, (distance mm, u m, softening).
  auto pull_site = [&](std::size_t k) {
    const Eigen::Vector3d at = site_point(organ, sites[k]);
    const std::unique_ptr<organ::Organ> reference = reference_at(model, at, fit.refine_size_mm, refine_radius_mm);
    nlohmann::json softenings = nlohmann::json::array();
    std::size_t pulls = 0;
    for (const PressTilt tilt : {PressTilt::straight, static_cast<PressTilt>(1 + k % 2)})
      for (const double distance : o.distances_mm) {
        const Eigen::Vector3d& normal = normals[sites[k]];
        const ToolSpec tool = pulled_out(site_press(organ, sites[k], normal, tilt, distance, o.press), normal);
        ++pulls;
        note("calibrate",
             fmt::format("pull curve: site {} of {}, {:g} mm: {} with {} ({} tetrahedra)", k + 1, sites.size(),
                         distance, tool.text, o.reference, reference->model().tetrahedra.size()));
        Eigen::Vector3d force;
        try {
          force = press(o.reference, *reference, {tool}, grasped).tools[0].force;
        } catch (const std::runtime_error& e) {
          warn("calibrate", fmt::format("pull curve: site {} {:g} mm left out: {}", k + 1, distance, e.what()));
          continue;
        }
        const HeldPull held = held_pull(organ, tool, o);
        if (!(force.norm() > 0.0) || !held.matched) continue;
        softenings.push_back({static_cast<int>(tilt), exact_json(distance),
                              exact_json(matching_softening(held.law, held.grasp, held.displacement, force.norm())),
                              exact_json(force.norm())});
      }
    return nlohmann::json{{"pulls", pulls}, {"softenings", std::move(softenings)}};
  };
  const std::size_t jobs = o.jobs > 0 ? static_cast<std::size_t>(o.jobs) : usable_cpus();
  struct Pulled {
    ToolSpec tool;
    HeldPull held;
    double softening, reference_force;  // s, N
  };
  std::map<double, std::vector<Pulled>> by_distance;  // mm, in site order
  const std::vector<nlohmann::json> results = run_site_jobs(sites.size(), jobs, pull_site);
  for (std::size_t k = 0; k < results.size(); ++k) {
    fit.pulls += results[k].at("pulls").get<std::size_t>();
    for (const nlohmann::json& p : results[k].at("softenings")) {
      const double distance = exact_double(p.at(1));
      const Eigen::Vector3d& normal = normals[sites[k]];
      const ToolSpec tool = pulled_out(
          site_press(organ, sites[k], normal, static_cast<PressTilt>(p.at(0).get<int>()), distance, o.press), normal);
      by_distance[distance].push_back({tool, held_pull(organ, tool, o), exact_double(p.at(2)), exact_double(p.at(3))});
      ++fit.solved;
    }
  }
  if (fit.solved == 0)
    throw std::runtime_error(
        fmt::format("none of the {} pull-curve pulls could be solved by {}: pull less far "
                    "(--pull-depths)",
                    fit.pulls, o.reference));
  auto drawn = [](const Pulled& p) { return (p.held.displacement - p.held.grasp.closed_at).norm(); };
  fit.curve.push_back({0.0, 1.0});
  for (const auto& [distance, pulls] : by_distance) {  // std::map: increasing distance
    double mean_drawn = 0.0, mean_log = 0.0;
    for (const Pulled& p : pulls) {
      mean_drawn += drawn(p);
      mean_log += std::log(p.softening);
    }
    mean_drawn /= static_cast<double>(pulls.size());
    mean_log /= static_cast<double>(pulls.size());
    double spread = 0.0;
    for (const Pulled& p : pulls) spread += (std::log(p.softening) - mean_log) * (std::log(p.softening) - mean_log);
    fit.curve.push_back({mean_drawn, std::exp(mean_log)});
    fit.scatter.push_back(std::exp(std::sqrt(spread / static_cast<double>(pulls.size()))));
  }
  // The fitted law against the reference at the pulls it was fitted to.
  model::OrganModel fitted_model = model;
  fitted_model.sites.pull_curve = fit.curve;
  fitted_model.sites.pull_tip_radius = o.press.tuning.tip_radius;
  const organ::Organ fitted(std::move(fitted_model));
  for (const auto& entry : by_distance) {
    const std::vector<Pulled>& pulls = entry.second;
    double log_squares = 0.0;
    for (const Pulled& p : pulls) {
      const HeldPull h = held_pull(fitted, p.tool, o);
      const double l = std::log(h.grasp.force(h.law, h.displacement).norm() / p.reference_force);
      log_squares += l * l;
    }
    fit.force_factor.push_back(std::exp(std::sqrt(log_squares / static_cast<double>(pulls.size()))));
  }
  return fit;
}

}  // namespace organsim::cli
