// `organsim segment CT -o MASK --seed X,Y,Z [--seed …] [--background-seed X,Y,Z …] [method options]
//  [--reference LABEL] [--json]`: only the segmentation stage, so a user can
// iterate on seeds quickly and check the mask in 3D Slicer before baking.
#include <nlohmann/json.hpp>

#include <memory>

#include <fmt/format.h>

#include "command_line/command_line.h"
#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/segmentation.h"
#include "segmentation_options.h"

namespace organsim::cli {
namespace {

struct SegmentCommandOptions {
  std::string ct_path, series_uid, output_path;
  SegmentationCommandOptions segmentation;
  bool json = false;
};

int run_segment(const SegmentCommandOptions& o) {
  const pipeline::SeededSegmentationOptions options = seeded_segmentation_options(o.segmentation);
  if (options.seeds.empty())
    throw CLI::ValidationError("--seed",
                               "give at least one point inside the organ: --seed X,Y,Z or --seed-voxel I,J,K");
  // The bake's measured 7.2–7.5 bytes per voxel bound what segmenting alone holds.
  const pipeline::CtImage::Pointer ct =
      pipeline::read_ct(o.ct_path, o.series_uid, {8.0, 256.0 * 1024 * 1024, "segmenting it"});
  const pipeline::SeededSegmentation segmented = pipeline::segment_from_seeds(*ct, options);
  std::optional<double> dice;
  if (!o.segmentation.reference_path.empty())
    dice = pipeline::dice_coefficient(*segmented.mask, *pipeline::read_label_mask(o.segmentation.reference_path,
                                                                                  o.segmentation.reference_value, *ct));
  pipeline::write_mask_image(*segmented.mask, o.output_path);
  if (segmented.explanation) pipeline::write_mask_image(*segmented.explanation, o.segmentation.explain_path);

  const pipeline::SeededSegmentationReport& r = segmented.report;
  for (const std::string& warning : r.warnings) warn("segment", warning);
  if (o.json) {
    nlohmann::ordered_json j;
    j["mask"] = o.output_path;
    if (segmented.explanation) j["explanation"] = o.segmentation.explain_path;
    j["segmentation"] = seeded_segmentation_report_json(r);
    if (dice) j["dice"] = *dice;
    fmt::print("{}\n", j.dump());
    return 0;
  }
  fmt::print("mask            {} ({} voxels, {:.1f} mL)\n", o.output_path, r.voxels, r.volume_ml);
  print_seeded_segmentation_report(r);
  if (dice) fmt::print("Dice            {:.4f} against {}\n", *dice, o.segmentation.reference_path);
  return 0;
}

}  // namespace

Command add_segment_command(CLI::App& app) {
  auto o = std::make_shared<SegmentCommandOptions>();
  app.add_option("ct", o->ct_path, "CT: a DICOM series directory, or a NIfTI, NRRD or MHA/MHD file")->required();
  app.add_option("-o,--output", o->output_path, "Mask to write (.nii.gz, .nii, .nrrd or .mha), on the CT's grid")
      ->required();
  app.add_option("--series", o->series_uid, "Series instance UID, when the DICOM directory holds several series");
  add_seeded_segmentation_options(app, o->segmentation);
  app.add_option("--closing", o->segmentation.method.closing_radius_mm,
                 "Closing radius after leak control, mm (0: none)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_flag("--json", o->json, "Print the report as one JSON object on stdout");
  return [o] { return run_segment(*o); };
}

}  // namespace organsim::cli
