#include "depth_curve_fit.h"

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

DepthCurveFit fit_depth_curve(const model::OrganModel& model, const DepthCurveOptions& o) {
  DepthCurveFit fit;
  const double radius_mm = o.press.tuning.tip_radius * 1e3;
  if (model.sites.empty() || !(radius_mm > 0.0) || o.sites <= 0) return fit;
  const organ::Organ organ(model);
  const std::vector<Eigen::Vector3d> normals = rest_normals(organ);
  const std::vector<std::uint32_t> sites = press_sites(organ, o.sites, o.seed, o.press);
  fit.refine_size_mm = o.cells_mm();
  const double refine_radius_mm = *std::max_element(o.depths_mm.begin(), o.depths_mm.end()) + 2.0 * radius_mm;
  // The fast models' force with the law alone (no curve, g = 1), pressed by
  // the same contact rule as the reference (a tool that slips under the law
  // slips under it at the curve's sites too): the first registered model
  // matched to the reference that runs on this model file (each gives the site
  // law's force).
  model::OrganModel linear_model = model;
  linear_model.sites.depth_curve.clear();
  linear_model.sites.supported_depth_curve.clear();
  const organ::Organ linear_law(std::move(linear_model));
  std::string fast_model;
  for (const realtime::RegisteredModel* entry : realtime::registered_models())
    if (entry->matches_reference && fast_model.empty() && realtime::unsuitable_model(*entry, model).empty())
      fast_model = entry->name;
  PressOptions fast_press = o.press;
  set_parameter(fast_press.tuning.models, "unmatched", {0.0, {}});
  // Per site: its presses and, for each that solved, (depth mm, ln |F_ref| / |F_law|).
  auto press_site = [&](std::size_t k) {
    const Eigen::Vector3d at = site_point(organ, sites[k]);
    const std::unique_ptr<organ::Organ> reference = reference_at(model, at, fit.refine_size_mm, refine_radius_mm);
    nlohmann::json ratios = nlohmann::json::array();
    std::size_t presses = 0;
    for (const PressTilt tilt : {PressTilt::straight, static_cast<PressTilt>(1 + k % 2)})
      for (const double depth : o.depths_mm) {
        const ToolSpec tool = site_press(organ, sites[k], normals[sites[k]], tilt, depth, o.press);
        ++presses;
        note("calibrate",
             fmt::format("depth curve: site {} of {}, {:g} mm: {} with {} ({} tetrahedra)", k + 1, sites.size(), depth,
                         tool.text, o.reference, reference->model().tetrahedra.size()));
        Eigen::Vector3d force;
        try {
          force = press(o.reference, *reference, {tool}, o.press).tools[0].force;
        } catch (const std::runtime_error& e) {
          warn("calibrate", fmt::format("depth curve: site {} {:g} mm left out: {}", k + 1, depth, e.what()));
          continue;
        }
        organ::SiteLaw law;
        const geometry::SurfacePoint touched = organ.surface_tree().closest_point(tool.point_mm * 1e-3);
        if (!(force.norm() > 0.0) || !law.set(organ, touched, o.press.tuning.tip_radius)) continue;
        const Eigen::Vector3d linear = press(fast_model, linear_law, {tool}, fast_press).tools[0].force;
        if (!(linear.norm() > 0.0)) continue;
        ratios.push_back({exact_json(depth), exact_json(std::log(force.norm() / linear.norm()))});
      }
    return nlohmann::json{{"presses", presses}, {"ratios", std::move(ratios)}};
  };
  const std::size_t jobs = o.jobs > 0 ? static_cast<std::size_t>(o.jobs) : usable_cpus();
  std::map<double, std::vector<double>> log_ratios;  // per depth (mm), in site order
  for (const nlohmann::json& site : run_site_jobs(sites.size(), jobs, press_site)) {
    fit.presses += site.at("presses").get<std::size_t>();
    for (const nlohmann::json& ratio : site.at("ratios")) {
      log_ratios[exact_double(ratio.at(0))].push_back(exact_double(ratio.at(1)));
      ++fit.solved;
    }
  }
  if (fit.solved == 0)
    throw std::runtime_error(
        fmt::format("none of the {} depth-curve presses could be solved by {}: press less deep "
                    "(--depths)",
                    fit.presses, o.reference));
  for (const auto& [depth, logs] : log_ratios) {  // std::map: increasing depth
    double mean = 0.0;
    for (double l : logs) mean += l;
    mean /= static_cast<double>(logs.size());
    double spread = 0.0;
    for (double l : logs) spread += (l - mean) * (l - mean);
    fit.curve.push_back({depth * 1e-3, std::exp(mean)});
    fit.scatter.push_back(std::exp(std::sqrt(spread / static_cast<double>(logs.size()))));
  }
  return fit;
}

}  // namespace organsim::cli
