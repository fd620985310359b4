#include "segmentation_options.h"

#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "command_line/command_line.h"

namespace organsim::cli {
namespace {

/// "X,Y,Z" → three finite numbers; nullopt when the text is not that.
std::optional<std::array<double, 3>> parse_triple(const std::string& text) {
  std::array<double, 3> v{};
  std::istringstream in(text);
  for (int k = 0; k < 3; ++k) {
    if (k > 0 && in.get() != ',') return std::nullopt;
    if (!(in >> v[k]) || !std::isfinite(v[k])) return std::nullopt;
  }
  return in.peek() == std::char_traits<char>::eof() ? std::optional(v) : std::nullopt;
}

const CLI::Validator kPoint(
    [](std::string& text) {
      return parse_triple(text) ? std::string() : "takes X,Y,Z: three numbers in mm (LPS), got '" + text + "'";
    },
    "X,Y,Z");

const CLI::Validator kVoxel(
    [](std::string& text) {
      const auto v = parse_triple(text);
      bool whole = v.has_value();
      for (int k = 0; whole && k < 3; ++k) whole = (*v)[k] == std::floor((*v)[k]);
      return whole ? std::string() : "takes I,J,K: three whole voxel indices, got '" + text + "'";
    },
    "I,J,K");

void add_points(std::vector<pipeline::SeedPoint>& to, const std::vector<std::string>& points,
                const std::vector<std::string>& voxels) {
  for (const std::string& p : points) to.push_back(pipeline::SeedPoint::at_mm(*parse_triple(p)));
  for (const std::string& v : voxels) {
    const std::array<double, 3> t = *parse_triple(v);
    to.push_back(
        pipeline::SeedPoint::at_voxel({static_cast<long>(t[0]), static_cast<long>(t[1]), static_cast<long>(t[2])}));
  }
}

}  // namespace

void add_seeded_segmentation_options(CLI::App& app, SegmentationCommandOptions& o) {
  pipeline::SeededSegmentationOptions& m = o.method;
  app.add_option("--seed", o.seeds, "A point inside the organ X,Y,Z (LPS, mm, as 3D Slicer shows it); repeatable")
      ->check(kPoint)
      ->take_all();
  app.add_option("--seed-voxel", o.seed_voxels, "A voxel inside the organ I,J,K; repeatable")
      ->check(kVoxel)
      ->take_all();
  app.add_option("--background-seed", o.background_seeds,
                 "A point X,Y,Z (mm) in a neighbour the organ must not include (heart, stomach, kidney); repeatable")
      ->check(kPoint)
      ->take_all();
  app.add_option("--background-seed-voxel", o.background_seed_voxels, "A background seed as a voxel I,J,K; repeatable")
      ->check(kVoxel)
      ->take_all();
  app.add_option("--hu-window", o.hu_window,
                 "HU window LOW,HIGH of the organ (default: from the seeds' neighbourhoods, see --window-sigmas)")
      ->delimiter(',')
      ->expected(2);
  app.add_option("--window-sigmas", o.window_sigmas,
                 fmt::format("HU window from the seeds: median - BELOW to median + ABOVE robust sigmas (default {},{})",
                             m.window_sigmas_below, m.window_sigmas_above))
      ->delimiter(',')
      ->expected(2)
      ->check(kPositive);
  app.add_option("--seed-radius", m.seed_radius_mm, "Neighbourhood of each seed for the HU statistics, mm")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--opening", m.opening_radius_mm,
                 "Leak control: opening radius, mm; cuts bridges thinner than twice this into neighbours at the "
                 "same HU (0: none)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--reach", m.reach_mm,
                 "Leak control: how far beyond the opened organ its border may lie, mm (restores thin edges)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_flag(
      "--no-neck-rule", [&m](std::int64_t) { m.take_back_lobes = false; },
      "Leak control: keep out every piece the opening cut, even one of the organ's own tissue behind a neck "
      "thicker than the opening radius (docs/segmentation.md#what-leak-control-gives-back)");
  app.add_option("--lesion-radius", m.lesion_radius_mm,
                 "Takes in dents up to this radius, mm, that lesions and vessels at the organ's surface leave, when "
                 "the organ encloses them (0: none)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--smoothing-iterations", m.smoothing_iterations,
                 "Edge-preserving smoothing (curvature anisotropic diffusion) iterations (0: none)")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  app.add_option("--working-spacing", m.working_spacing_mm,
                 "Segment on blocks of about this size, mm, when the CT is finer (0: full resolution)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option(
      "--explain", o.explain_path,
      "Write a label map on the CT's grid (1 organ, 2 cut by leak control, 3 given to background seeds, 4 organ "
      "given back by the neck rule) "
      "that 3D Slicer opens over the CT (.nii.gz, .nrrd, .mha; docs/segmentation.md#what-was-cut)");
  app.add_option("--reference", o.reference_path,
                 "A label map of the same CT (TotalSegmentator, 3D Slicer): print the Dice of the result against it");
  app.add_option("--reference-value", o.reference_value, "The organ's value in the --reference label map")
      ->capture_default_str();
}

pipeline::SeededSegmentationOptions seeded_segmentation_options(const SegmentationCommandOptions& o) {
  pipeline::SeededSegmentationOptions m = o.method;
  add_points(m.seeds, o.seeds, o.seed_voxels);
  add_points(m.background_seeds, o.background_seeds, o.background_seed_voxels);
  if (!o.hu_window.empty()) m.hu_window = std::make_pair(o.hu_window[0], o.hu_window[1]);
  if (!o.window_sigmas.empty()) m.window_sigmas_below = o.window_sigmas[0], m.window_sigmas_above = o.window_sigmas[1];
  m.explain = !o.explain_path.empty();
  return m;
}

void print_seeded_segmentation_report(const pipeline::SeededSegmentationReport& r) {
  fmt::print("HU window       {:.0f} to {:.0f} HU", r.hu_low, r.hu_high);
  if (r.window_given)
    fmt::print(" (given)\n");
  else
    fmt::print(
        " (seeds' neighbourhoods: median {:.1f}, robust sigma {:.1f}; organ core: median {:.1f}, robust sigma "
        "{:.1f} HU)\n",
        r.seed_median_hu, r.seed_sigma_hu, r.organ_median_hu, r.organ_sigma_hu);
  fmt::print("leak control    window region {:.1f} mL, cut by the opening {:.1f} mL", r.grown_ml, r.cut_by_opening_ml);
  if (r.background_split_ml > 0.0) fmt::print(", {:.1f} mL given to background seeds", r.background_split_ml);
  fmt::print("\n");
  for (const pipeline::CutRegion& c : r.taken_back)
    fmt::print(
        "taken back      {:.1f} mL cut by the opening: {:.0f} HU (robust sigma {:.0f}), joined by a neck {:.0f} mm "
        "thick at {:.0f} HU, box {:.0f}..{:.0f}, {:.0f}..{:.0f}, {:.0f}..{:.0f} mm: the organ's tissue behind a neck\n",
        c.volume_ml, c.median_hu, c.sigma_hu, c.neck_thickness_mm, c.neck_median_hu, c.box_low_mm[0], c.box_high_mm[0],
        c.box_low_mm[1], c.box_high_mm[1], c.box_low_mm[2], c.box_high_mm[2]);
  for (const pipeline::CutRegion& c : r.cut_regions)
    fmt::print(
        "cut             {:.1f} mL by {}: {:.0f} HU (robust sigma {:.0f}; organ core {:.0f}: {}), joined by a neck "
        "{:.0f} mm wide, box {:.0f}..{:.0f}, {:.0f}..{:.0f}, {:.0f}..{:.0f} mm; left out: {}; if it is organ, add "
        "--seed {:.1f},{:.1f},{:.1f}\n",
        c.volume_ml, c.cause, c.median_hu, c.sigma_hu, r.window_given ? r.seed_median_hu : r.organ_median_hu,
        c.like_organ ? "tissue like the organ's" : "unlike the organ, more likely a neighbour", c.neck_width_mm,
        c.box_low_mm[0], c.box_high_mm[0], c.box_low_mm[1], c.box_high_mm[1], c.box_low_mm[2], c.box_high_mm[2],
        c.kept_out_because, c.seed_mm[0], c.seed_mm[1], c.seed_mm[2]);
  fmt::print("lesions         {:.1f} mL of enclosed dents (lesions, vessels at the surface) taken in",
             r.enclosed_dents_ml);
  if (r.lesion_seeds > 0) fmt::print("; {} seed(s) in a lesion added {:.1f} mL", r.lesion_seeds, r.lesion_seed_ml);
  fmt::print("\n");
  fmt::print("working grid    {:.3g}x{:.3g}x{:.3g} mm\n", r.working_spacing_mm[0], r.working_spacing_mm[1],
             r.working_spacing_mm[2]);
  std::string steps;
  double total = 0.0;
  for (const auto& [step, seconds] : r.step_seconds)
    steps += fmt::format("{} {:.2f}, ", step, seconds), total += seconds;
  fmt::print("time (segment)  {}total {:.2f} s\n", steps, total);
}

nlohmann::ordered_json seeded_segmentation_report_json(const pipeline::SeededSegmentationReport& r) {
  nlohmann::ordered_json j;
  j["voxels"] = r.voxels;
  j["volume_ml"] = r.volume_ml;
  j["hu_window"] = {r.hu_low, r.hu_high};
  j["hu_window_source"] = r.window_given ? "given" : "seeds";
  j["seed_median_hu"] = r.seed_median_hu;
  j["seed_sigma_hu"] = r.seed_sigma_hu;
  j["organ_median_hu"] = r.organ_median_hu;
  j["organ_sigma_hu"] = r.organ_sigma_hu;
  j["working_spacing_mm"] = r.working_spacing_mm;
  j["window_region_ml"] = r.grown_ml;
  j["cut_by_opening_ml"] = r.cut_by_opening_ml;
  j["background_split_ml"] = r.background_split_ml;
  j["enclosed_dents_ml"] = r.enclosed_dents_ml;
  j["lesion_seeds"] = r.lesion_seeds;
  j["lesion_seed_ml"] = r.lesion_seed_ml;
  j["border_slices"] = r.border_slices;
  const auto regions = [](const std::vector<pipeline::CutRegion>& list, bool cut) {
    nlohmann::ordered_json all = nlohmann::ordered_json::array();
    for (const pipeline::CutRegion& c : list) {
      nlohmann::ordered_json region;
      region["cause"] = c.cause;
      region["volume_ml"] = c.volume_ml;
      region["median_hu"] = c.median_hu;
      region["sigma_hu"] = c.sigma_hu;
      region["neck_width_mm"] = c.neck_width_mm;
      region["neck_thickness_mm"] = c.neck_thickness_mm;
      region["neck_median_hu"] = c.neck_median_hu;
      region["contact_fraction"] = c.contact_fraction;
      region["depth_mm"] = c.depth_mm;
      region["like_organ"] = c.like_organ;
      region["box_mm"] = {c.box_low_mm, c.box_high_mm};
      if (cut) {
        region["kept_out_because"] = c.kept_out_because;
        region["seed_mm"] = c.seed_mm;
        region["seed_option"] = fmt::format("--seed {:.1f},{:.1f},{:.1f}", c.seed_mm[0], c.seed_mm[1], c.seed_mm[2]);
      }
      all.push_back(region);
    }
    return all;
  };
  j["cut_regions"] = regions(r.cut_regions, true);
  j["taken_back"] = regions(r.taken_back, false);
  j["warnings"] = r.warnings;
  nlohmann::ordered_json steps;
  for (const auto& [step, seconds] : r.step_seconds) steps[step] = seconds;
  j["seconds"] = steps;
  return j;
}

}  // namespace organsim::cli
