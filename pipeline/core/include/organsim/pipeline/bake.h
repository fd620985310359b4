// The whole pipeline in one call: CT → mask → fixed point → surface →
// tetrahedra → beam tables → an OrganModel, with a report of what was made and
// how long each stage took. `organsim bake` is a thin shell around bake().
//
// Errors are std::runtime_error with one line saying what is wrong and what to
// do. Nothing here names the input file or any DICOM tag in the model, the
// report or the progress messages: only the SHA-256 of the voxels identifies
// the input.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "organsim/model/organ_model.h"
#include "organsim/pipeline/beam_baking.h"
#include "organsim/pipeline/ct_image.h"
#include "organsim/pipeline/seeded_segmentation.h"
#include "organsim/pipeline/site_compliance.h"
#include "organsim/pipeline/supports.h"
#include "organsim/pipeline/surface.h"
#include "organsim/tetrahedra/tetrahedra.h"

namespace organsim::pipeline {

struct BakeOptions {
  std::string ct_path;     ///< DICOM series directory, NIfTI, NRRD or MHA/MHD
  std::string series_uid;  ///< chooses one series in a directory that holds several

  // Segmentation: a label map, or seeds (organsim/pipeline/seeded_segmentation.h).
  std::string label_path;
  int label_value = 1;
  double label_closing_radius_mm = 0.0;  ///< closing applied to a label map, mm
  SeededSegmentationOptions seeded;      ///< used when there is no label map
  std::size_t minimum_voxels = 1000;     ///< smaller masks are an error
  std::string reference_label_path;      ///< when set: the report gives the Dice against this label map
  int reference_label_value = 1;

  // The beams' clamp; default: the deepest interior point of the mask.
  std::optional<std::array<double, 3>> fixed_point_mm;
  std::optional<std::array<long, 3>> fixed_point_voxel;

  SurfaceOptions surface;
  TetrahedraOptions tetrahedra;
  /// The FEM models hold the organ by the nodes within their clamp radius
  /// of the fixed point (10 mm, SiteComplianceOptions::fixed_radius): the
  /// tetrahedra are refined to cells of this size there (mm; 0: not), so that
  /// the clamp is a ball the mesh resolves rather than the handful of nodes
  /// 8 mm cells put in it, which moved the FEM reference's force by up to
  /// 20 % from one meshing to the next (docs/fem.md#the-clamp).
  double clamp_cells_mm = 2.5;
  BeamBakingOptions beams;
  /// False (--no-beam-tables): the model carries no beam tables, which are
  /// the multi-beam model's alone (and the slowest stage but segmentation);
  /// every other deformation model runs on it, `--model beam` refuses it.
  bool beam_tables = true;
  /// False (--no-site-compliance): the model carries no site compliances, and
  /// the fast models give their own forces, not the FEM reference's
  /// (docs/matching.md).
  bool site_compliance = true;
  SiteComplianceOptions sites;
  /// What the organ rests on and is attached to, from the CT (--supports ct);
  /// empty (--supports none): the model holds no supports.
  std::optional<SupportOptions> supports = SupportOptions{};
  model::Material material = model::liver_default_material();

  std::string program_version;    ///< written into the model's provenance
  std::string output_path;        ///< when set: the model file is written there (atomically)
  std::string intermediates_dir;  ///< when set: mask.nii.gz, surface.vtp, surface.stl, tetrahedra.vtu, published
                                  ///< only when the whole bake (and the model file) succeeded
};

/// What the pipeline made, for the user to check before simulating.
struct BakeReport {
  std::array<std::size_t, 3> image_size{};
  std::array<double, 3> image_spacing_mm{};
  std::string segmentation;                        ///< "label map (value N)" or "seeds (N, M background)"
  std::optional<SeededSegmentationReport> seeded;  ///< what the seeded segmentation did
  std::vector<std::string> segmentation_warnings;  ///< the mask does not look like a whole liver
  std::optional<double> reference_dice;            ///< against BakeOptions::reference_label_path
  std::size_t mask_voxels = 0;
  double mask_volume_ml = 0.0;
  std::array<double, 3> fixed_point_mm{};
  std::string fixed_point_source;       ///< "given point", "given voxel" or "deepest interior point"
  double fixed_point_depth_mm = 0.0;    ///< deepest interior point: its distance to the mask boundary
  double fixed_point_outside_mm = 0.0;  ///< given point or voxel: distance to the nearest organ voxel (0 inside)
  std::size_t surface_vertices = 0, surface_triangles = 0;
  double surface_area_cm2 = 0.0, surface_volume_ml = 0.0;
  std::size_t volume_vertices = 0;
  TetrahedralQuality tetrahedra;
  std::vector<std::string> tetrahedra_warnings;  ///< quality goals missed (tetrahedra_quality_warnings)
  double tetrahedra_volume_ml = 0.0;
  std::uint32_t stations = 0;  ///< 0: baked without beam tables
  std::size_t beam_sections = 0;
  SiteComplianceReport sites;             ///< when the model has site compliances (sites.unknowns > 0)
  std::optional<SupportReport> supports;  ///< when the bake looked for supports
  std::string sites_skipped;  ///< why the site compliances were not computed (the FEM clamp cannot hold the organ)
  /// Each stage's own time, in the order they start. The fixed point (the
  /// deepest interior point) runs beside the surface, and the beam tables
  /// beside the tetrahedra, assemble and the site compliances, so the times
  /// add up to more than the total.
  std::vector<std::pair<std::string, double>> stage_seconds;
  double total_seconds = 0.0;  ///< the bake's wall time, reading the CT to the finished model (not writing it)
};

struct BakeResult {
  model::OrganModel model;
  BakeReport report;
  /// Seeded segmentation with BakeOptions::seeded.explain: what was kept and
  /// cut, as SeededSegmentation::explanation.
  MaskImage::Pointer segmentation_explanation;
};

/// Called when a stage starts (fraction 0), advances and ends (fraction 1).
using BakeProgress = std::function<void(const std::string& stage, double fraction)>;

/// Runs the pipeline. The result is deterministic: the same input and options
/// give the same model (the report's timings aside).
BakeResult bake(const BakeOptions& options, const BakeProgress& progress = {});

}  // namespace organsim::pipeline
