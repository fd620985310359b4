// Stage 2 of the pipeline, from seeds: the organ mask of a CT from one or more
// points inside the organ (and optionally points in neighbouring structures
// that must stay out), for when no label map exists.
//
// The method, each step an ITK filter (docs/segmentation.md has the why):
//  1. working grid: voxels finer than `working_spacing_mm` are averaged in
//     blocks (bin shrink), so a 512×512×200 CT costs what a 2.5 mm CT costs;
//  2. edge-preserving smoothing (curvature anisotropic diffusion);
//  3. a HU window from the seeds' neighbourhoods: the median − 4.5 to + 3
//     robust σ (1.4826 × median absolute deviation, at least 10 HU), taken
//     again from the organ's certain part (step 5) that this first window
//     finds; or the window the user gives;
//  4. with background seeds: a marker-controlled watershed on the gradient
//     magnitude splits the window's region between the organ's seeds and the
//     background seeds (3D Slicer's "grow from seeds" idea);
//  5. leak control: the window's region eroded by the opening radius (mm,
//     Euclidean distance maps) loses the bridges thinner than twice that into
//     the heart, stomach, kidney or muscle at the same HU; its component at the
//     seeds is certainly organ, what lies farther than the opening radius plus
//     `reach_mm` from it is not, and a marker-controlled watershed on the
//     gradient magnitude puts the border in between on the strongest edge
//     (a thin fat plane, a partial-volume dip), which a touching muscle of the
//     same HU still has; a cut piece that is the organ's own tissue behind a
//     neck of it (a lobe) is given back (take_back_lobes);
//  6. hole filling (3D, then slice by slice for vessels that cross a slice),
//     closing, the component holding the seeds, and back onto the CT's grid.
//
// Errors are std::runtime_error with one line: a seed outside the volume, in
// air, lung, fat or bone, a seed in a structure thinner than the opening, an
// empty or tiny result.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

/// A point in the CT, as the user gave it: LPS millimetres or a voxel index.
struct SeedPoint {
  std::optional<std::array<double, 3>> point_mm;
  std::optional<std::array<long, 3>> voxel;
  static SeedPoint at_mm(const std::array<double, 3>& p) { return {p, std::nullopt}; }
  static SeedPoint at_voxel(const std::array<long, 3>& v) { return {std::nullopt, v}; }
};

struct SeededSegmentationOptions {
  /// Inside the organ; at least one. A seed whose neighbourhood reads as fat
  /// (−30 HU down to lesion_low_hu) beside one in the organ's tissue marks a
  /// hypodense lesion, which is taken into the organ (not a window seed).
  std::vector<SeedPoint> seeds;
  std::vector<SeedPoint> background_seeds;  ///< in neighbours the organ must not include (heart, stomach, …)

  double working_spacing_mm = 2.5;     ///< voxels finer than this are averaged in blocks; 0: full resolution
  int smoothing_iterations = 5;        ///< curvature anisotropic diffusion; 0: none
  double smoothing_conductance = 3.0;  ///< diffusion stops at edges steeper than about this (× mean gradient)
  double seed_radius_mm = 10.0;        ///< neighbourhood of each seed that gives the HU statistics
  /// HU window = [median − below × σ, median + above × σ], σ the robust σ. Wider
  /// below: the liver's own lower tail (partial volume at its border with fat,
  /// less-enhanced regions in a contrast phase, hypodense lesions); above lie
  /// contrast-filled vessels and bone, which hole filling takes back.
  double window_sigmas_below = 4.5;
  double window_sigmas_above = 3.0;
  /// The first window, from the seeds' neighbourhoods, reaches this far above
  /// (a seed in a less enhanced part still finds the rest); the final window
  /// comes from the organ's certain part that the first one finds.
  double discovery_sigmas_above = 6.0;
  double minimum_sigma_hu = 10.0;                      ///< floor of the robust σ (a very uniform neighbourhood)
  std::optional<std::pair<double, double>> hu_window;  ///< given LOW,HIGH replaces the statistics
  double opening_radius_mm = 10.0;  ///< leak control: cuts bridges thinner than twice this, mm; 0: none
  double reach_mm = 3.0;            ///< leak control: how far beyond the opened organ its border may lie, mm
  double closing_radius_mm = 0.0;   ///< closes notches and vessel entries, mm; 0: none
  /// Lesions and vessels at the organ's surface leave dents the HU window
  /// cannot see and hole filling cannot close. A dent up to this radius (the
  /// largest lesion's) is taken into the organ when it is soft tissue or a
  /// vessel (lesion_low_hu up to vessel_high_hu) and the organ encloses it:
  /// at least `lesion_enclosure` of its border touches the organ. 0: off.
  double lesion_radius_mm = 20.0;
  double lesion_enclosure = 0.6;
  double lesion_low_hu = -40.0;       ///< below: fat and air, never a lesion's inside
  double vessel_high_hu = 300.0;      ///< above: bone and contrast in the bowel
  std::size_t minimum_voxels = 1000;  ///< smaller results are an error
  /// Regions of the HU window that leak control or a background seed took
  /// from the organ are reported from this volume up, mL.
  double reported_cut_ml = 5.0;
  /// Leak control gives back a piece it cut that is the organ's own tissue
  /// behind a neck of it (docs/segmentation.md#what-leak-control-gives-back):
  /// HU and spread like the organ core's, a neck thicker than the opening
  /// radius and not darker than the organ, thick enough to survive the
  /// opening itself, smaller than the organ kept, no background seed in it.
  bool take_back_lobes = true;
  /// Also make SeededSegmentation::explanation (a label map on the CT's grid).
  bool explain = false;
};

/// A region of the HU window, joined to the organ's seeds, that the
/// segmentation left out: what it was, where, and where a seed would take it
/// back (docs/segmentation.md#what-was-cut).
struct CutRegion {
  std::string cause;  ///< "leak control" or "background seed"
  double volume_ml = 0.0;
  double median_hu = 0.0, sigma_hu = 0.0;  ///< its HU (smoothed; σ robust)
  /// mm: the equivalent diameter of its contact with the organ kept,
  /// 2 √(A/π) for the contact area A; 0 where it touches the organ nowhere.
  double neck_width_mm = 0.0;
  /// mm: the neck's thickness, the diameter of the largest ball of the
  /// window's region centred on the contact (a bridge of partial volume is
  /// one or two voxels thick however long its contact).
  double neck_thickness_mm = 0.0;
  double contact_fraction = 0.0;  ///< of its surface, the part that touches the organ kept
  /// Median HU (smoothed) of the voxels on both sides of that contact. Below
  /// both pieces' HU it is an interface (a fat plane, partial volume between
  /// two organs); near them, one tissue running through.
  double neck_median_hu = 0.0;
  /// mm: how deep in the window's region its deepest voxel lies, about half
  /// the tissue's thickness there (deeper than the opening radius: the piece
  /// survives the opening).
  double depth_mm = 0.0;
  std::array<double, 3> box_low_mm{}, box_high_mm{};  ///< its bounding box (the CT's physical frame, LPS)
  /// Its voxel deepest in the window's region (where its tissue is thickest):
  /// --seed X,Y,Z there takes it back.
  std::array<double, 3> seed_mm{};
  /// Its median HU lies within two robust σ of the organ core's (at least
  /// minimum_sigma_hu): tissue like the organ's, so perhaps organ; otherwise
  /// more likely a neighbour of similar HU (a muscle, the bowel wall).
  bool like_organ = false;
  /// Why the neck rule left it out (why_not_taken_back), in words.
  std::string kept_out_because;
};

/// Why leak control keeps a cut piece out (empty: it is taken back), judged
/// against the organ core's HU median and robust σ on the smoothed CT and the
/// volume of the organ kept (mL).
std::string why_not_taken_back(const CutRegion& piece, double core_median_hu, double core_sigma_hu, double organ_ml,
                               const SeededSegmentationOptions& options);

/// The labels of SeededSegmentation::explanation.
enum ExplanationLabel : std::uint8_t {
  kNotOrgan = 0,
  kOrgan = 1,
  kCutByLeakControl = 2,
  kGivenToBackground = 3,
  kTakenBack = 4,  ///< organ: cut by the opening, given back by the neck rule
};

/// What the segmentation did, for the user to judge it (and a warning when the
/// result does not look like a liver).
struct SeededSegmentationReport {
  std::size_t voxels = 0;
  double volume_ml = 0.0;
  double seed_median_hu = 0.0, seed_sigma_hu = 0.0;    ///< statistics of the seeds' neighbourhoods (smoothed)
  double organ_median_hu = 0.0, organ_sigma_hu = 0.0;  ///< of the organ's certain part the first window found
  double hu_low = 0.0, hu_high = 0.0;                  ///< the window used
  bool window_given = false;                           ///< the user's window rather than the statistics
  std::array<double, 3> working_spacing_mm{};
  double background_split_ml = 0.0;    ///< given to the background seeds' regions
  double grown_ml = 0.0;               ///< the window's region connected to the seeds, before leak control
  double cut_by_opening_ml = 0.0;      ///< of that, what leak control removed
  double enclosed_dents_ml = 0.0;      ///< lesions and vessels at the surface taken into the organ
  std::size_t lesion_seeds = 0;        ///< seeds that read as a hypodense lesion (fat-dark, beside an organ seed)
  double lesion_seed_ml = 0.0;         ///< what their lesions added to the organ
  std::size_t border_slices = 0;       ///< axial slices where the mask touches the volume's side
  std::vector<CutRegion> cut_regions;  ///< largest first; those of at least reported_cut_ml
  /// Pieces the opening cut and the neck rule gave back (they are organ), largest first.
  std::vector<CutRegion> taken_back;
  std::vector<std::string> warnings;
  std::vector<std::pair<std::string, double>> step_seconds;  ///< in order
};

struct SeededSegmentation {
  MaskImage::Pointer mask;  ///< on the CT's grid
  /// With options.explain: on the CT's grid, each voxel's ExplanationLabel (the
  /// organ, what leak control cut, what the background seeds took, what the
  /// neck rule gave back).
  MaskImage::Pointer explanation;
  SeededSegmentationReport report;
};

/// Segments the organ holding `options.seeds`. Deterministic.
SeededSegmentation segment_from_seeds(const CtImage& ct, const SeededSegmentationOptions& options);

/// Warnings for a mask that does not look like a whole liver: a volume outside
/// 0.6–3.5 L, or touching the volume's side on many slices (a cut-off organ).
std::vector<std::string> liver_plausibility_warnings(double volume_ml, std::size_t border_slices,
                                                     std::size_t organ_slices);

/// Axial slices (along the third index) in which the mask touches the
/// volume's first or last row or column, and the slices the mask occupies.
std::pair<std::size_t, std::size_t> border_and_organ_slices(const MaskImage& mask);

}  // namespace organsim::pipeline
