#include "held_out_evaluation.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "organsim/realtime/model_registry.h"
#include "power_law/power_law.h"
#include "press_plan.h"
#include "organsim/geometry/model_measures.h"
#include "reference_cache.h"
#include "site_jobs.h"

namespace organsim::cli {
namespace {

constexpr double kDegreesPerRadian = 57.29577951308232;
/// The models matched to the reference (model_registry.h), which the evaluation measures.
std::vector<std::string> fast_models() {
  std::vector<std::string> names;
  for (const realtime::RegisteredModel* entry : realtime::registered_models())
    if (entry->matches_reference) names.emplace_back(entry->name);
  return names;
}

/// One fast model's answer to one press, against the reference's.
struct FastAnswer {
  bool solved = false;
  std::string error;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< N
  double log_ratio = 0.0;                           ///< ln(|F| / |F_ref|)
  double direction_error_deg = 0.0;                 ///< angle between F and F_ref
  double surface_difference = 0.0;                  ///< mean over the surface vertices, of the bounding box diagonal
  double largest_stretch = 1.0;                     ///< the surface's largest edge stretch, length / rest length
};

struct PressRecord {
  std::size_t site = 0;      ///< 0-based among the sites
  std::uint32_t vertex = 0;  ///< surface vertex (runtime numbering)
  PressTilt tilt = PressTilt::straight;
  double depth_mm = 0.0;
  ToolSpec tool;
  bool reference_solved = false;
  std::string reference_error;
  Eigen::Vector3d reference_force = Eigen::Vector3d::Zero();  ///< N
  std::size_t reference_tetrahedra = 0;
  double reference_cell_mm =
      0.0;  ///< the reference's cells at the site: the longest edge of the tetrahedra at its nearest node
  std::optional<Eigen::Vector3d> check_force;  ///< N, the reference on the --check-refinement cells
  double thickness_mm = 0.0;                   ///< the organ's thickness along the straight press at the site
  double clamp_distance_mm = 0.0;              ///< from the site to the clamp's centre
  /// What the organ rests on where the straight press's line leaves it again.
  model::Supports::Kind support_behind = model::Supports::Kind::kFree;
  double reference_stretch = 1.0;  ///< the reference surface's largest edge stretch
  std::map<std::string, FastAnswer> fast;
};

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * kDegreesPerRadian;
}

FastAnswer answer(const std::string& name, const organ::Organ& organ, const PressRecord& r,
                  const PressResult& reference, const PressOptions& o, const Eigen::Vector3d& extent) {
  FastAnswer a;
  try {
    const PressResult fast = press(name, organ, {r.tool}, o);
    a.force = fast.tools[0].force;
    a.solved = a.force.norm() > 0.0;
    if (!a.solved) {
      a.error = "no force";
      return a;
    }
    a.log_ratio = std::log(a.force.norm() / r.reference_force.norm());
    a.direction_error_deg = angle_deg(a.force, r.reference_force);
    a.surface_difference = compare_presses(fast, reference, extent).surface.mean;
    const model::OrganModel& m = organ.model();
    a.largest_stretch = geometry::largest_edge_stretch(m.surface_vertices, fast.positions, m.surface_triangles);
  } catch (const std::runtime_error& e) {
    a.error = e.what();
  }
  return a;
}

/// A group of presses' figures for one model: the force factor
/// exp(√mean ln²(|F|/|F_ref|)), the direction error, the surface
/// displacement difference and the worst stretch factor: over the presses, the
/// surface's largest edge stretch against the reference's, exp(max |ln(λ/λ_ref)|).
struct Summary {
  std::size_t presses = 0, unsolved = 0;
  double factor = 0.0, direction_mean_deg = 0.0, direction_max_deg = 0.0, difference_mean = 0.0;
  double stretch_factor_max = 1.0;
};

template <typename Keep>
Summary summarize(const std::vector<PressRecord>& records, const std::string& model, Keep keep) {
  Summary s;
  double log_squares = 0.0;
  for (const PressRecord& r : records) {
    if (!r.reference_solved || !keep(r)) continue;
    const FastAnswer& a = r.fast.at(model);
    if (!a.solved) {
      ++s.unsolved;
      continue;
    }
    ++s.presses;
    log_squares += a.log_ratio * a.log_ratio;
    s.direction_mean_deg += a.direction_error_deg;
    s.direction_max_deg = std::max(s.direction_max_deg, a.direction_error_deg);
    s.difference_mean += a.surface_difference;
    s.stretch_factor_max =
        std::max(s.stretch_factor_max, std::exp(std::abs(std::log(a.largest_stretch / r.reference_stretch))));
  }
  if (s.presses == 0) return s;
  const double n = static_cast<double>(s.presses);
  s.factor = std::exp(std::sqrt(log_squares / n));
  s.direction_mean_deg /= n;
  s.difference_mean /= n;
  return s;
}

/// The reference's straight presses at one depth from site to site: its force,
/// and how much of its spread the organ's thickness under the press and the
/// distance to the clamp explain.
struct SiteSpread {
  std::vector<const PressRecord*> presses;
  double least_n = 0.0, most_n = 0.0;
  std::optional<plot::PowerLawFit> thickness, clamp_distance;  ///< from 3 presses on
};

/// |F| ∝ x^p over the sites, from three presses on (two always fit exactly).
std::optional<plot::PowerLawFit> spread_fit(const std::vector<double>& x, const std::vector<double>& force,
                                            const char* what) {
  if (x.size() < 3) return std::nullopt;
  try {
    return plot::fit_power_law(x, force, what);
  } catch (const std::invalid_argument&) {
    return std::nullopt;  // every site at the same distance, or a zero force: no power law to fit
  }
}

SiteSpread site_spread(const std::vector<PressRecord>& records, double depth_mm) {
  SiteSpread s;
  std::vector<double> force, thickness, clamp;
  for (const PressRecord& r : records) {
    if (!r.reference_solved || r.tilt != PressTilt::straight || r.depth_mm != depth_mm || !(r.thickness_mm > 0.0))
      continue;
    s.presses.push_back(&r);
    force.push_back(r.reference_force.norm());
    thickness.push_back(r.thickness_mm);
    clamp.push_back(r.clamp_distance_mm);
  }
  if (s.presses.empty()) return s;
  s.least_n = *std::min_element(force.begin(), force.end());
  s.most_n = *std::max_element(force.begin(), force.end());
  s.thickness = spread_fit(thickness, force, "the thickness under the press");
  s.clamp_distance = spread_fit(clamp, force, "the distance to the clamp");
  return s;
}

nlohmann::json fit_json(const std::optional<plot::PowerLawFit>& fit) {
  if (!fit) return nullptr;
  return {{"exponent", fit->exponent}, {"explained", fit->explained}};
}

nlohmann::json summary_json(const Summary& s) {
  return {{"presses", s.presses},
          {"unsolved", s.unsolved},
          {"force_factor", s.factor},
          {"direction_error_mean_deg", s.direction_mean_deg},
          {"direction_error_max_deg", s.direction_max_deg},
          {"mean_difference", s.difference_mean},
          {"stretch_factor_max", s.stretch_factor_max}};
}

nlohmann::json vector_json(const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }

const char* tilt_name(PressTilt tilt) { return tilt == PressTilt::straight ? "straight" : "tilted"; }

const char* support_name(model::Supports::Kind kind) {
  switch (kind) {
    case model::Supports::Kind::kContact: return "contact";
    case model::Supports::Kind::kAttachment: return "attachment";
    case model::Supports::Kind::kFree: break;
  }
  return "free";
}

void print_json(const EvaluationOptions& o, double refine_size_mm, std::size_t sites,
                const std::vector<PressRecord>& records) {
  nlohmann::json presses = nlohmann::json::array(), summary;
  for (const PressRecord& r : records) {
    nlohmann::json p = {{"site", r.site + 1},
                        {"vertex", r.vertex},
                        {"tool", r.tool.text},
                        {"direction", tilt_name(r.tilt)},
                        {"depth_mm", r.depth_mm},
                        {"thickness_mm", r.thickness_mm},
                        {"clamp_distance_mm", r.clamp_distance_mm},
                        {"support_behind", support_name(r.support_behind)},
                        {"reference_solved", r.reference_solved}};
    if (!r.reference_solved) {
      p["reference_error"] = r.reference_error;
    } else {
      p["reference_force_n"] = vector_json(r.reference_force);
      p["reference_tetrahedra"] = r.reference_tetrahedra;
      p["reference_cell_at_site_mm"] = r.reference_cell_mm;
      p["reference_largest_stretch"] = r.reference_stretch;
      if (r.check_force) p["check_force_n"] = vector_json(*r.check_force);
      for (const auto& [name, a] : r.fast) {
        if (!a.solved) {
          p[name] = {{"error", a.error}};
          continue;
        }
        p[name] = {{"force_n", vector_json(a.force)},
                   {"force_ratio", std::exp(a.log_ratio)},
                   {"direction_error_deg", a.direction_error_deg},
                   {"mean_difference", a.surface_difference},
                   {"largest_stretch", a.largest_stretch}};
      }
    }
    presses.push_back(std::move(p));
  }
  for (const std::string& model : fast_models()) {
    nlohmann::json by_depth;
    for (const double depth : o.depths_mm) {
      auto at = [&](const PressRecord& r) { return r.depth_mm == depth; };
      by_depth[fmt::format("{:g}", depth)] = {
          {"all", summary_json(summarize(records, model, at))},
          {"straight",
           summary_json(summarize(records, model,
                                  [&](const PressRecord& r) { return at(r) && r.tilt == PressTilt::straight; }))},
          {"tilted", summary_json(summarize(records, model, [&](const PressRecord& r) {
             return at(r) && r.tilt != PressTilt::straight;
           }))}};
    }
    summary[model] = {{"by_depth_mm", by_depth},
                      {"all", summary_json(summarize(records, model, [](const PressRecord&) { return true; }))}};
  }
  nlohmann::json spread;
  for (const double depth : o.depths_mm) {
    const SiteSpread s = site_spread(records, depth);
    if (s.presses.empty()) continue;
    spread[fmt::format("{:g}", depth)] = {{"presses", s.presses.size()},
                                          {"least_force_n", s.least_n},
                                          {"most_force_n", s.most_n},
                                          {"thickness", fit_json(s.thickness)},
                                          {"clamp_distance", fit_json(s.clamp_distance)}};
  }
  const nlohmann::json j = {{"model", o.model_path},
                            {"reference", o.reference},
                            {"tip_radius_mm", o.press.tuning.tip_radius * 1e3},
                            {"reference_cells_mm", refine_size_mm},
                            {"check_cells_mm", o.check_size_mm},
                            {"seed", o.seed},
                            {"pull_bite_mm", o.pull_bite_mm},
                            {"sites", sites},
                            {"depths_mm", o.depths_mm},
                            {"summary", summary},
                            {"reference_spread_by_depth_mm", spread},
                            {"presses", presses}};
  std::cout << j.dump() << '\n';
}

void print_table(const EvaluationOptions& o, double refine_size_mm, std::size_t sites,
                 const std::vector<PressRecord>& records) {
  std::size_t failed = 0;
  for (const PressRecord& r : records) failed += !r.reference_solved;
  std::cout << fmt::format(
      "{:<14}{} against {} on {}: {} sites (seed {}), each {} 45 degrees, {} presses; tip radius {:g} mm\n", "evaluate",
      o.model_path, o.reference,
      refine_size_mm > 0.0 ? fmt::format("tetrahedra re-meshed to {:g} mm around each site", refine_size_mm)
                           : std::string("the model's own tetrahedra"),
      sites, o.seed,
      o.pull_bite_mm > 0.0
          ? fmt::format("grasped after a {:g} mm bite and pulled straight out and tilted", o.pull_bite_mm)
          : std::string("pressed straight in and tilted"),
      records.size(), o.press.tuning.tip_radius * 1e3);
  for (const PressRecord& r : records)
    if (!r.reference_solved)
      std::cout << fmt::format("{:<14}site {} {} {:g} mm ({}): {}\n", "unsolved", r.site + 1, tilt_name(r.tilt),
                               r.depth_mm, r.tool.text, r.reference_error);
  std::cout << fmt::format(
      "\nforce factor exp(sqrt(mean ln^2(|F| / |F_ref|))), the factor the forces are typically off by; direction: "
      "angle between F and F_ref (mean / max); displacement: mean surface vertex difference, % of the bounding box "
      "diagonal; stretch: the surface's largest edge stretch against the reference's, the worst press's factor "
      "({} of {} presses solved by the reference)\n\n",
      records.size() - failed, records.size());
  std::cout << "| model   | depth | direction | presses | force factor | direction mean / max | displacement | "
               "stretch |\n";
  for (const std::string& model : fast_models())
    for (const double depth : o.depths_mm)
      for (const char* direction : {"straight", "tilted", "all"}) {
        const Summary s = summarize(records, model, [&](const PressRecord& r) {
          const std::string name = tilt_name(r.tilt);
          return r.depth_mm == depth && (std::string(direction) == "all" || name == direction);
        });
        std::cout << fmt::format(
            "| {:<7} | {:>3g} mm | {:<9} | {:>7} | {:>11.2f}x | {:>8.1f} / {:>5.1f} deg | {:>11.2f}% | {:>6.2f}x |\n",
            model, depth, direction, s.presses, s.factor, s.direction_mean_deg, s.direction_max_deg,
            100 * s.difference_mean, s.stretch_factor_max);
      }
  bool any_check = false;
  for (const PressRecord& r : records)
    if (r.check_force) {
      if (!any_check)
        std::cout << fmt::format(
            "\nthe reference under refinement, straight presses: |F| on {:g} mm cells, on {:g} "
            "mm cells, change\n",
            refine_size_mm, o.check_size_mm);
      any_check = true;
      std::cout << fmt::format("{:<14}site {:>2} {:>4g} mm: {:.4f} N, {:.4f} N, {:+.1f} %\n", "refinement", r.site + 1,
                               r.depth_mm, r.reference_force.norm(), r.check_force->norm(),
                               100 * (r.check_force->norm() / r.reference_force.norm() - 1));
    }
  for (const double depth : o.depths_mm) {
    const SiteSpread s = site_spread(records, depth);
    if (s.presses.empty()) continue;
    std::cout << fmt::format(
        "\nthe reference from site to site, straight {:g} mm presses: |F|, the organ's thickness "
        "along the press, the distance to the clamp's centre, what the organ rests on behind the site\n",
        depth);
    for (const PressRecord* r : s.presses)
      std::cout << fmt::format("{:<14}site {:>2} {:>4g} mm: {:.4f} N, {:.1f} mm, {:.1f} mm, {}\n", "site", r->site + 1,
                               depth, r->reference_force.norm(), r->thickness_mm, r->clamp_distance_mm,
                               support_name(r->support_behind));
    std::cout << fmt::format("{:<14}{:g} mm: {:.4f} to {:.4f} N ({:.1f}x) over {} sites", "spread", depth, s.least_n,
                             s.most_n, s.most_n / s.least_n, s.presses.size());
    auto fit = [](const char* what, const std::optional<plot::PowerLawFit>& f) {
      return f ? fmt::format("; ln|F| against ln {}: exponent {:.2f}, explains {:.0f} %", what, f->exponent,
                             100 * f->explained)
               : std::string();
    };
    std::cout << fit("thickness", s.thickness) << fit("clamp distance", s.clamp_distance) << '\n';
  }
}

/// What every site's presses share.
struct Plan {
  const EvaluationOptions& o;
  const model::OrganModel& model;
  const organ::Organ& organ;
  Eigen::Vector3d extent;
  std::vector<Eigen::Vector3d> normals;
  std::vector<std::uint32_t> sites;
  double refine_size_mm = 0.0, refine_radius_mm = 0.0;
  PressOptions settled;  ///< the mass-spring model's presses
  const ReferenceCache& cache;
};

// A record crosses from a job's process to the parent as JSON, every number
// to the last bit.
nlohmann::json exact_vector_json(const Eigen::Vector3d& v) {
  return nlohmann::json::array({exact_json(v.x()), exact_json(v.y()), exact_json(v.z())});
}
Eigen::Vector3d exact_vector(const nlohmann::json& j) {
  return {exact_double(j.at(0)), exact_double(j.at(1)), exact_double(j.at(2))};
}

/// Site k's presses by the reference, on the organ re-meshed around the site:
/// fills each record's reference part and `surfaces` (the reference's
/// surface, where it solved).
void press_reference(const Plan& plan, std::size_t k, std::vector<PressRecord>& records,
                     std::vector<std::vector<model::Point3>>& surfaces) {
  const EvaluationOptions& o = plan.o;
  const Eigen::Vector3d at = site_point(plan.organ, plan.sites[k]);
  const std::unique_ptr<organ::Organ> reference =
      reference_at(plan.model, at, plan.refine_size_mm, plan.refine_radius_mm);
  const std::unique_ptr<organ::Organ> check =
      o.check_size_mm > 0.0 ? reference_at(plan.model, at, o.check_size_mm, plan.refine_radius_mm) : nullptr;
  for (std::size_t i = 0; i < records.size(); ++i) {
    PressRecord& r = records[i];
    r.reference_tetrahedra = reference->model().tetrahedra.size();
    r.reference_cell_mm = 1e3 * cell_size_at(*reference, at);
    note("calibrate", fmt::format("site {} of {}, {} {:g} mm: {} with {} ({} tetrahedra)", k + 1, plan.sites.size(),
                                  tilt_name(r.tilt), r.depth_mm, r.tool.text, o.reference, r.reference_tetrahedra));
    try {
      PressResult pressed = press(o.reference, *reference, {r.tool}, o.press);
      r.reference_force = pressed.tools[0].force;
      r.reference_solved = r.reference_force.norm() > 0.0;
      if (!r.reference_solved) r.reference_error = "the reference gave no force";
      surfaces[i] = std::move(pressed.positions);  // the surfaces compare vertex by vertex; the tetrahedra differ
    } catch (const std::runtime_error& e) {
      r.reference_error = e.what();
    }
    if (!r.reference_solved) {
      warn("calibrate", fmt::format("site {} {} {:g} mm: the reference did not solve: {}", k + 1, tilt_name(r.tilt),
                                    r.depth_mm, r.reference_error));
      continue;
    }
    if (check && r.tilt == PressTilt::straight) {
      try {
        r.check_force = press(o.reference, *check, {r.tool}, o.press).tools[0].force;
      } catch (const std::runtime_error& e) {
        warn("calibrate",
             fmt::format("site {} {:g} mm on {:g} mm cells: {}", k + 1, r.depth_mm, o.check_size_mm, e.what()));
      }
    }
  }
}

/// The reference part of a site's records (every press solved) and their
/// surfaces, as the cache keeps them (every number to the last bit).
nlohmann::json reference_json(const std::vector<PressRecord>& records,
                              const std::vector<std::vector<model::Point3>>& surfaces) {
  nlohmann::json presses = nlohmann::json::array();
  for (std::size_t i = 0; i < records.size(); ++i) {
    const PressRecord& r = records[i];
    nlohmann::json surface = nlohmann::json::array();
    for (const model::Point3& p : surfaces[i]) surface.push_back(exact_vector_json({p[0], p[1], p[2]}));
    presses.push_back({{"tool", r.tool.text},
                       {"solved", r.reference_solved},
                       {"force", exact_vector_json(r.reference_force)},
                       {"tetrahedra", r.reference_tetrahedra},
                       {"cell_mm", exact_json(r.reference_cell_mm)},
                       {"check_force", r.check_force ? exact_vector_json(*r.check_force) : nlohmann::json(nullptr)},
                       {"surface", surface}});
  }
  return presses;
}

/// Fills the records' reference part from what the cache kept; false (the
/// records untouched) when the kept presses are not these or do not parse.
bool read_reference(const nlohmann::json& kept, std::vector<PressRecord>& records,
                    std::vector<std::vector<model::Point3>>& surfaces, std::size_t vertices) {
  if (!kept.is_array() || kept.size() != records.size()) return false;
  std::vector<PressRecord> read = records;
  std::vector<std::vector<model::Point3>> read_surfaces(records.size());
  try {
    for (std::size_t i = 0; i < records.size(); ++i) {
      const nlohmann::json& k = kept[i];
      PressRecord& r = read[i];
      if (k.at("tool").get<std::string>() != r.tool.text || !k.at("solved").get<bool>()) return false;
      r.reference_solved = true;
      r.reference_force = exact_vector(k.at("force"));
      r.reference_tetrahedra = k.at("tetrahedra").get<std::size_t>();
      r.reference_cell_mm = exact_double(k.at("cell_mm"));
      if (!k.at("check_force").is_null()) r.check_force = exact_vector(k.at("check_force"));
      for (const nlohmann::json& p : k.at("surface")) {
        const Eigen::Vector3d v = exact_vector(p);
        read_surfaces[i].push_back({v.x(), v.y(), v.z()});
      }
      if (read_surfaces[i].size() != vertices) return false;
    }
  } catch (const std::exception&) {  // a damaged file: nlohmann's errors and exact_double's
    return false;
  }
  records = std::move(read);
  surfaces = std::move(read_surfaces);
  return true;
}

/// Site k's presses: straight in and tilted, at every depth, the reference on
/// the organ re-meshed around the site (or as --reference-cache kept it),
/// then the fast models.
std::vector<PressRecord> press_site(const Plan& plan, std::size_t k) {
  const EvaluationOptions& o = plan.o;
  const organ::Organ& organ = plan.organ;
  const std::uint32_t vertex = plan.sites[k];
  const Eigen::Vector3d at = site_point(organ, vertex);
  std::vector<PressRecord> records;
  for (const PressTilt tilt : {PressTilt::straight, static_cast<PressTilt>(1 + k % 2)})
    for (const double depth : o.depths_mm) {
      PressRecord r;
      r.site = k;
      r.vertex = vertex;
      r.tilt = tilt;
      r.depth_mm = depth;
      r.tool = site_press(organ, vertex, plan.normals[vertex], tilt, depth, o.press);
      if (o.pull_bite_mm > 0.0) r.tool = pulled_out(r.tool, plan.normals[vertex]);
      r.thickness_mm = 1e3 * thickness_along(organ, at, -plan.normals[vertex]);
      r.clamp_distance_mm = 1e3 * (at - organ.fixed_point()).norm();
      r.support_behind = support_behind(organ, at, -plan.normals[vertex]);
      records.push_back(std::move(r));
    }
  std::vector<std::vector<model::Point3>> surfaces(records.size());
  const std::string key = plan.cache.site_key(k, vertex);
  const std::optional<nlohmann::json> kept = plan.cache.find(key);
  if (kept && read_reference(*kept, records, surfaces, organ.vertex_count())) {
    note("calibrate", fmt::format("site {} of {}: the reference's presses as --reference-cache kept them", k + 1,
                                  plan.sites.size()));
  } else {
    press_reference(plan, k, records, surfaces);
    // A site the reference could not press in full is pressed again next time
    // (a failure can be the machine's: memory short under many jobs).
    const bool all_solved =
        std::all_of(records.begin(), records.end(), [](const PressRecord& r) { return r.reference_solved; });
    if (plan.cache.enabled() && all_solved) {
      try {
        plan.cache.keep(key, reference_json(records, surfaces));
      } catch (const std::runtime_error& e) {
        warn("calibrate", fmt::format("site {}: --reference-cache could not keep its presses: {}", k + 1, e.what()));
      }
    }
  }
  for (std::size_t i = 0; i < records.size(); ++i) {
    PressRecord& r = records[i];
    if (!r.reference_solved) continue;
    PressResult reference;
    reference.positions = std::move(surfaces[i]);
    r.reference_stretch = geometry::largest_edge_stretch(organ.model().surface_vertices, reference.positions,
                                                         organ.model().surface_triangles);
    std::string forces;
    for (const std::string& name : fast_models()) {
      const bool settles = realtime::find_model(name)->static_press == realtime::StaticPress::settled;
      r.fast[name] = answer(name.c_str(), organ, r, reference, settles ? plan.settled : o.press, plan.extent);
      forces += fmt::format(", {} {:.4f} N", name, r.fast[name].force.norm());
    }
    detail("calibrate", fmt::format("|F| {} {:.4f} N{}", o.reference, r.reference_force.norm(), forces));
  }
  return records;
}

nlohmann::json record_json(const PressRecord& r) {
  nlohmann::json fast = nlohmann::json::object();
  for (const auto& [name, a] : r.fast)
    fast[name] = {{"solved", a.solved},
                  {"error", a.error},
                  {"force", exact_vector_json(a.force)},
                  {"log_ratio", exact_json(a.log_ratio)},
                  {"direction", exact_json(a.direction_error_deg)},
                  {"difference", exact_json(a.surface_difference)},
                  {"stretch", exact_json(a.largest_stretch)}};
  return {{"site", r.site},
          {"vertex", r.vertex},
          {"tilt", static_cast<int>(r.tilt)},
          {"depth_mm", exact_json(r.depth_mm)},
          {"tool",
           {{"text", r.tool.text},
            {"point_mm", exact_vector_json(r.tool.point_mm)},
            {"displacement_mm", exact_vector_json(r.tool.displacement_mm)}}},
          {"reference_solved", r.reference_solved},
          {"reference_error", r.reference_error},
          {"reference_force", exact_vector_json(r.reference_force)},
          {"reference_tetrahedra", r.reference_tetrahedra},
          {"reference_cell_mm", exact_json(r.reference_cell_mm)},
          {"check_force", r.check_force ? exact_vector_json(*r.check_force) : nlohmann::json(nullptr)},
          {"thickness_mm", exact_json(r.thickness_mm)},
          {"clamp_distance_mm", exact_json(r.clamp_distance_mm)},
          {"support_behind", static_cast<int>(r.support_behind)},
          {"reference_stretch", exact_json(r.reference_stretch)},
          {"fast", fast}};
}

PressRecord record_from(const nlohmann::json& j) {
  PressRecord r;
  r.site = j.at("site").get<std::size_t>();
  r.vertex = j.at("vertex").get<std::uint32_t>();
  r.tilt = static_cast<PressTilt>(j.at("tilt").get<int>());
  r.depth_mm = exact_double(j.at("depth_mm"));
  const nlohmann::json& tool = j.at("tool");
  r.tool = {tool.at("text").get<std::string>(), exact_vector(tool.at("point_mm")),
            exact_vector(tool.at("displacement_mm"))};
  r.reference_solved = j.at("reference_solved").get<bool>();
  r.reference_error = j.at("reference_error").get<std::string>();
  r.reference_force = exact_vector(j.at("reference_force"));
  r.reference_tetrahedra = j.at("reference_tetrahedra").get<std::size_t>();
  r.reference_cell_mm = exact_double(j.at("reference_cell_mm"));
  if (!j.at("check_force").is_null()) r.check_force = exact_vector(j.at("check_force"));
  r.thickness_mm = exact_double(j.at("thickness_mm"));
  r.clamp_distance_mm = exact_double(j.at("clamp_distance_mm"));
  r.support_behind = static_cast<model::Supports::Kind>(j.at("support_behind").get<int>());
  r.reference_stretch = exact_double(j.at("reference_stretch"));
  for (const auto& [name, a] : j.at("fast").items())
    r.fast[name] = {a.at("solved").get<bool>(),      a.at("error").get<std::string>(), exact_vector(a.at("force")),
                    exact_double(a.at("log_ratio")), exact_double(a.at("direction")),  exact_double(a.at("difference")),
                    exact_double(a.at("stretch"))};
  return r;
}

}  // namespace

int run_evaluation(const EvaluationOptions& given) {
  EvaluationOptions o = given;
  o.press.grasp_bite_mm = o.pull_bite_mm;  // a pull is a grasp drawn out (press(): a bite, the jaws closed, the move)
  if (o.depths_mm.empty()) throw CLI::ValidationError("--depths", "give at least one depth");
  for (const double d : o.depths_mm)
    if (!(d > 0.0 && std::isfinite(d)))
      throw CLI::ValidationError("--depths", "each depth must be a positive number of mm");
  if (o.jobs < 0) throw CLI::ValidationError("--jobs", "must be 0 (one per CPU) or more");
  std::vector<std::string> needed = fast_models();
  needed.push_back(o.reference);
  const model::OrganModel model = load_simulation_model("calibrate", o.model_path, needed);
  warn_if_depth_curve_rescaled("calibrate", model, fast_models(), o.press.tuning);
  const organ::Organ organ(model);
  const double radius_mm = o.press.tuning.tip_radius * 1e3;
  // A mass-spring press held longer for a softened network (calibrate's rule).
  PressOptions settled = o.press;
  settled.settle_seconds *= std::min(5.0, 1.0 / std::sqrt(std::min(1.0, model.material.spring_stiffness_scale)));
  const double refine_size_mm = o.refine_size_mm < 0.0 ? 0.5 * radius_mm : o.refine_size_mm;
  // The tip's whole path and what it takes in, with a margin: cells of the
  // refinement size within the deepest press plus two radii of the site.
  const double refine_radius_mm = *std::max_element(o.depths_mm.begin(), o.depths_mm.end()) + 2.0 * radius_mm;
  nlohmann::json reference_options = {
      {"reference", o.reference},
      {"depths_mm", o.depths_mm},
      {"refine_size_mm", exact_json(refine_size_mm)},
      {"refine_radius_mm", exact_json(refine_radius_mm)},
      {"check_size_mm", exact_json(o.check_size_mm)},
      {"pull_bite_mm", exact_json(o.pull_bite_mm)},
      {"snap_distance_mm", exact_json(o.press.snap_distance_mm)},
      {"fixed_radius_mm", exact_json(o.press.tuning.models.of<fem::OrganFemOptions>().fixed_radius * 1e3)},
      {"linear_solver", o.press.tuning.linear_solver},
      {"tip_radius_mm", exact_json(radius_mm)},
      {"friction", exact_json(o.press.tuning.friction)}};
  // Only a reference on its supports names them, so that the caches of those
  // held by their clamp alone stay valid.
  if (o.press.tuning.models.of<fem::OrganFemOptions>().supports) reference_options["supports"] = "baked";
  const ReferenceCache cache(
      o.reference_cache, o.reference_cache.empty() ? std::string() : reference_fingerprint(model, reference_options));
  const Plan plan{o,
                  model,
                  organ,
                  bounding_box_extent(model.surface_vertices),
                  rest_normals(organ),
                  press_sites(organ, o.sites, o.seed, o.press),
                  refine_size_mm,
                  refine_radius_mm,
                  settled,
                  cache};

  const std::size_t jobs = std::min(plan.sites.size(), o.jobs > 0 ? static_cast<std::size_t>(o.jobs) : usable_cpus());
  if (jobs > 1) note("calibrate", fmt::format("{} sites shared among {} processes", plan.sites.size(), jobs));
  const std::vector<nlohmann::json> by_site = run_site_jobs(plan.sites.size(), jobs, [&](std::size_t k) {
    nlohmann::json site = nlohmann::json::array();
    for (const PressRecord& r : press_site(plan, k)) site.push_back(record_json(r));
    return site;
  });
  std::vector<PressRecord> records;
  for (const nlohmann::json& site : by_site)
    for (const nlohmann::json& r : site) records.push_back(record_from(r));
  if (std::none_of(records.begin(), records.end(), [](const PressRecord& r) { return r.reference_solved; }))
    throw std::runtime_error(fmt::format("none of the {} presses could be solved by {}: press less deep (--depths)",
                                         records.size(), o.reference));
  if (o.json)
    print_json(o, plan.refine_size_mm, plan.sites.size(), records);
  else
    print_table(o, plan.refine_size_mm, plan.sites.size(), records);
  return 0;
}

}  // namespace organsim::cli
