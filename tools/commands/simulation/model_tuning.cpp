#include "model_tuning.h"

#include "command_line.h"

#ifdef ORGANSIM_HAVE_FEM_DIRECT
#include "organsim/fem/direct_factorizations.h"
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

void add_model_tuning_options(CLI::App& app, ModelTuning& tuning) {
  app.add_option("--tip-radius", tuning.tip_radius_mm,
                 "The tools' end: a hemisphere of this radius on the shaft, mm (a 5 mm laparoscopic probe: 2.5; 0: a "
                 "point tool; docs/realtime.md#contact-rule)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--friction", tuning.friction,
                 "Coulomb's friction coefficient between the tools and the organ: beyond it the organ slips under a "
                 "tool, in the real-time engine and in static presses alike (wet serosa on steel: 0.1-0.3; inf: it "
                 "never slips, as in a grasp; docs/realtime.md#contact-rule)")
      ->check(kNonNegativeOrInfinity)
      ->capture_default_str();
  app.add_option(
         "--fixed-radius", tuning.fixed_radius_mm,
         "FEM models (and springs with --volume-springs): clamp the tetrahedral nodes within this distance of the "
         "fixed point, mm (docs/fem.md)")
      ->check(kPositive)
      ->capture_default_str();
  app.add_flag("--volume-springs", tuning.volume_springs,
               "springs: also a spring on every tetrahedron edge, the surface tied to the tetrahedra, held at the "
               "clamp like the FEM models (--fixed-radius) instead of by body springs (docs/springs.md)");
  app.add_option(
         "--region", tuning.region,
         "springs: integrate all nodes, only a dynamic region around the tools, or a fixed one (--region-rings)")
      ->check(CLI::IsMember({"all", "dynamic", "fixed"}))
      ->capture_default_str();
  app.add_option("--region-rings", tuning.region_rings, "springs, fixed region: its size in springs from each tool")
      ->check(CLI::Range(1u, 1000000u))
      ->capture_default_str();
  app.add_option("--region-threshold", tuning.region_threshold_mm,
                 "springs, dynamic region: a node displaced beyond this activates its neighbours, mm")
      ->check(kPositive)
      ->capture_default_str();
  app.add_flag("--unmatched", tuning.unmatched,
               "beam, springs: the model's own contact force, not the FEM reference's site law that a model with "
               "site compliances gives a tool of finite size (docs/matching.md)");
  add_linear_solver_option(app, tuning.linear_solver);
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

void apply_model_tuning(const ModelTuning& tuning, fem::OrganFemOptions& fem, realtime::SpringModelOptions& springs) {
  fem.fixed_radius = tuning.fixed_radius_mm * 1e-3;
  fem.factorization = factorization_factory(tuning.linear_solver);
  springs.network.volume_springs = tuning.volume_springs;
  if (tuning.volume_springs) {
    // The body springs stand in for the interior a surface network lacks, and
    // pin each vertex in space; with the interior's springs there, the organ is
    // held where the FEM models hold it, so that it moves about the clamp as
    // theirs does (docs/springs.md#organ-networks-make_organ_network).
    springs.network.body_factor = 0.0;
    springs.network.clamp_radius = tuning.fixed_radius_mm * 1e-3;
  }
  springs.simulation.region = springs::parse_region(tuning.region);
  springs.simulation.region_rings = tuning.region_rings;
  springs.simulation.threshold = tuning.region_threshold_mm * 1e-3;
  springs.match_sites = !tuning.unmatched;
}

void apply_model_tuning(const ModelTuning& tuning, realtime::EngineOptions& engine) {
  apply_model_tuning(tuning, engine.fem, engine.springs);
  engine.tip_radius = tuning.tip_radius_mm * 1e-3;
  engine.friction = tuning.friction;
  engine.grasp_limit = tuning.grasp_limit;
  engine.beams.match_sites = !tuning.unmatched;
}

}  // namespace organsim::cli
