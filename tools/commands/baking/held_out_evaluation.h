// `organsim calibrate MODEL --evaluate`: the fast models (multi-beam,
// mass-spring) as the model file makes them, measured against a FEM reference
// on presses no fit saw: sites spread over the organ (seeded), each pressed
// straight in and tilted 45°, at several depths (or grasped and pulled out:
// pull_bite_mm). The reference is pressed on
// the organ re-meshed with cells of half the tip's radius around each site,
// where its force no longer depends on the mesh (docs/fem.md#a-tool-of-finite-size).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "organsim/realtime/model_registry.h"
#include "static_press/static_press.h"

namespace organsim::cli {

struct EvaluationOptions {
  std::string model_path;
  std::string reference = realtime::reference_model().name;
  int sites = 24;
  std::vector<double> depths_mm{2.0, 5.0, 10.0};
  std::uint32_t seed = 1;
  /// Cells under each press for the reference, mm: < 0 half the tip's
  /// radius; 0 the model's own tetrahedra.
  double refine_size_mm = -1.0;
  /// > 0: the straight presses' reference again on cells of this size, to
  /// show how much it still changes under refinement.
  double check_size_mm = 0.0;
  /// > 0: pulls instead of presses: each site grasped after a bite this deep
  /// (mm; docs/realtime.md#grasping) and drawn out by each depth, straight
  /// along the outward normal and tilted 45° from it.
  double pull_bite_mm = 0.0;
  bool json = false;
  /// Processes the sites are shared among (each presses every jobs-th site;
  /// the table is the same whatever the number); 0: one per CPU, at most one
  /// per site.
  int jobs = 0;
  /// A directory that keeps the reference's presses of every site as it
  /// finishes, for later runs to take (reference_cache.h); empty: none.
  std::string reference_cache;
  PressOptions press;
};

/// Prints the held-out table (or one JSON object); returns the exit code.
/// Throws std::runtime_error for an unusable model or no press solved.
int run_evaluation(const EvaluationOptions& o);

}  // namespace organsim::cli
