// `organsim calibrate MODEL -o CALIBRATED.organ [--reference psh|corotational]
// [--presses N]`: presses the organ at N places spread over its surface with
// the reference FEM model and fits the fast models to it: the multi-beam
// model's attenuation and stiffness scale, the mass-spring model's stiffness
// scale. Half the presses fit, the other half measure the error before and
// after; the fitted values go into a copy of the model with their provenance.
//
// Why the fit is so simple (docs/cli.md, `organsim calibrate`): under a prescribed tool
// displacement the multi-beam space distortion of a single tool is
// exp(−κ d) s(x), s independent of the material and κ = β ln α; its force is
// linear in E. So κ is a one-dimensional minimization of the nodal
// displacement difference (only β ln α enters: α is kept and β fitted), and
// each stiffness scale is the geometric mean of the force ratios |F_ref|/|F|:
// the reference's point-contact stiffness varies tenfold from site to site,
// and a least-squares fit on the forces themselves would follow the stiffest
// few presses and be off by that much everywhere else.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <random>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/model/model_file.h"
#include "depth_curve_fit.h"
#include "pull_curve_fit.h"
#include "held_out_evaluation.h"
#include "press_plan.h"
#include "static_press/static_press.h"

namespace organsim::cli {
namespace {

struct CalibrateOptions {
  std::string model_path, output_path;
  std::string reference = realtime::reference_model().name;
  int presses = 16;
  double depth_mm = 5.0;
  std::uint32_t seed = 1;
  bool json = false;
  bool evaluate = false;
  EvaluationOptions evaluation;  ///< also the depth curve's depths and reference cells
  int curve_sites = 6;
  int pull_sites = 6;                                   ///< with --pull: the pull curve's sites
  std::vector<double> pull_depths_mm{5.0, 10.0, 20.0};  ///< with --pull: how far the pull curve's grasps are drawn
  PressOptions press = settled_long_enough();
  /// The mass-spring presses held 6 s (the engine's 2 s settle a unit-scale
  /// network; a fitted softer one rings longer, and an unsettled press would
  /// show as a displacement error the fit did not make).
  static PressOptions settled_long_enough() {
    PressOptions o;
    o.settle_seconds = 6.0;
    return o;
  }
};

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

/// The depth and pull curves' sites start from --seed plus this.
constexpr std::uint32_t kCurveSeedOffset = 1000;

/// Where a curve's `count` sites are pressed: other sites than `calibrate
/// --evaluate --seed N` presses (those the evaluation measures are held out
/// from the curves), the reference on the evaluation's cells.
CurveSiteOptions curve_sites(const CalibrateOptions& o, int count) {
  CurveSiteOptions sites;
  sites.sites = count;
  sites.seed = o.seed + kCurveSeedOffset;
  sites.refine_size_mm = o.evaluation.refine_size_mm;
  sites.reference = o.reference;
  sites.jobs = o.evaluation.jobs;
  sites.press = o.press;
  return sites;
}

/// The fast models calibrate fits (their registry entries' calibration), in
/// the registry's order; at most the first with an attenuation has it fitted.
std::vector<const realtime::RegisteredModel*> calibrated_models() {
  std::vector<const realtime::RegisteredModel*> models;
  for (const realtime::RegisteredModel* entry : realtime::registered_models())
    if (entry->calibration.stiffness_scale) models.push_back(entry);
  return models;
}

/// The index in `models` of the model whose attenuation is fitted, or -1.
int attenuated_index(const std::vector<const realtime::RegisteredModel*>& models) {
  for (std::size_t k = 0; k < models.size(); ++k)
    if (models[k]->calibration.attenuated) return static_cast<int>(k);
  return -1;
}

/// `o` for pressing `entry` on an organ of `material`: a model that settles
/// (StaticPress::settled) softened by a stiffness scale s rings 1/sqrt(s)
/// times longer, and is held that much longer (at most 5 times) so that each
/// press is measured settled.
PressOptions held_until_settled(const realtime::RegisteredModel& entry, const model::Material& material,
                                PressOptions o) {
  if (entry.static_press == realtime::StaticPress::settled && entry.calibration.stiffness_scale)
    o.settle_seconds *= std::min(5.0, 1.0 / std::sqrt(std::min(1.0, material.*entry.calibration.stiffness_scale)));
  return o;
}

/// One press of the calibration: the reference's answer and what the fast
/// models need to be refitted without pressing again.
struct Probe {
  ToolSpec tool;
  PressResult reference;
  std::vector<Eigen::Vector3d>
      unattenuated;                    ///< per tetrahedral node: the attenuated model's displacement with κ = 0, m
  std::vector<double> distance;        ///< per tetrahedral node: from that model's action point, m
  std::vector<Eigen::Vector3d> force;  ///< per calibrated model: its force at stiffness scale 1, N
};

/// Mean nodal displacement difference (fraction of the bounding box's
/// diagonal) of the attenuated field exp(−κ d) s against the reference.
double attenuated_difference(const Probe& p, const organ::Organ& organ, double rate, double diagonal) {
  const std::vector<model::Point3>& rest = organ.model().volume_vertices;
  double sum = 0.0;
  for (std::size_t n = 0; n < rest.size(); ++n) {
    const Eigen::Vector3d reference = point(p.reference.node_positions[n]) - point(rest[n]);
    sum += (std::exp(-rate * p.distance[n]) * p.unattenuated[n] - reference).norm();
  }
  return sum / (diagonal * static_cast<double>(std::max<std::size_t>(rest.size(), 1)));
}

double mean_attenuated_difference(const std::vector<Probe>& probes, const organ::Organ& organ, double rate,
                                  double diagonal) {
  double sum = 0.0;
  for (const Probe& p : probes) sum += attenuated_difference(p, organ, rate, diagonal);
  return sum / static_cast<double>(probes.size());
}

/// The attenuation rate κ (1/m) that minimizes the mean difference: a scan
/// over [0, 400] 1/m, then golden-section search around the best point.
double fit_attenuation_rate(const std::vector<Probe>& probes, const organ::Organ& organ, double diagonal) {
  constexpr double kHighest = 400.0, kStep = 10.0;
  auto cost = [&](double rate) { return mean_attenuated_difference(probes, organ, rate, diagonal); };
  double best = 0.0, best_cost = cost(0.0);
  for (double rate = kStep; rate <= kHighest; rate += kStep)
    if (const double c = cost(rate); c < best_cost) best = rate, best_cost = c;
  double low = std::max(0.0, best - kStep), high = best + kStep;
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = high - ratio * (high - low), b = low + ratio * (high - low);
  double cost_a = cost(a), cost_b = cost(b);
  for (int i = 0; i < 40; ++i) {
    if (cost_a < cost_b) {
      high = b, b = a, cost_b = cost_a;
      a = high - ratio * (high - low), cost_a = cost(a);
    } else {
      low = a, a = b, cost_a = cost_b;
      b = low + ratio * (high - low), cost_b = cost(b);
    }
  }
  const double refined = 0.5 * (low + high);
  return cost(refined) < best_cost ? refined : best;
}

/// ln(|F| / |F_reference|) of one press.
double log_force_ratio(const Eigen::Vector3d& force, const Eigen::Vector3d& reference) {
  return std::log(force.norm() / reference.norm());
}

/// The scale s minimizing Σ ln²(s |F| / |F_reference|) over the probes (the
/// forces of calibrated model `k`): the geometric mean of the ratios
/// |F_reference| / |F|.
double fit_force_scale(const std::vector<Probe>& probes, std::size_t k) {
  double sum = 0.0;
  for (const Probe& p : probes) {
    if (!(p.force[k].norm() > 0.0) || !(p.reference.tools[0].force.norm() > 0.0))
      throw std::runtime_error("a press gave no force to fit a stiffness to: press deeper (--depth)");
    sum -= log_force_ratio(p.force[k], p.reference.tools[0].force);
  }
  return std::exp(sum / static_cast<double>(probes.size()));
}

/// The factor by which model `k`'s forces are typically off, exp(sqrt(mean
/// ln²(s |F| / |F_reference|))) (1 = exact; 2 = twice or half the
/// reference's): what the fit minimizes, stiff and soft alike.
double force_factor(const std::vector<Probe>& probes, std::size_t k, double scale) {
  double sum = 0.0;
  for (const Probe& p : probes) sum += std::pow(log_force_ratio(scale * p.force[k], p.reference.tools[0].force), 2);
  return std::exp(std::sqrt(sum / static_cast<double>(probes.size())));
}

/// Held-out errors of one fast model as pressed with an organ's material.
/// Forces as the typical factor off (force_factor) and as the vector error
/// sqrt(Σ |F − F_reference|² / Σ |F_reference|²), which the largest forces
/// dominate.
struct ModelError {
  double difference = 0.0, force = 0.0, factor = 0.0;
};
/// Per calibrated model.
using HeldOutError = std::vector<ModelError>;

HeldOutError measure_held_out(const organ::Organ& organ, const std::vector<const realtime::RegisteredModel*>& models,
                              const std::vector<Probe>& probes, const PressOptions& o, const Eigen::Vector3d& extent) {
  HeldOutError errors(models.size());
  double reference_size = 0.0;
  for (const Probe& p : probes) reference_size += p.reference.tools[0].force.squaredNorm();
  const double n = static_cast<double>(probes.size());
  for (std::size_t k = 0; k < models.size(); ++k) {
    const PressOptions held = held_until_settled(*models[k], organ.model().material, o);
    double difference = 0.0, force = 0.0, log_squares = 0.0;
    for (const Probe& p : probes) {
      const PressResult pressed = press(models[k]->name, organ, {p.tool}, held);
      const Eigen::Vector3d& reference = p.reference.tools[0].force;
      difference += compare_presses(pressed, p.reference, extent).measure.mean;
      force += (pressed.tools[0].force - reference).squaredNorm();
      log_squares += std::pow(log_force_ratio(pressed.tools[0].force, reference), 2);
    }
    errors[k] = {difference / n, std::sqrt(force / reference_size), std::exp(std::sqrt(log_squares / n))};
  }
  return errors;
}

model::OrganModel with_material(model::OrganModel model, const model::Material& material) {
  model.material = material;
  return model;
}

/// The presses, alternately to fit and held out: each pressed with the
/// reference on `organ` and with the fast models on `unit_organ` (unit scales,
/// no attenuation). A press the reference cannot solve is left out with a warning.
void press_probes(const CalibrateOptions& o, const std::vector<const realtime::RegisteredModel*>& models,
                  const organ::Organ& organ, const organ::Organ& unit_organ, std::vector<Probe>& fit,
                  std::vector<Probe>& held_out) {
  const std::vector<Eigen::Vector3d> normals = rest_normals(organ);
  const std::vector<std::uint32_t> sites = press_sites(organ, o.presses, o.seed, o.press);
  const int attenuated = attenuated_index(models);
  for (std::size_t k = 0; k < sites.size(); ++k) {
    // Straight in, or tilted 45° along one of two tangents in turn: the organ
    // is pressed and dragged in use, and a fit to one kind would not transfer.
    Probe p;
    p.tool = site_press(organ, sites[k], normals[sites[k]], static_cast<PressTilt>(k % 3), o.depth_mm, o.press);
    note("calibrate", fmt::format("press {} of {}: {} with {}", k + 1, sites.size(), p.tool.text, o.reference));
    try {
      p.reference = press(o.reference, organ, {p.tool}, o.press);
    } catch (const std::runtime_error& e) {
      warn("calibrate", fmt::format("press {} ({}) left out: {}", k + 1, p.tool.text, e.what()));
      continue;
    }
    std::string forces = fmt::format("|F| {} {:.4f} N", o.reference, p.reference.tools[0].force.norm());
    for (std::size_t m = 0; m < models.size(); ++m) {
      const PressResult pressed = press(models[m]->name, unit_organ, {p.tool}, o.press);
      if (static_cast<int>(m) == attenuated) {
        const std::vector<model::Point3>& rest = organ.model().volume_vertices;
        for (std::size_t n = 0; n < rest.size(); ++n) {
          p.unattenuated.push_back(point(pressed.node_positions[n]) - point(rest[n]));
          p.distance.push_back((point(rest[n]) - pressed.tools[0].action_point).norm());
        }
      }
      p.force.push_back(pressed.tools[0].force);
      forces += fmt::format(", {} {:.4f} N", models[m]->name, pressed.tools[0].force.norm());
    }
    detail("calibrate", forces);
    ((fit.size() + held_out.size()) % 2 == 0 ? fit : held_out).push_back(std::move(p));
  }
  if (fit.size() < 2 || held_out.size() < 2)
    throw std::runtime_error(fmt::format("only {} of {} presses could be solved by {}: press less deep (--depth)",
                                         fit.size() + held_out.size(), sites.size(), o.reference));
}

/// The fitted material, and the names of the values kept because the fitted
/// one would raise the held-out error (computed the same way).
struct FittedMaterial {
  model::Material material;
  std::vector<std::string> kept;
};

FittedMaterial fit_material(const model::Material& before, const std::vector<const realtime::RegisteredModel*>& models,
                            const std::vector<Probe>& fit, const std::vector<Probe>& held_out,
                            const organ::Organ& unit_organ, double diagonal) {
  FittedMaterial result{before, {}};
  model::Material& after = result.material;
  if (attenuated_index(models) >= 0) {
    const double alpha =
        std::abs(std::log(before.attenuation_alpha)) > 1e-12 ? before.attenuation_alpha : std::exp(1.0);
    const double rate_before = before.attenuation_beta * std::log(before.attenuation_alpha);
    after.attenuation_alpha = alpha;
    const double rate = fit_attenuation_rate(fit, unit_organ, diagonal);
    if (mean_attenuated_difference(held_out, unit_organ, rate, diagonal) <=
        mean_attenuated_difference(held_out, unit_organ, rate_before, diagonal))
      after.attenuation_beta = rate / std::log(alpha);
    else
      result.kept.push_back("attenuation");
  }
  for (std::size_t k = 0; k < models.size(); ++k) {
    double model::Material::*scale = models[k]->calibration.stiffness_scale;
    const double fitted = fit_force_scale(fit, k);
    if (force_factor(held_out, k, fitted) <= force_factor(held_out, k, before.*scale))
      after.*scale = fitted;
    else
      result.kept.push_back(std::string(models[k]->name) + " stiffness");
  }
  return result;
}

/// How the calibration was made and what it achieved, in the model's provenance.
void record_calibration(model::OrganModel& calibrated, const CalibrateOptions& o,
                        const std::vector<const realtime::RegisteredModel*>& models, std::size_t fitted,
                        std::size_t held_out, const HeldOutError& before, const HeldOutError& after) {
  auto& parameters = calibrated.provenance.parameters;
  parameters["calibration_reference"] = o.reference;
  parameters["calibration_presses"] = fmt::format("{} fitted, {} held out", fitted, held_out);
  parameters["calibration_depth_mm"] = fmt::format("{:g}", o.depth_mm);
  parameters["calibration_seed"] = std::to_string(o.seed);
  // The models' settings the presses were made with: calibration_<model> = "name value, …".
  for (const realtime::RegisteredModel* entry : realtime::registered_models())
    if (entry->name == o.reference || entry->matches_reference)
      parameters["calibration_" + std::string(entry->name)] = parameter_values(*entry, o.press.tuning.models).dump();
  for (std::size_t k = 0; k < models.size(); ++k)
    parameters["calibration_held_out_" + std::string(models[k]->name)] =
        fmt::format("displacement {:.3g} -> {:.3g} % of the bounding box, force off by x {:.3g} -> {:.3g}",
                    100 * before[k].difference, 100 * after[k].difference, before[k].factor, after[k].factor);
}

struct CalibrationOutcome {
  std::vector<const realtime::RegisteredModel*> models;  ///< the calibrated fast models
  std::size_t fitted = 0, held_out = 0;
  model::Material before, after;
  std::vector<std::string> kept;
  HeldOutError error_before, error_after;
  DepthCurveFit curve;             ///< empty without site compliances
  bool curve_on_supports = false;  ///< the curve is of presses on the supports
  PullCurveFit pulls;              ///< empty without --pull
};

void print_json(const CalibrateOptions& o, const CalibrationOutcome& c) {
  auto material = [](const model::Material& m) {
    return nlohmann::json{{"attenuation_alpha", m.attenuation_alpha},
                          {"attenuation_beta_per_m", m.attenuation_beta},
                          {"beam_stiffness_scale", m.beam_stiffness_scale},
                          {"spring_stiffness_scale", m.spring_stiffness_scale}};
  };
  auto errors = [&](const HeldOutError& e) {
    nlohmann::json models = nlohmann::json::object();
    for (std::size_t k = 0; k < c.models.size(); ++k)
      models[c.models[k]->name] = {
          {"mean_difference", e[k].difference}, {"force_factor", e[k].factor}, {"force_error", e[k].force}};
    return models;
  };
  nlohmann::json j = {{"reference", o.reference},
                      {"model", o.model_path},
                      {"output", o.output_path},
                      {"presses_fitted", c.fitted},
                      {"presses_held_out", c.held_out},
                      {"before", material(c.before)},
                      {"after", material(c.after)},
                      {"kept", c.kept},
                      {"held_out_before", errors(c.error_before)},
                      {"held_out_after", errors(c.error_after)}};
  nlohmann::json curve = nlohmann::json::array();
  for (std::size_t i = 0; i < c.curve.curve.size(); ++i)
    curve.push_back(
        {{"depth_mm", c.curve.curve[i][0] * 1e3}, {"factor", c.curve.curve[i][1]}, {"scatter", c.curve.scatter[i]}});
  j["depth_curve"] = curve;
  j["depth_curve_on_the_supports"] = c.curve_on_supports;
  j["depth_curve_presses"] = {
      {"pressed", c.curve.presses}, {"solved", c.curve.solved}, {"reference_cells_mm", c.curve.refine_size_mm}};
  nlohmann::json pull = nlohmann::json::array();
  for (std::size_t i = 0; i < c.pulls.curve.size(); ++i) {
    pull.push_back({{"drawn_mm", c.pulls.curve[i][0] * 1e3}, {"softening", c.pulls.curve[i][1]}});
    if (i > 0) {
      pull.back()["scatter"] = c.pulls.scatter[i - 1];
      pull.back()["force_factor"] = c.pulls.force_factor[i - 1];
    }
  }
  j["pull_curve"] = pull;
  j["pull_curve_pulls"] = {
      {"pulled", c.pulls.pulls}, {"solved", c.pulls.solved}, {"reference_cells_mm", c.pulls.refine_size_mm}};
  std::cout << j.dump() << '\n';
}

void print_table(const CalibrateOptions& o, const CalibrationOutcome& c) {
  std::cout << fmt::format(
      "{:<14}{} against {}: {} presses of {:g} mm, inward or tilted 45 degrees (seed {}), {} fitted, "
      "{} held out\n",
      "calibrate", o.model_path, o.reference, c.fitted + c.held_out, o.depth_mm, o.seed, c.fitted, c.held_out);
  std::string fitted;
  for (const realtime::RegisteredModel* entry : c.models) {
    fitted += fmt::format("{}{}: ", fitted.empty() ? "" : "; ", entry->name);
    if (entry->calibration.attenuated)
      fitted += fmt::format("attenuation beta {:g} -> {:g} 1/m (alpha {:g}; only beta ln alpha enters), ",
                            c.before.attenuation_beta, c.after.attenuation_beta, c.after.attenuation_alpha);
    fitted += fmt::format("stiffness E x {:g} -> {:g}", c.before.*entry->calibration.stiffness_scale,
                          c.after.*entry->calibration.stiffness_scale);
  }
  std::cout << fmt::format("{:<14}{}\n", "fitted", fitted);
  for (const std::string& k : c.kept)
    std::cout << fmt::format("{:<14}{}: the fitted value would raise the held-out error; the model's value is kept\n",
                             "kept", k);
  if (!c.curve.curve.empty()) {
    std::string points;
    for (std::size_t i = 0; i < c.curve.curve.size(); ++i)
      points += fmt::format("{}{:g} mm x {:.3g} (scatter x {:.3g})", points.empty() ? "" : ", ",
                            c.curve.curve[i][0] * 1e3, c.curve.curve[i][1], c.curve.scatter[i]);
    std::cout << fmt::format(
        "{:<14}the reference's force over the site law's linear one{}: {}; {} of {} presses solved "
        "on {:g} mm cells\n",
        "depth curve", c.curve_on_supports ? " on the supports" : "", points, c.curve.solved, c.curve.presses,
        c.curve.refine_size_mm);
  }
  if (!c.pulls.curve.empty()) {
    std::string points;
    for (std::size_t i = 1; i < c.pulls.curve.size(); ++i)
      points += fmt::format("{}{:.3g} mm x {:.3g} (scatter x {:.3g}; forces then off by x {:.3g})",
                            points.empty() ? "" : ", ", c.pulls.curve[i][0] * 1e3, c.pulls.curve[i][1],
                            c.pulls.scatter[i - 1], c.pulls.force_factor[i - 1]);
    std::cout << fmt::format(
        "{:<14}the held patch's softening against the bonded punch, by the distance drawn since the jaws "
        "closed: {}; {} of {} pulls solved on {:g} mm cells\n",
        "pull curve", points, c.pulls.solved, c.pulls.pulls, c.pulls.refine_size_mm);
  }
  std::cout << fmt::format(
      "\nheld-out presses against {}: mean nodal displacement difference (% of the bounding box "
      "diagonal); force factor exp(sqrt(mean ln^2(|F| / |F_ref|))), the factor the forces are "
      "typically off by (fitted); force error sqrt(sum |F - F_ref|^2 / sum |F_ref|^2)\n\n",
      o.reference);
  std::cout
      << "| model   | displacement before | after  | force factor before | after  | force error before | after  |\n";
  auto row = [](const char* name, double d0, double d1, double k0, double k1, double f0, double f1) {
    std::cout << fmt::format("| {:<7} | {:>18.3f}% | {:>5.3f}% | {:>18.2f}x | {:>5.2f}x | {:>17.1f}% | {:>5.1f}% |\n",
                             name, 100 * d0, 100 * d1, k0, k1, 100 * f0, 100 * f1);
  };
  for (std::size_t k = 0; k < c.models.size(); ++k) {
    const ModelError &b = c.error_before[k], &a = c.error_after[k];
    row(c.models[k]->name, b.difference, a.difference, b.factor, a.factor, b.force, a.force);
  }
  std::cout << fmt::format("\n{:<14}{}\n", "written", o.output_path);
}

int run_calibrate(CalibrateOptions o) {
  if (o.evaluate) {
    EvaluationOptions& e = o.evaluation;
    e.model_path = o.model_path;
    e.reference = o.reference;
    e.seed = o.seed;
    e.json = o.json;
    e.press = o.press;
    e.press.command = "calibrate";
    return run_evaluation(e);
  }
  if (o.output_path.empty())
    throw CLI::ValidationError("--output", "give the calibrated model file to write (or --evaluate)");
  if (o.presses < 4 || o.presses > 256)
    throw CLI::ValidationError("--presses", "must be 4 to 256 (half fit, half held out)");
  o.press.command = "calibrate";
  CalibrationOutcome c;
  c.models = calibrated_models();
  std::vector<std::string> pressed{o.reference};
  for (const realtime::RegisteredModel* entry : c.models) pressed.push_back(entry->name);
  const model::OrganModel original = load_simulation_model("calibrate", o.model_path, pressed);
  c.before = original.material;
  const organ::Organ organ(original);  // its own material: the errors before
  model::Material unit = c.before;     // κ = 0 and unit scales: what the fit scales
  unit.attenuation_beta = 0.0;
  for (const realtime::RegisteredModel* entry : c.models) unit.*entry->calibration.stiffness_scale = 1.0;
  const organ::Organ unit_organ(with_material(original, unit));
  const Eigen::Vector3d extent = bounding_box_extent(organ.model().surface_vertices);

  std::vector<Probe> fit, held_out;
  press_probes(o, c.models, organ, unit_organ, fit, held_out);
  c.fitted = fit.size();
  c.held_out = held_out.size();
  FittedMaterial fitted = fit_material(c.before, c.models, fit, held_out, unit_organ, extent.norm());
  c.after = fitted.material;
  c.kept = std::move(fitted.kept);

  // What the user gets: every held-out press again with both materials.
  model::OrganModel calibrated = with_material(original, c.after);
  if (!original.sites.empty() && o.curve_sites > 0 && o.press.tuning.tip_radius > 0.0) {
    DepthCurveOptions curve;
    static_cast<CurveSiteOptions&>(curve) = curve_sites(o, o.curve_sites);
    curve.depths_mm = o.evaluation.depths_mm;
    c.curve = fit_depth_curve(original, curve);
    // Pressed against its supports the organ has a curve of its own: the
    // other holding's curve stays as it was.
    const bool on_supports = c.curve_on_supports =
        o.press.tuning.models.of<fem::OrganFemOptions>().supports && !original.sites.supported.empty();
    (on_supports ? calibrated.sites.supported_depth_curve : calibrated.sites.depth_curve) = c.curve.curve;
    (on_supports ? calibrated.sites.supported_curve_tip_radius : calibrated.sites.curve_tip_radius) =
        o.press.tuning.tip_radius;
    calibrated.provenance
        .parameters[on_supports ? "calibration_depth_curve_on_the_supports" : "calibration_depth_curve"] = fmt::format(
        "{} on {:g} mm cells, {} sites, {} of {} presses solved, tip {:g} mm", o.reference, c.curve.refine_size_mm,
        o.curve_sites, c.curve.solved, c.curve.presses, o.press.tuning.tip_radius * 1e3);
  }
  if (!original.sites.empty() && o.evaluation.pull_bite_mm > 0.0 && o.pull_sites > 0 &&
      o.press.tuning.tip_radius > 0.0) {
    PullCurveOptions pull;
    static_cast<CurveSiteOptions&>(pull) = curve_sites(o, o.pull_sites);
    pull.distances_mm = o.pull_depths_mm;
    pull.bite_mm = o.evaluation.pull_bite_mm;
    // On the model as written so far: the law's force where the jaws close
    // is the depth curve's.
    c.pulls = fit_pull_curve(calibrated, pull);
    calibrated.sites.pull_curve = c.pulls.curve;
    calibrated.sites.pull_tip_radius = o.press.tuning.tip_radius;
    calibrated.provenance.parameters["calibration_pull_curve"] =
        fmt::format("{} on {:g} mm cells, {} sites, bite {:g} mm, {} of {} pulls solved, tip {:g} mm", o.reference,
                    c.pulls.refine_size_mm, o.pull_sites, pull.bite_mm, c.pulls.solved, c.pulls.pulls,
                    o.press.tuning.tip_radius * 1e3);
  }
  note("calibrate", "measuring the held-out presses before and after");
  c.error_before = measure_held_out(organ, c.models, held_out, o.press, extent);
  const organ::Organ calibrated_organ(calibrated);
  c.error_after = measure_held_out(calibrated_organ, c.models, held_out, o.press, extent);
  record_calibration(calibrated, o, c.models, c.fitted, c.held_out, c.error_before, c.error_after);
  model::write_organ_model_file(calibrated, o.output_path);

  if (o.json)
    print_json(o, c);
  else
    print_table(o, c);
  return 0;
}

}  // namespace

Command add_calibrate_command(CLI::App& app) {
  auto o = std::make_shared<CalibrateOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  app.add_option("-o,--output", o->output_path, "The calibrated model file to write (not with --evaluate)");
  app.add_option("--reference", o->reference, "The FEM model the fast models are fitted to")
      ->check(CLI::IsMember(reference_model_names()))
      ->capture_default_str();
  app.add_option("--presses", o->presses, "Presses spread over the surface: half to fit, half held out (4-256)")
      ->capture_default_str();
  app.add_option("--depth", o->depth_mm,
                 "How far each press goes (inward along the normal, or tilted 45 degrees along a tangent), mm")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--seed", o->seed, "Where the press sites start (the same seed, the same sites)")
      ->capture_default_str();
  add_model_tuning_options(app, o->press.tuning);
  app.add_option("--settle", o->press.settle_seconds,
                 "Mass-spring model: seconds each press is held before the force is read")
      ->check(kPositive)
      ->capture_default_str();
  app.add_flag("--evaluate", o->evaluate,
               "Fit nothing: measure the model's multi-beam and mass-spring forces against the reference on presses "
               "spread over the organ (--sites, --depths), the reference re-meshed finely around each press")
      ->excludes("--output");
  app.add_option("--sites", o->evaluation.sites,
                 "--evaluate: sites spread over the surface, each pressed straight in and "
                 "tilted 45 degrees (1-256)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  app.add_option("--jobs", o->evaluation.jobs,
                 "--evaluate and the depth curve: processes the sites are shared among (0: one per CPU; the results "
                 "are the same whatever the number; each holds a re-meshed reference, about 0.7 GB on a liver)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--reference-cache", o->evaluation.reference_cache,
                 "--evaluate: keep each site's reference presses in this directory as they finish, and take them "
                 "from there in a later run of the same reference on the same organ (a stopped evaluation resumes; a "
                 "changed fast model is measured again without the reference's hours)")
      ->needs("--evaluate");
  app.add_option("--curve-sites", o->curve_sites,
                 "A model with site compliances: sites spread over the surface whose presses (straight and tilted, at "
                 "each of --depths) fit the site law's depth curve (0: none; docs/matching.md)")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  app.add_option("--depths", o->evaluation.depths_mm,
                 "--evaluate and the depth curve: press depths, mm, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--reference-cells", o->evaluation.refine_size_mm,
                 "--evaluate and the depth curve: the reference's cells under each press, mm (default: half the tip's "
                 "radius, where its "
                 "force no longer depends on the mesh; 0: the model's own tetrahedra)")
      ->check(kNonNegative);
  app.add_option("--check-cells", o->evaluation.check_size_mm,
                 "--evaluate: also press straight in on cells of this size, mm, and print how much the reference "
                 "changed (its convergence)")
      ->check(kNonNegative);
  app.add_option("--pull", o->evaluation.pull_bite_mm,
                 "Grasps: each site grasped after a bite this deep, mm, and drawn out straight along the normal and "
                 "tilted 45 degrees. --evaluate: pulls instead of presses, drawn out by each of --depths; otherwise "
                 "also fit the grasp's pull curve at --pull-sites sites drawn out by each of --pull-depths "
                 "(docs/matching.md#pulls)")
      ->check(kPositive);
  app.add_option("--pull-sites", o->pull_sites,
                 "--pull: sites spread over the surface (other than --evaluate's) whose pulls fit the pull curve")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  app.add_option("--pull-depths", o->pull_depths_mm,
                 "--pull: how far the pull curve's grasps are drawn out, mm, comma-separated")
      ->delimiter(',')
      ->check(kPositive)
      ->capture_default_str();
  app.add_flag("--json", o->json,
               "Print the fitted values and the held-out errors (or the evaluation) as one JSON object");
  return [o] { return run_calibrate(*o); };
}

}  // namespace organsim::cli
