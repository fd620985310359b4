#include "organsim/pipeline/bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>

#include "organsim/geometry/model_measures.h"
#include "organsim/io/atomic_file.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/model/model_file.h"
#include "organsim/organ/organ.h"
#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/fixed_point.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/image_hash.h"
#include "organsim/pipeline/segmentation.h"

namespace organsim::pipeline {
namespace {

// The surface in the order the runtime keeps it (organ::morton_order), so
// that loading the model renumbers and copies nothing.
geometry::SurfaceMesh in_runtime_order(geometry::SurfaceMesh mesh) {
  organ::renumber_in_morton_order(mesh.vertices, mesh.triangles);
  return mesh;
}

constexpr double kMetresPerMillimetre = 1e-3;
constexpr double kMillilitresPerCubicMetre = 1e6;

std::string format_triple(const std::array<double, 3>& v) { return fmt::format("{},{},{}", v[0], v[1], v[2]); }

/// Seeds as the user gave them: "X,Y,Z mm" or "I,J,K voxel", separated by "; ".
std::string seeds_text(const std::vector<SeedPoint>& seeds) {
  std::string text;
  for (const SeedPoint& seed : seeds) {
    if (!text.empty()) text += "; ";
    if (seed.point_mm) text += format_triple(*seed.point_mm) + " mm";
    if (seed.voxel) text += fmt::format("{},{},{} voxel", (*seed.voxel)[0], (*seed.voxel)[1], (*seed.voxel)[2]);
  }
  return text;
}
/// Times the stages and tells the progress callback about them, from
/// whichever thread a stage runs on (one at a time).
class StageClock {
 public:
  StageClock(const BakeProgress& progress, BakeReport& report)
      : progress_(progress), report_(report), started_(std::chrono::steady_clock::now()) {}
  template <typename Work>
  auto run(const std::string& stage, Work&& work) {
    notify(stage, 0.0);
    const auto start = std::chrono::steady_clock::now();
    if constexpr (std::is_void_v<decltype(work())>) {
      work();
      record(stage, start);
    } else {
      auto result = work();
      record(stage, start);
      return result;
    }
  }

  /// A stage that runs on its own thread beside the stages after it: start()
  /// begins it, join() waits for its result. Its time is its own, so the
  /// stages' times add up to more than total_seconds, the bake's wall time.
  template <typename Result>
  class Beside {
   public:
    template <typename Work>
    void start(StageClock& clock, const std::string& stage, Work work) {
      clock.notify(stage, 0.0);
      slot_ = clock.report_.stage_seconds.size();
      clock.report_.stage_seconds.emplace_back(stage, 0.0);
      result_ = std::async(std::launch::async, [&clock, stage, work = std::move(work)] {
        const auto start = std::chrono::steady_clock::now();
        Result result = work();
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        clock.notify(stage, 1.0);
        return std::make_pair(std::move(result), seconds);
      });
    }
    /// Waits for the stage and records its time; rethrows what it threw.
    Result join(StageClock& clock) {
      auto [result, seconds] = result_.get();
      clock.report_.stage_seconds[slot_].second = seconds;
      return std::move(result);
    }

   private:
    std::future<std::pair<Result, double>> result_;
    std::size_t slot_ = 0;
  };

  void notify(const std::string& stage, double fraction) const {
    if (!progress_) return;
    const std::lock_guard<std::mutex> one_at_a_time(progress_mutex_);
    progress_(stage, fraction);
  }
  /// Seconds since the bake started.
  double wall_seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  }

 private:
  void record(const std::string& stage, std::chrono::steady_clock::time_point start) {
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    report_.stage_seconds.emplace_back(stage, seconds);
    notify(stage, 1.0);
  }
  const BakeProgress& progress_;
  BakeReport& report_;
  const std::chrono::steady_clock::time_point started_;
  mutable std::mutex progress_mutex_;
};

void check_options(const BakeOptions& o) {
  const bool label = !o.label_path.empty(), seed = !o.seeded.seeds.empty();
  if (label && seed) throw std::runtime_error("give either --label or seeds (--seed/--seed-voxel), not both");
  if (!label && !seed)
    throw std::runtime_error(
        "no segmentation: give --label MASK (a label map) or --seed X,Y,Z / --seed-voxel I,J,K (a point in the organ)");
  if (label && !o.seeded.background_seeds.empty())
    throw std::runtime_error("background seeds go with --seed, not with a label map");
  const model::Material& m = o.material;
  if (!(std::isfinite(m.young_modulus) && m.young_modulus > 0.0))
    throw std::runtime_error(
        fmt::format("--young-modulus must be a positive number of pascals (got {})", m.young_modulus));
  if (!(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5))
    throw std::runtime_error(fmt::format("--poisson-ratio must lie in (-1, 0.5) (got {})", m.poisson_ratio));
  if (!(std::isfinite(m.density) && m.density > 0.0))
    throw std::runtime_error(fmt::format("--density must be a positive number of kg/m³ (got {})", m.density));
  if (!(std::isfinite(m.attenuation_alpha) && m.attenuation_alpha > 0.0))
    throw std::runtime_error(fmt::format("--alpha must be positive (got {})", m.attenuation_alpha));
  if (!(std::isfinite(m.attenuation_beta) && m.attenuation_beta >= 0.0))
    throw std::runtime_error(
        fmt::format("--beta must be a non-negative number per metre (got {})", m.attenuation_beta));
  if (o.beam_tables && (o.beams.stations < 1 || o.beams.stations > 4096))
    throw std::runtime_error(
        fmt::format("--stations must lie in 1..4096 (got {}); to bake a model without beam tables "
                    "(every model but the multi-beam one runs on it), pass --no-beam-tables",
                    o.beams.stations));
  if (!(o.clamp_cells_mm >= 0.0 && std::isfinite(o.clamp_cells_mm)))
    throw std::runtime_error(
        fmt::format("--clamp-cells must be a non-negative number of mm (got {})", o.clamp_cells_mm));
  if (o.surface.target_vertices < 100)
    throw std::runtime_error(
        fmt::format("--surface-vertices must be at least 100 (got {})", o.surface.target_vertices));
}

MaskImage::Pointer segment(const CtImage& ct, const BakeOptions& o, BakeReport& report,
                           MaskImage::Pointer& explanation) {
  MaskImage::Pointer mask;
  if (!o.label_path.empty()) {
    mask = clean_mask(*read_label_mask(o.label_path, o.label_value, ct), o.label_closing_radius_mm);
    report.segmentation = fmt::format("label map (value {})", o.label_value);
  } else {
    SeededSegmentationOptions seeded = o.seeded;
    seeded.minimum_voxels = o.minimum_voxels;
    SeededSegmentation segmented = segment_from_seeds(ct, seeded);
    mask = segmented.mask;
    report.segmentation =
        fmt::format("seeds ({} in the organ, {} background)", o.seeded.seeds.size(), o.seeded.background_seeds.size());
    report.segmentation_warnings = segmented.report.warnings;
    report.seeded = std::move(segmented.report);
    explanation = segmented.explanation;
  }
  report.mask_voxels = count_voxels(*mask);
  if (report.mask_voxels < o.minimum_voxels)
    throw std::runtime_error(
        fmt::format("the segmentation has only {} voxels (fewer than {}); check the label value or the seeds",
                    report.mask_voxels, o.minimum_voxels));
  const auto spacing = mask->GetSpacing();
  report.mask_volume_ml = static_cast<double>(report.mask_voxels) * spacing[0] * spacing[1] * spacing[2] * 1e-3;
  if (!o.label_path.empty()) {
    const auto [border, slices] = border_and_organ_slices(*mask);
    report.segmentation_warnings = liver_plausibility_warnings(report.mask_volume_ml, border, slices);
  }
  if (!o.reference_label_path.empty())
    report.reference_dice =
        dice_coefficient(*mask, *read_label_mask(o.reference_label_path, o.reference_label_value, ct));
  return mask;
}

/// The intermediates a bake writes on request. Each is written to a temporary
/// file in the directory as soon as it exists and published only by commit(),
/// when the whole bake has succeeded: a bake that fails leaves nothing partial
/// (and removes the directory if it made it and it is still empty).
class Intermediates {
 public:
  explicit Intermediates(std::string directory) : directory_(std::move(directory)) {}
  Intermediates(const Intermediates&) = delete;
  Intermediates& operator=(const Intermediates&) = delete;
  ~Intermediates() {
    files_.clear();  // removes the uncommitted temporary files
    std::error_code ignored;
    if (created_directory_ && !committed_ && std::filesystem::is_empty(directory_, ignored))
      std::filesystem::remove(directory_, ignored);
  }

  bool wanted() const { return !directory_.empty(); }

  /// Where to write intermediate `name` (e.g. "mask.nii.gz", whose extension
  /// picks the writer) until commit().
  std::string stage(const std::string& name, const std::string& extension) {
    std::error_code error;
    if (!std::filesystem::exists(directory_, error)) {
      std::filesystem::create_directories(directory_, error);
      if (error)
        throw std::runtime_error(
            fmt::format("cannot create the intermediates directory '{}': {}", directory_, error.message()));
      created_directory_ = true;
    }
    files_.push_back(std::make_unique<io::AtomicFile>((std::filesystem::path(directory_) / name).string(), extension));
    return files_.back()->temp_path();
  }

  void commit() {
    for (auto& file : files_) file->commit();
    committed_ = true;
  }

 private:
  std::string directory_;
  std::vector<std::unique_ptr<io::AtomicFile>> files_;
  bool created_directory_ = false, committed_ = false;
};

std::map<std::string, std::string> provenance_parameters(const BakeOptions& o, const BakeReport& report) {
  std::map<std::string, std::string> p;
  p["segmentation"] = report.segmentation;
  if (o.label_path.empty()) {
    const SeededSegmentationOptions& s = o.seeded;
    p["seeds"] = seeds_text(s.seeds);
    p["background_seeds"] = seeds_text(s.background_seeds);
    p["hu_window"] = fmt::format("{},{}", report.seeded->hu_low, report.seeded->hu_high);
    p["hu_window_source"] = report.seeded->window_given ? "given"
                                                        : fmt::format("seed median -{}/+{} robust sigma",
                                                                      s.window_sigmas_below, s.window_sigmas_above);
    p["working_spacing_mm"] = fmt::format("{}", s.working_spacing_mm);
    p["smoothing"] = fmt::format("curvature anisotropic diffusion, {} iterations, conductance {}",
                                 s.smoothing_iterations, s.smoothing_conductance);
    p["opening_radius_mm"] = fmt::format("{}", s.opening_radius_mm);
    p["reach_mm"] = fmt::format("{}", s.reach_mm);
    p["closing_radius_mm"] = fmt::format("{}", s.closing_radius_mm);
  } else {
    p["closing_radius_mm"] = fmt::format("{}", o.label_closing_radius_mm);
  }
  p["minimum_voxels"] = fmt::format("{}", o.minimum_voxels);
  p["fixed_point_mm"] = format_triple(report.fixed_point_mm);
  p["fixed_point_source"] = report.fixed_point_source;
  p["surface_vertices"] = fmt::format("{}", o.surface.target_vertices);
  p["smoothing_iterations"] = fmt::format("{}", o.surface.smoothing_iterations);
  p["smoothing_passband"] = fmt::format("{}", o.surface.smoothing_passband);
  p["tet_size_mm"] = fmt::format("{}", o.tetrahedra.tet_size_mm);
  p["facet_distance_mm"] = fmt::format("{}", o.tetrahedra.facet_distance_mm);
  p["facet_angle_deg"] = fmt::format("{}", o.tetrahedra.facet_angle_deg);
  p["radius_edge_ratio"] = fmt::format("{}", o.tetrahedra.radius_edge_ratio);
  p["mesh_optimization"] = o.tetrahedra.optimize ? "sliver removal" : "none";
  p["clamp_cells_mm"] = fmt::format("{}", o.clamp_cells_mm);
  p["clamp_radius_mm"] = fmt::format("{}", o.sites.fixed_radius * 1e3);
  if (!o.tetrahedra.refinements.empty()) {
    std::string places;
    for (const LocalRefinement& r : o.tetrahedra.refinements)
      places += fmt::format("{}{:.2f},{:.2f},{:.2f} mm within {} mm at {} mm", places.empty() ? "" : "; ",
                            r.centre[0] * 1e3, r.centre[1] * 1e3, r.centre[2] * 1e3, r.radius_mm, r.size_mm);
    p["tetrahedra_refined"] = places;
  }
  if (o.supports) {
    const SupportOptions& s = *o.supports;
    p["supports"] = fmt::format(
        "ct: tissue from {} HU at {}-{} mm outside ({} samples), attachments within {} mm of the surface point nearest "
        "the fixed point, "
        "modulus {} over {} mm",
        s.tissue_low_hu, s.near_mm, s.far_mm, s.samples, s.attachment_radius_mm,
        s.tissue_young_modulus > 0.0 ? fmt::format("E {} Pa", s.tissue_young_modulus) : std::string("the organ's E"),
        s.yielding_depth_mm);
  } else {
    p["supports"] = "none";
  }
  if (o.beam_tables) {
    p["stations"] = fmt::format("{}", o.beams.stations);
    p["section_samples_per_side"] = fmt::format("{}", o.beams.samples_per_side);
  } else {
    p["beam_tables"] = "none";
  }
  return p;
}

void require_valid(const model::OrganModel& model) {
  const std::string problem = model::validate_organ_model(model);
  if (!problem.empty()) throw std::runtime_error("the baked model is not valid: " + problem);
}

}  // namespace

/// A bake's peak memory: the phantom from 128x128x100 to 512x512x1500 voxels
/// (tools/experiments/scaling.py bake) held 7.2–7.6 bytes per voxel above a
/// base of 170–200 MiB while the segmentation kept a float copy of the CT,
/// 4.7 bytes since it bins the int16 CT directly, and the FEM of the site
/// compliances up to 350 MiB whatever the CT. The ask stays at the former
/// slope with a margin: a CT that passes fits with room to spare.
const MemoryNeed kBakeMemory{8.0, 768.0 * 1024 * 1024, "baking it"};

BakeResult bake(const BakeOptions& o, const BakeProgress& progress) {
  check_options(o);
  BakeResult result;
  BakeReport& report = result.report;
  StageClock clock(progress, report);

  const CtImage::Pointer ct = clock.run("read CT", [&] { return read_ct(o.ct_path, o.series_uid, kBakeMemory); });
  const auto size = ct->GetLargestPossibleRegion().GetSize();
  for (unsigned k = 0; k < 3; ++k) report.image_size[k] = size[k], report.image_spacing_mm[k] = ct->GetSpacing()[k];

  // The input's hash for the provenance, on the core the segmentation's
  // serial steps leave idle.
  std::future<std::string> input_sha256 = std::async(std::launch::async, [&ct] { return image_sha256(*ct); });

  Intermediates intermediates(o.intermediates_dir);
  const MaskImage::Pointer mask = clock.run("segment", [&] {
    MaskImage::Pointer segmented = segment(*ct, o, report, result.segmentation_explanation);
    if (intermediates.wanted()) write_mask_image(*segmented, intermediates.stage("mask.nii.gz", ".nii.gz"));
    return segmented;
  });
  // The fixed point and the surface need only the mask. The deepest
  // interior point (a distance map) runs beside the surface, whose
  // decimation is serial; a given point is only checked, and at once, so
  // that a wrong one is the first thing reported.
  const auto choose = [&] { return choose_fixed_point(*mask, o.fixed_point_mm, o.fixed_point_voxel); };
  StageClock::Beside<FixedPoint> fixed_point_stage;
  std::optional<FixedPoint> given_fixed_point;
  if (o.fixed_point_mm || o.fixed_point_voxel)
    given_fixed_point = clock.run("fixed point", choose);
  else
    fixed_point_stage.start(clock, "fixed point", choose);
  const geometry::SurfaceMesh surface = clock.run("surface", [&] {
    geometry::SurfaceMesh extracted = in_runtime_order(extract_surface(*mask, o.surface));
    if (intermediates.wanted()) {
      mesh_io::write_surface_vtp(extracted, intermediates.stage("surface.vtp", ".vtp"));
      mesh_io::write_surface_stl(extracted, intermediates.stage("surface.stl", ".stl"));
    }
    return extracted;
  });
  const FixedPoint fixed_point = given_fixed_point ? *given_fixed_point : fixed_point_stage.join(clock);
  report.fixed_point_mm = fixed_point.point_mm;
  report.fixed_point_source = fixed_point.source;
  report.fixed_point_depth_mm = fixed_point.depth_mm;
  report.fixed_point_outside_mm = fixed_point.outside_mm;
  report.surface_vertices = surface.vertices.size();
  report.surface_triangles = surface.triangles.size();
  report.surface_area_cm2 = geometry::surface_area(surface.vertices, surface.triangles) * 1e4;
  report.surface_volume_ml = geometry::enclosed_volume(surface.vertices, surface.triangles) * kMillilitresPerCubicMetre;

  const model::Point3 fixed_point_m{report.fixed_point_mm[0] * kMetresPerMillimetre,
                                    report.fixed_point_mm[1] * kMetresPerMillimetre,
                                    report.fixed_point_mm[2] * kMetresPerMillimetre};
  // The beam tables need the mask and the surface, the site compliances the
  // tetrahedra: the two largest stages overlap, the beam tables from before
  // the tetrahedra on, each filling the cores the other's serial parts (the
  // meshing, the factorization) leave idle. Both give the same result on any
  // number of threads.
  StageClock::Beside<model::BeamTables> beam_tables;
  if (o.beam_tables)
    beam_tables.start(clock, "beam tables", [&] {
      return bake_beam_tables(*mask, surface.vertices, fixed_point_m, o.beams,
                              [&](double fraction) { clock.notify("beam tables", fraction); });
    });
  const geometry::TetrahedralMesh tetrahedra = clock.run("tetrahedra", [&] {
    TetrahedraOptions options = o.tetrahedra;
    if (o.clamp_cells_mm > 0.0)
      options.refinements.push_back(clamp_refinement(fixed_point_m, o.sites.fixed_radius, o.clamp_cells_mm));
    geometry::TetrahedralMesh meshed = make_tetrahedra(surface, options);
    if (intermediates.wanted()) mesh_io::write_tetrahedra_vtu(meshed, intermediates.stage("tetrahedra.vtu", ".vtu"));
    return meshed;
  });
  report.tetrahedra = measure_quality(tetrahedra);
  report.tetrahedra_warnings = tetrahedra_quality_warnings(report.tetrahedra);
  report.volume_vertices = tetrahedra.vertices.size();
  report.tetrahedra_volume_ml = report.tetrahedra.total_volume_m3 * kMillilitresPerCubicMetre;

  model::OrganModel& model = result.model;
  clock.run("assemble", [&] {
    model.provenance.coordinate_frame = "LPS";
    model.provenance.program_version = o.program_version;
    model.provenance.input_sha256 = input_sha256.get();
    model.provenance.parameters = provenance_parameters(o, report);
    model.surface_vertices = surface.vertices;
    model.surface_triangles = surface.triangles;
    model.surface_texcoords = spherical_texture_coordinates(surface.vertices);
    model.volume_vertices = tetrahedra.vertices;
    model.tetrahedra = tetrahedra.tetrahedra;
    model.fixed_points = {fixed_point_m};
    model.material = o.material;
    model.meshing.tet_size = o.tetrahedra.tet_size_mm * 1e-3;
    if (o.clamp_cells_mm > 0.0) {
      model.meshing.clamp_radius = o.sites.fixed_radius;
      model.meshing.clamp_cell_size = o.clamp_cells_mm * 1e-3;
    }
    require_valid(model);
  });
  if (o.supports)
    clock.run("supports", [&] {
      SupportReport found;
      model.supports = find_supports(*ct, model, *o.supports, &found);
      report.supports = found;
      require_valid(model);
    });
  if (o.site_compliance)
    clock.run("site compliance", [&] {
      try {
        model.sites = compute_site_compliance(model, o.sites, &report.sites);
        model.provenance.parameters["site_compliance"] =
            fmt::format("psh at rest, nu {}, beta {}, clamp {} mm, patch {:.2f} mm, curvature fit {:.2f} mm{}",
                        o.sites.poisson_ratio, o.sites.stabilization, o.sites.fixed_radius * 1e3,
                        report.sites.patch_radius * 1e3, report.sites.curvature_radius * 1e3,
                        model.sites.supported.empty()
                            ? ""
                            : (o.sites.settle_contacts ? ", also on the supports, contacts settled per press"
                                                       : ", also on the supports"));
      } catch (const std::invalid_argument& e) {
        // The FEM models cannot hold this organ with their default clamp
        // either: the model is still good for every other use.
        report.sites_skipped = e.what();
        model.provenance.parameters["site_compliance"] = "none: " + report.sites_skipped;
      }
    });
  if (o.beam_tables) {
    model.beams = beam_tables.join(clock);
    require_valid(model);
  }
  report.stations = model.beams.stations_per_beam;
  report.beam_sections = model.beams.sections.size();
  report.total_seconds = clock.wall_seconds();
  if (!o.output_path.empty()) model::write_organ_model_file(model, o.output_path);
  intermediates.commit();
  return result;
}

}  // namespace organsim::pipeline
