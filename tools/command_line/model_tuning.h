// The command-line options that shape a deformation model beyond its name
// (replay, poke, touch, view).
#pragma once

#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "organsim/devices/session_file.h"
#include "organsim/organ_fem/organ_fem.h"
#include "organsim/realtime/deformation_model.h"
#include "organsim/realtime/engine.h"
#include "organsim/realtime/model_options.h"
#include "organsim/realtime/model_registry.h"

namespace organsim::cli {

/// What shapes the deformation models beyond their name.
struct ModelTuning {
  /// Each model's options, as its registered parameters set them (--merge,
  /// --fixed-radius, --region, …: realtime/model_options.h); --linear-solver
  /// sets the FEM models' factorization.
  realtime::ModelOptions models = with_default_linear_solver();
  std::string linear_solver = default_linear_solver();  ///< --linear-solver: the FEM tangents' factorization
  double tip_radius = 2.5e-3;  ///< m, --tip-radius (given in mm): the tools' hemispherical end (0: a point)
  double friction = realtime::EngineOptions{}.friction;        ///< --friction: Coulomb's μ between tool and organ
  double grasp_limit = realtime::EngineOptions{}.grasp_limit;  ///< --grasp-limit: N a grasp holds before it slips
  static const char* default_linear_solver();
  static realtime::ModelOptions with_default_linear_solver();
};
/// --linear-solver simplicial|direct: Eigen's simplicial LDLT, or (when
/// organsim was built with SuiteSparse and MUMPS) CHOLMOD and MUMPS.
void add_linear_solver_option(CLI::App& app, std::string& linear_solver);
/// The factory for --linear-solver's value (null: the simplicial one).
fem::FactorizationFactory factorization_factory(const std::string& linear_solver);
/// --tip-radius MM (the tools' end, docs/realtime.md#contact-rule), --friction,
/// every registered model's parameters (--NAME; lengths in mm; one option
/// sets each model that takes the name) and --linear-solver.
void add_model_tuning_options(CLI::App& app, ModelTuning& tuning);
/// Sets the parameter `name` of every model that takes it (a length in m);
/// throws CLI::ValidationError naming --NAME and `text` (the value as given)
/// when a model refuses the value.
void set_parameter(realtime::ModelOptions& options, const std::string& name, const realtime::ParameterValue& value,
                   const std::string& text = "");
/// `entry`'s choices in `options`, each as `lead` + "NAME VALUE" (", merge
/// influence, theory euler-bernoulli, …"): what a title says of a model's set-up.
std::string choice_text(const realtime::RegisteredModel& entry, const realtime::ModelOptions& options,
                        const std::string& lead);
/// The values of `entry`'s parameters in `options`, by name, as the command
/// line writes them (lengths in mm, flags true or false): what a command's
/// JSON reports of a model's set-up.
nlohmann::json parameter_values(const realtime::RegisteredModel& entry, const realtime::ModelOptions& options);
/// --grasp-limit N, for the commands that run the real-time engine (replay,
/// view, touch, serve): the pull a grasp holds (docs/realtime.md#grasping).
void add_grasp_option(CLI::App& app, ModelTuning& tuning);

/// The tuning of an engine: its models' options, its tools' tip radius,
/// friction and grasp limit.
void apply_model_tuning(const ModelTuning& tuning, realtime::EngineOptions& engine);

/// Warns once per radius when the model's depth curve (organsim calibrate) was
/// fitted for a tip of another radius than a tool's: the curve is then read at
/// the same depth relative to the tip's radius
/// (docs/matching.md#the-depth-curve-organsim-calibrate). Only the fast models
/// matched to the reference read it (`models` holds one that `tuning` keeps
/// matched: RegisteredModel::matches_reference), and a point tool has no site law. The tools' radii: each
/// `session` tool's own tip line, else --tip-radius.
void warn_if_depth_curve_rescaled(const std::string& command, const model::OrganModel& model,
                                  const std::vector<std::string>& models, const ModelTuning& tuning,
                                  const devices::Session* session = nullptr);

}  // namespace organsim::cli
