// The command-line options that shape a deformation model beyond its name
// (replay, poke, touch, view).
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "organsim/fem/organ_fem.h"
#include "organsim/realtime/deformation_model.h"
#include "organsim/realtime/engine.h"

namespace organsim::cli {

/// What shapes the deformation models beyond their name.
struct ModelTuning {
  double fixed_radius_mm = 10.0;  ///< --fixed-radius: the clamp ball of the FEM models and of the volume springs
  bool volume_springs =
      false;  ///< --volume-springs: springs on the tetrahedra's edges too, clamped instead of body springs
  std::string region = "all";        ///< --region all|dynamic|fixed: the springs' integrated region
  std::uint32_t region_rings = 3;    ///< --region-rings: a fixed region's size in springs
  double region_threshold_mm = 1.0;  ///< --region-threshold: displacement that grows a dynamic region
  std::string linear_solver = default_linear_solver();   ///< --linear-solver: the FEM tangents' factorization
  double tip_radius_mm = 2.5;                            ///< --tip-radius: the tools' hemispherical end (0: a point)
  double friction = realtime::EngineOptions{}.friction;  ///< --friction: Coulomb's μ between tool and organ
  double grasp_limit = realtime::EngineOptions{}.grasp_limit;  ///< --grasp-limit: N a grasp holds before it slips
  bool unmatched = false;  ///< --unmatched: the fast models' own forces, not the site law's
  static const char* default_linear_solver();
};
/// --linear-solver simplicial|direct: Eigen's simplicial LDLT, or (when
/// organsim was built with SuiteSparse and MUMPS) CHOLMOD and MUMPS.
void add_linear_solver_option(CLI::App& app, std::string& linear_solver);
/// The factory for --linear-solver's value (null: the simplicial one).
fem::FactorizationFactory factorization_factory(const std::string& linear_solver);
/// --tip-radius MM (the tools' end, docs/realtime.md#contact-rule), --friction, --fixed-radius
/// MM (the FEM models clamp the tetrahedral nodes within this distance of the
/// model's fixed point), --volume-springs, --region, --region-rings and --region-threshold MM
/// (the mass-spring model; docs/springs.md), --unmatched (docs/matching.md) and
/// --linear-solver.
void add_model_tuning_options(CLI::App& app, ModelTuning& tuning);
/// Applies the tuning to the FEM and mass-spring options (of an engine or of
/// realtime::ModelOptions).
void apply_model_tuning(const ModelTuning& tuning, fem::OrganFemOptions& fem, realtime::SpringModelOptions& springs);
/// --grasp-limit N, for the commands that run the real-time engine (replay,
/// view, touch, serve): the pull a grasp holds (docs/realtime.md#grasping).
void add_grasp_option(CLI::App& app, ModelTuning& tuning);

/// The same for an engine, and its tools' tip radius and friction.
void apply_model_tuning(const ModelTuning& tuning, realtime::EngineOptions& engine);

}  // namespace organsim::cli
