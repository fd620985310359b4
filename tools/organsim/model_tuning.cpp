#include "model_tuning.h"

#include "command_line.h"

namespace organsim::cli {

void add_model_tuning_options(CLI::App& app, ModelTuning& tuning) {
  app.add_option("--fixed-radius", tuning.fixed_radius_mm,
                 "FEM models: clamp the tetrahedral nodes within this distance of the fixed point, mm (docs/fem.md)")
      ->check(kPositive)
      ->capture_default_str();
  app.add_flag("--volume-springs", tuning.volume_springs,
               "springs: also a spring on every tetrahedron edge, the surface tied to the tetrahedra (docs/springs.md)");
  app.add_option("--region", tuning.region, "springs: integrate all nodes, or only a dynamic region around the tools")
      ->check(CLI::IsMember({"all", "dynamic"}))
      ->capture_default_str();
  app.add_option("--region-threshold", tuning.region_threshold_mm,
                 "springs, dynamic region: a node displaced beyond this activates its neighbours, mm")
      ->check(kPositive)
      ->capture_default_str();
}

void apply_model_tuning(const ModelTuning& tuning, fem::OrganFemOptions& fem, realtime::SpringModelOptions& springs) {
  fem.fixed_radius = tuning.fixed_radius_mm * 1e-3;
  springs.network.volume_springs = tuning.volume_springs;
  springs.simulation.region = tuning.region == "dynamic" ? springs::Region::dynamic : springs::Region::all;
  springs.simulation.threshold = tuning.region_threshold_mm * 1e-3;
}

}  // namespace organsim::cli
