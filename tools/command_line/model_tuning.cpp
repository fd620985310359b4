#include "command_line/model_tuning.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "command_line/command_line.h"
#include "organsim/realtime/session_playback.h"

#ifdef ORGANSIM_HAVE_FEM_DIRECT
#include "organsim/fem_direct/direct_factorizations.h"
#endif

namespace organsim::cli {

const char* ModelTuning::default_linear_solver() {
#ifdef ORGANSIM_HAVE_FEM_DIRECT
  return "direct";
#else
  return "simplicial";
#endif
}

void add_linear_solver_option(CLI::App& app, std::string& linear_solver) {
#ifdef ORGANSIM_HAVE_FEM_DIRECT
  const std::vector<std::string> choices = {"simplicial", "direct"};
#else
  const std::vector<std::string> choices = {"simplicial"};
#endif
  app.add_option("--linear-solver", linear_solver,
                 "FEM models: factorize tangents with Eigen's simplicial LDLT, or with CHOLMOD (positive definite) "
                 "and MUMPS (PSH) (docs/fem.md#linear-solver)")
      ->check(CLI::IsMember(choices))
      ->capture_default_str();
}

fem::FactorizationFactory factorization_factory(const std::string& linear_solver) {
#ifdef ORGANSIM_HAVE_FEM_DIRECT
  if (linear_solver == "direct") return &fem::direct_factorization;
#else
  (void)linear_solver;
#endif
  return nullptr;
}

namespace {

using realtime::ModelParameter;

/// Every model's parameter called `name`, in the order the models are registered.
std::vector<std::pair<const realtime::RegisteredModel*, const ModelParameter*>> parameters_called(
    const std::string& name) {
  std::vector<std::pair<const realtime::RegisteredModel*, const ModelParameter*>> found;
  for (const realtime::RegisteredModel* entry : realtime::registered_models())
    for (std::size_t k = 0; k < entry->parameter_count; ++k)
      if (name == entry->parameters[k].name) found.emplace_back(entry, &entry->parameters[k]);
  return found;
}

/// The value as the command line writes it (lengths in mm).
std::string command_line_text(const ModelParameter& parameter, const realtime::ParameterValue& value) {
  switch (parameter.kind) {
    case ModelParameter::Kind::length: return fmt::format("{:g}", value.number * 1e3);
    case ModelParameter::Kind::choice: return std::string(value.text);
    case ModelParameter::Kind::flag: return value.number != 0.0 ? "true" : "false";
    case ModelParameter::Kind::number:
    case ModelParameter::Kind::count: break;
  }
  return fmt::format("{:g}", value.number);
}

std::vector<std::string> choices_of(const ModelParameter& parameter) {
  std::vector<std::string> choices;
  const std::string all = parameter.choices ? parameter.choices : "";
  for (std::size_t start = 0; start <= all.size();) {
    const std::size_t bar = std::min(all.find('|', start), all.size());
    choices.push_back(all.substr(start, bar - start));
    start = bar + 1;
  }
  return choices;
}

}  // namespace

void set_parameter(realtime::ModelOptions& options, const std::string& name, const realtime::ParameterValue& value,
                   const std::string& text) {
  for (const auto& [entry, parameter] : parameters_called(name))
    if (const std::string why = parameter->set(options, value); !why.empty())
      throw CLI::ValidationError("--" + name, "'" + (text.empty() ? std::string(value.text) : text) + "': " + why);
}

realtime::ModelOptions ModelTuning::with_default_linear_solver() {
  realtime::ModelOptions options;
  options.edit<fem::OrganFemOptions>().factorization = factorization_factory(default_linear_solver());
  return options;
}

void add_model_tuning_options(CLI::App& app, ModelTuning& tuning) {
  app.add_option_function<double>(
         "--tip-radius", [&tuning](double mm) { tuning.tip_radius = mm * 1e-3; },
         "The tools' end: a hemisphere of this radius on the shaft, mm (a 5 mm laparoscopic probe: 2.5; 0: a "
         "point tool; docs/realtime.md#contact-rule)")
      ->check(kNonNegative)
      ->default_str(fmt::format("{:g}", ModelTuning{}.tip_radius * 1e3));
  app.add_option("--friction", tuning.friction,
                 "Coulomb's friction coefficient between the tools and the organ: beyond it the organ slips under a "
                 "tool, in the real-time engine and in static presses alike (wet serosa on steel: 0.1-0.3; inf: it "
                 "never slips, as in a grasp; docs/realtime.md#contact-rule)")
      ->check(kNonNegativeOrInfinity)
      ->capture_default_str();
  std::vector<std::string> added;
  for (const realtime::RegisteredModel* entry : realtime::registered_models())
    for (std::size_t k = 0; k < entry->parameter_count; ++k) {
      const ModelParameter& parameter = entry->parameters[k];
      const std::string name = parameter.name;
      if (std::find(added.begin(), added.end(), name) != added.end()) continue;
      added.push_back(name);
      realtime::ModelOptions& models = tuning.models;
      if (parameter.kind == ModelParameter::Kind::flag) {
        app.add_flag_callback(
            "--" + name,
            [&models, name] {
              set_parameter(models, name, {1.0, {}}, "true");
            },
            parameter.help);
        continue;
      }
      const bool length = parameter.kind == ModelParameter::Kind::length;
      const std::string help = length ? std::string(parameter.help) + ", mm" : parameter.help;
      CLI::Option* option = app.add_option_function<std::string>(
          "--" + name,
          [&models, name, &parameter](const std::string& text) {
            realtime::ParameterValue value{0.0, text};
            if (parameter.kind != ModelParameter::Kind::choice) {
              char* end = nullptr;
              value.number = std::strtod(text.c_str(), &end);
              if (text.empty() || end != text.c_str() + text.size())
                throw CLI::ValidationError("--" + name, "'" + text + "' is not a number");
              if (parameter.kind == ModelParameter::Kind::length) value.number *= 1e-3;  // mm on the command line
            }
            set_parameter(models, name, value, text);
          },
          help);
      option->default_str(command_line_text(parameter, parameter.get(realtime::ModelOptions{})));
      if (parameter.kind == ModelParameter::Kind::choice) option->check(CLI::IsMember(choices_of(parameter)));
    }
  add_linear_solver_option(app, tuning.linear_solver);
  app.get_option("--linear-solver")->each([&tuning](const std::string& solver) {
    tuning.models.edit<fem::OrganFemOptions>().factorization = factorization_factory(solver);
  });
}

std::string choice_text(const realtime::RegisteredModel& entry, const realtime::ModelOptions& options,
                        const std::string& lead) {
  std::string text;
  for (std::size_t k = 0; k < entry.parameter_count; ++k)
    if (entry.parameters[k].kind == ModelParameter::Kind::choice)
      text += lead + entry.parameters[k].name + " " + std::string(entry.parameters[k].get(options).text);
  return text;
}

nlohmann::json parameter_values(const realtime::RegisteredModel& entry, const realtime::ModelOptions& options) {
  nlohmann::json values = nlohmann::json::object();
  for (std::size_t k = 0; k < entry.parameter_count; ++k) {
    const ModelParameter& parameter = entry.parameters[k];
    const realtime::ParameterValue value = parameter.get(options);
    nlohmann::json& slot = values[parameter.name];
    switch (parameter.kind) {
      case ModelParameter::Kind::length: slot = value.number * 1e3; break;
      case ModelParameter::Kind::choice: slot = std::string(value.text); break;
      case ModelParameter::Kind::flag: slot = value.number != 0.0; break;
      case ModelParameter::Kind::number:
      case ModelParameter::Kind::count: slot = value.number; break;
    }
  }
  return values;
}

void add_grasp_option(CLI::App& app, ModelTuning& tuning) {
  app.add_option(
         "--grasp-limit", tuning.grasp_limit,
         "The largest pull a grasper's closed jaws hold, N: pulled harder, the tissue slips out of them and the "
         "slip is counted (an engineering choice, separate from the device's force clamp; inf: never slips; "
         "docs/realtime.md#grasping)")
      ->check(kNonNegativeOrInfinity)
      ->capture_default_str();
}

void apply_model_tuning(const ModelTuning& tuning, realtime::EngineOptions& engine) {
  engine.models = tuning.models;
  engine.tip_radius = tuning.tip_radius;
  engine.friction = tuning.friction;
  engine.grasp_limit = tuning.grasp_limit;
}

void warn_if_depth_curve_rescaled(const std::string& command, const model::OrganModel& model,
                                  const std::vector<std::string>& models, const ModelTuning& tuning,
                                  const devices::Session* session) {
  const model::SiteCompliance& sites = model.sites;
  const bool matched = std::any_of(models.begin(), models.end(), [&](const std::string& m) {
    const realtime::RegisteredModel* entry = realtime::find_model(m);
    return entry && entry->matches_reference && entry->matches_reference(tuning.models);
  });
  // The curve this run's presses read: on the supports their own, where the model has it.
  const bool on_supports = tuning.models.of<fem::OrganFemOptions>().supports && !sites.supported_depth_curve.empty();
  const double fitted_radius = on_supports ? sites.supported_curve_tip_radius : sites.curve_tip_radius;
  if ((on_supports ? sites.supported_depth_curve : sites.depth_curve).empty() || !matched) return;
  realtime::EngineOptions options;
  options.tip_radius = tuning.tip_radius;
  if (session) options = realtime::with_session_tips(options, *session);
  std::vector<double> radii;  // m, each tool's as the engine will take it
  for (std::size_t k = 0; k < (session ? session->tools.size() : 1); ++k) radii.push_back(options.tip_radius_of(k));
  std::vector<double> warned;
  for (const double radius : radii) {
    if (!(radius > 0.0) || std::abs(radius - fitted_radius) <= 1e-9 ||
        std::find(warned.begin(), warned.end(), radius) != warned.end())
      continue;
    warned.push_back(radius);
    warn(command, fmt::format("the model's depth curve was fitted for a {:g} mm tip, and a tool's is {:g} mm: the "
                              "curve is read at the same depth relative to the radius, which follows the tip's own "
                              "contact but not the organ's bending (that depends on the depth alone); for a curve of "
                              "this tip run organsim calibrate with --tip-radius {:g} "
                              "(docs/matching.md#the-depth-curve-organsim-calibrate)",
                              fitted_radius * 1e3, radius * 1e3, radius * 1e3));
  }
}

}  // namespace organsim::cli
