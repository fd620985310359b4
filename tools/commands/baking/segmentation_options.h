// The seeded-segmentation options that `organsim segment` and `organsim bake`
// share, and the report both print.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "organsim/pipeline/seeded_segmentation.h"

namespace organsim::cli {

struct SegmentationCommandOptions {
  std::vector<std::string> seeds, seed_voxels;                        ///< "X,Y,Z" (mm) / "I,J,K"
  std::vector<std::string> background_seeds, background_seed_voxels;  ///< the same, for background seeds
  std::vector<double> hu_window;                                      ///< LOW,HIGH or empty
  std::vector<double> window_sigmas;                                  ///< BELOW,ABOVE or empty
  pipeline::SeededSegmentationOptions method;                         ///< the numeric parameters
  std::string reference_path;                                         ///< a label map to compute the Dice against
  std::string explain_path;  ///< --explain: where to write the label map of what was kept and cut
  int reference_value = 1;
};

/// Registers --seed, --seed-voxel, --background-seed, --background-seed-voxel
/// (each repeatable), --hu-window, the method's parameters, --reference and
/// --explain.
void add_seeded_segmentation_options(CLI::App& app, SegmentationCommandOptions& options);

/// The options with the seeds parsed (the validators have checked their form).
pipeline::SeededSegmentationOptions seeded_segmentation_options(const SegmentationCommandOptions& options);

/// The report as lines of text ("segmentation    ...") and as JSON.
void print_seeded_segmentation_report(const pipeline::SeededSegmentationReport& report);
nlohmann::ordered_json seeded_segmentation_report_json(const pipeline::SeededSegmentationReport& report);

}  // namespace organsim::cli
