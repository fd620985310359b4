// `organsim bake CT -o MODEL [segmentation] [fixed point] [mesh, beam, material options] [--json]`;
// the segmentation options are segment's (segmentation_options.h).
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>

#include <fmt/format.h>
#include <unistd.h>

#include "bake_command.h"
#include "command_line/command_line.h"
#include "organsim/model/model_file.h"
#include "organsim/pipeline/bake.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/version.h"
#include "segmentation_options.h"

namespace organsim::cli {
namespace {

struct BakeCommandOptions {
  pipeline::BakeOptions bake;
  std::string output_path;
  SegmentationCommandOptions segmentation;
  std::vector<double> fixed_point_mm, fixed_point_voxel;
  std::vector<std::string> refine_at;  // X,Y,Z (LPS, mm) each
  double refine_radius_mm = 10.0, refine_size_mm = 1.25;
  double closing_radius_mm = -1.0;  // < 0: the default of the segmentation method
  bool no_beam_tables = false;
  bool no_site_compliance = false;
  double site_patch_mm = 0.0;
  std::string supports = "ct";
  pipeline::SupportOptions support;
  bool json = false;
};

std::array<long, 3> to_voxel(const std::vector<double>& v, const char* option) {
  std::array<long, 3> voxel{};
  for (int k = 0; k < 3; ++k) {
    if (v[k] != std::floor(v[k])) throw std::runtime_error(fmt::format("{} takes whole voxel indices I,J,K", option));
    voxel[k] = static_cast<long>(v[k]);
  }
  return voxel;
}

/// Progress on stderr: a bar redrawn in place on a terminal, one line per
/// finished stage otherwise (logs, CI) or with --verbose. Stages may overlap
/// (the fixed point beside the surface, the beam tables beside the tetrahedra
/// and the site compliances): each keeps its own start.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(bool lines) : terminal_(!lines && ::isatty(STDERR_FILENO) == 1) {}
  void operator()(const std::string& stage, double fraction) {
    const auto now = std::chrono::steady_clock::now();
    if (fraction == 0.0) started_[stage] = now;
    const double seconds = std::chrono::duration<double>(now - started_[stage]).count();
    if (!terminal_) {
      if (fraction == 0.0) std::fprintf(stderr, "organsim bake: %s ...\n", stage.c_str());
      if (fraction == 1.0) std::fprintf(stderr, "organsim bake: %s done in %.2f s\n", stage.c_str(), seconds);
      return;
    }
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth + 0.5);
    std::fprintf(stderr, "\r\033[K%-12s [%s%s] %3d%% %6.1f s", stage.c_str(), std::string(filled, '#').c_str(),
                 std::string(kWidth - filled, '.').c_str(), static_cast<int>(fraction * 100 + 0.5), seconds);
    if (fraction == 1.0) std::fputc('\n', stderr);
    std::fflush(stderr);
  }

 private:
  bool terminal_;
  std::map<std::string, std::chrono::steady_clock::time_point> started_;
};

nlohmann::ordered_json report_json(const pipeline::BakeReport& r, const model::OrganModel& model,
                                   const std::string& output, std::uintmax_t bytes) {
  nlohmann::ordered_json j;
  j["model"] = output;
  j["model_bytes"] = bytes;
  j["input_sha256"] = model.provenance.input_sha256;
  j["image"] = {{"size", r.image_size}, {"spacing_mm", r.image_spacing_mm}};
  j["segmentation"] = {{"method", r.segmentation}, {"voxels", r.mask_voxels}, {"volume_ml", r.mask_volume_ml}};
  if (r.seeded) j["segmentation"]["seeded"] = seeded_segmentation_report_json(*r.seeded);
  j["segmentation"]["warnings"] = r.segmentation_warnings;
  if (r.reference_dice) j["segmentation"]["dice"] = *r.reference_dice;
  j["fixed_point"] = {{"position_mm", r.fixed_point_mm}, {"source", r.fixed_point_source}};
  if (r.fixed_point_source == "deepest interior point")
    j["fixed_point"]["depth_mm"] = r.fixed_point_depth_mm;
  else
    j["fixed_point"]["outside_mm"] = r.fixed_point_outside_mm;
  j["surface"] = {{"vertices", r.surface_vertices},
                  {"triangles", r.surface_triangles},
                  {"area_cm2", r.surface_area_cm2},
                  {"volume_ml", r.surface_volume_ml}};
  const auto& q = r.tetrahedra;
  j["tetrahedra"] = {{"count", q.tetrahedra},
                     {"vertices", r.volume_vertices},
                     {"volume_ml", r.tetrahedra_volume_ml},
                     {"min_dihedral_deg", q.min_dihedral_deg},
                     {"max_dihedral_deg", q.max_dihedral_deg},
                     {"max_radius_edge_ratio", q.max_radius_edge_ratio},
                     {"mean_radius_edge_ratio", q.mean_radius_edge_ratio},
                     {"min_volume_mm3", q.min_volume_m3 * 1e9},
                     {"warnings", r.tetrahedra_warnings}};
  j["beams"] = {{"stations", r.stations}, {"sections", r.beam_sections}};
  if (model.sites.empty())
    j["site_compliance"] = {{"computed", false},
                            {"reason", r.sites_skipped.empty() ? "--no-site-compliance" : r.sites_skipped}};
  else
    j["site_compliance"] = {{"computed", true},
                            {"boundary_nodes", r.sites.boundary_nodes},
                            {"patch_radius_mm", r.sites.patch_radius * 1e3},
                            {"curvature_radius_mm", r.sites.curvature_radius * 1e3},
                            {"unknowns", r.sites.unknowns},
                            {"factor_entries", r.sites.factor_entries},
                            {"factorization_seconds", r.sites.factorization_seconds},
                            {"solve_seconds", r.sites.solve_seconds},
                            {"unsettled_sites", r.sites.unsettled_sites}};
  if (r.supports)
    j["supports"] = {{"found", true},
                     {"contact_vertices", r.supports->contact_vertices},
                     {"attachment_vertices", r.supports->attachment_vertices},
                     {"free_vertices", r.supports->free_vertices},
                     {"unseen_vertices", r.supports->unseen_vertices},
                     {"contact_area_cm2", r.supports->contact_area_cm2},
                     {"attachment_area_cm2", r.supports->attachment_area_cm2},
                     {"surface_area_cm2", r.supports->surface_area_cm2},
                     {"foundation_modulus_pa_per_m", r.supports->modulus}};
  else
    j["supports"] = {{"found", false}};
  nlohmann::ordered_json stages;
  for (const auto& [stage, seconds] : r.stage_seconds) stages[stage] = seconds;
  j["seconds"] = {{"stages", stages}, {"total", r.total_seconds}};
  return j;
}

double percent_from(double value, double reference) { return 100.0 * (value / reference - 1.0); }

void print_report(const pipeline::BakeReport& r, const model::OrganModel& model, const std::string& output,
                  std::uintmax_t bytes) {
  const auto& q = r.tetrahedra;
  fmt::print("model           {} ({:.2f} MB)\n", output, static_cast<double>(bytes) / 1e6);
  fmt::print("image           {}x{}x{} voxels of {:.3g}x{:.3g}x{:.3g} mm, SHA-256 {}\n", r.image_size[0],
             r.image_size[1], r.image_size[2], r.image_spacing_mm[0], r.image_spacing_mm[1], r.image_spacing_mm[2],
             model.provenance.input_sha256);
  fmt::print("segmentation    {}: {} voxels, {:.1f} mL\n", r.segmentation, r.mask_voxels, r.mask_volume_ml);
  if (r.seeded) print_seeded_segmentation_report(*r.seeded);
  if (r.reference_dice) fmt::print("Dice            {:.4f} against the reference label map\n", *r.reference_dice);
  fmt::print("fixed point     {:.2f},{:.2f},{:.2f} mm LPS ({}", r.fixed_point_mm[0], r.fixed_point_mm[1],
             r.fixed_point_mm[2], r.fixed_point_source);
  if (r.fixed_point_source == "deepest interior point")
    fmt::print(", {:.1f} mm from the surface", r.fixed_point_depth_mm);
  else if (r.fixed_point_outside_mm > 0.0)
    fmt::print(", {:.1f} mm outside the mask", r.fixed_point_outside_mm);
  fmt::print(")\n");
  fmt::print("surface         {} vertices, {} triangles, area {:.1f} cm²\n", r.surface_vertices, r.surface_triangles,
             r.surface_area_cm2);
  fmt::print(
      "tetrahedra      {} on {} vertices; dihedral angles {:.1f}°..{:.1f}°, radius-edge ratio max {:.2f} mean {:.2f}\n",
      q.tetrahedra, r.volume_vertices, q.min_dihedral_deg, q.max_dihedral_deg, q.max_radius_edge_ratio,
      q.mean_radius_edge_ratio);
  fmt::print("volumes         mask {:.1f} mL, surface {:.1f} mL ({:+.2f} %), tetrahedra {:.1f} mL ({:+.2f} %)\n",
             r.mask_volume_ml, r.surface_volume_ml, percent_from(r.surface_volume_ml, r.mask_volume_ml),
             r.tetrahedra_volume_ml, percent_from(r.tetrahedra_volume_ml, r.mask_volume_ml));
  if (r.stations > 0)
    fmt::print("beam tables     {} stations x {} beams\n", r.stations, r.surface_vertices);
  else
    fmt::print("beam tables     none (--no-beam-tables): every model but --model beam runs on it\n");
  if (r.sites.unknowns > 0) {
    fmt::print(
        "site compliance {} boundary nodes solved, patch {:.1f} mm, curvature fit {:.1f} mm; {} unknowns, factor "
        "{:.1f} M entries; factorization {:.2f} s, solves {:.2f} s\n",
        r.sites.boundary_nodes, r.sites.patch_radius * 1e3, r.sites.curvature_radius * 1e3, r.sites.unknowns,
        r.sites.factor_entries * 1e-6, r.sites.factorization_seconds, r.sites.solve_seconds);
    if (r.sites.unsettled_sites > 0)
      fmt::print("{:<16}{} sites' presses found no set of contacts that holds; each keeps the one it reached\n",
                 "warning", r.sites.unsettled_sites);
  } else if (!r.sites_skipped.empty())
    fmt::print("site compliance none: {}; the fast models give their own forces\n", r.sites_skipped);
  else
    fmt::print("site compliance none (--no-site-compliance): the fast models give their own forces\n");
  if (r.supports)
    fmt::print(
        "supports        contact {:.0f} cm² ({} vertices), attachment {:.0f} cm² ({}), free {} vertices ({} beyond the "
        "CT's field of view), of {:.0f} cm²; foundation modulus {:.3g} Pa/m\n",
        r.supports->contact_area_cm2, r.supports->contact_vertices, r.supports->attachment_area_cm2,
        r.supports->attachment_vertices, r.supports->free_vertices, r.supports->unseen_vertices,
        r.supports->surface_area_cm2, r.supports->modulus);
  else
    fmt::print("supports        none (--supports none): the organ is held by its clamp alone\n");
  fmt::print("material        E {} Pa, nu {}, rho {} kg/m³, alpha {:.4g}, beta {} 1/m\n", model.material.young_modulus,
             model.material.poisson_ratio, model.material.density, model.material.attenuation_alpha,
             model.material.attenuation_beta);
  std::string stages;
  for (const auto& [stage, seconds] : r.stage_seconds) stages += fmt::format("{} {:.2f}, ", stage, seconds);
  fmt::print("time (s)        {}total {:.2f}\n", stages, r.total_seconds);
}

/// The pipeline with the command's options; writes the model file.
pipeline::BakeResult bake_model(BakeCommandOptions& o, const pipeline::BakeProgress& progress) {
  pipeline::BakeOptions& b = o.bake;
  b.seeded = seeded_segmentation_options(o.segmentation);
  b.reference_label_path = o.segmentation.reference_path;
  b.reference_label_value = o.segmentation.reference_value;
  if (!o.fixed_point_mm.empty())
    b.fixed_point_mm = std::array<double, 3>{o.fixed_point_mm[0], o.fixed_point_mm[1], o.fixed_point_mm[2]};
  if (!o.fixed_point_voxel.empty()) b.fixed_point_voxel = to_voxel(o.fixed_point_voxel, "--fixed-point-voxel");
  for (const std::string& at : o.refine_at) {
    const std::array<double, 3> mm = parse_xyz(at, "--refine-at " + at);
    b.tetrahedra.refinements.push_back(
        {{mm[0] * 1e-3, mm[1] * 1e-3, mm[2] * 1e-3}, o.refine_radius_mm, o.refine_size_mm});
  }
  if (o.closing_radius_mm >= 0.0) b.label_closing_radius_mm = b.seeded.closing_radius_mm = o.closing_radius_mm;
  b.beam_tables = !o.no_beam_tables;
  b.site_compliance = !o.no_site_compliance;
  b.supports = o.supports == "ct" ? std::optional<pipeline::SupportOptions>(o.support) : std::nullopt;
  b.sites.threads = b.beams.threads;
  b.sites.patch_radius = o.site_patch_mm * 1e-3;
  b.program_version = kProgramVersion;
  b.output_path = o.output_path;
  return pipeline::bake(b, progress);
}

int run_bake(BakeCommandOptions& o) {
  ProgressPrinter printer(verbosity() == Verbosity::verbose);
  pipeline::BakeProgress progress;
  if (verbosity() != Verbosity::quiet)
    progress = [&](const std::string& stage, double fraction) { printer(stage, fraction); };
  const pipeline::BakeResult result = bake_model(o, progress);
  if (result.segmentation_explanation)
    pipeline::write_mask_image(*result.segmentation_explanation, o.segmentation.explain_path);
  for (const std::string& warning : result.report.segmentation_warnings) warn("bake", warning);
  for (const std::string& warning : result.report.tetrahedra_warnings) warn("bake", warning);
  const std::uintmax_t bytes = std::filesystem::file_size(o.output_path);
  if (o.json)
    fmt::print("{}\n", report_json(result.report, result.model, o.output_path, bytes).dump());
  else
    print_report(result.report, result.model, o.output_path, bytes);
  return 0;
}

void add_bake_options(CLI::App& app, const std::shared_ptr<BakeCommandOptions>& o) {
  pipeline::BakeOptions& b = o->bake;
  app.add_option("ct", b.ct_path, "CT: a DICOM series directory, or a NIfTI, NRRD or MHA/MHD file")->required();
  app.add_option("-o,--output", o->output_path, "Model file to write (.organ)")->required();
  app.add_option("--series", b.series_uid, "Series instance UID, when the DICOM directory holds several series");
  app.add_option("--label", b.label_path, "Segmentation: a label map on the CT's grid (3D Slicer, TotalSegmentator)");
  app.add_option("--label-value", b.label_value, "The organ's value in the label map")->capture_default_str();
  add_seeded_segmentation_options(app, o->segmentation);
  app.add_option("--closing", o->closing_radius_mm,
                 "Morphological closing radius, mm (default: 3 after seeded segmentation, 0 for label maps)")
      ->check(kNonNegative);
  app.add_option("--fixed-point", o->fixed_point_mm,
                 "Beam clamp X,Y,Z (LPS, mm; e.g. the portal vein entry), in or on the organ; default: the deepest "
                 "interior point")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--fixed-point-voxel", o->fixed_point_voxel, "Beam clamp as a voxel I,J,K")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--surface-vertices", b.surface.target_vertices, "Simulation surface size (vertices)")
      ->capture_default_str();
  app.add_option("--tet-size", b.tetrahedra.tet_size_mm, "Tetrahedron size, mm")->capture_default_str();
  app.add_option("--refine-at", o->refine_at,
                 "Finer tetrahedra around X,Y,Z (LPS, mm), e.g. where a tool presses; repeat for more places "
                 "(docs/fem.md#a-tool-of-finite-size)");
  app.add_option("--refine-radius", o->refine_radius_mm, "Around each --refine-at: the radius of the fine cells, mm")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--refine-size", o->refine_size_mm,
                 "Around each --refine-at: the fine cells' size, mm (growing 0.3 mm per mm beyond the radius)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--clamp-cells", b.clamp_cells_mm,
                 "The tetrahedra's size over the FEM models' clamp (within 10 mm of the fixed point), mm (0: the "
                 "--tet-size there too; docs/fem.md#the-clamp)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--facet-distance", b.tetrahedra.facet_distance_mm,
                 "Largest distance of a boundary facet from the surface, mm")
      ->capture_default_str();
  app.add_option("--stations", b.beams.stations, "Beam stations (sections per beam)")->capture_default_str();
  app.add_flag("--no-beam-tables", o->no_beam_tables,
               "Bake no beam tables: faster; the model runs every deformation model but the multi-beam one");
  app.add_flag("--no-site-compliance", o->no_site_compliance,
               "Bake no site compliances: the multi-beam and mass-spring models then give their own forces, not the "
               "FEM reference's (docs/matching.md)");
  app.add_option("--site-patch", o->site_patch_mm,
                 "Site compliances: the radius of the surface patch each site's load is spread over, mm (0: twice the "
                 "median boundary edge; docs/matching.md)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_flag("--settle-contacts", b.sites.settle_contacts,
               "Site compliances on the supports: each site's press settles which contacts hold it (those it lifts "
               "carry nothing), as the FEM reference's unilateral contacts do, instead of taking every contact as "
               "pressed; what the fast models on the supports need to match the reference, and slow (a minute or more "
               "on a liver; docs/supports.md)");
  app.add_option("--supports", o->supports,
                 "What the organ rests on and is attached to in the body: ct (found in the CT, the surface against "
                 "tissue rather than air or fat) or none (held by its clamp alone; docs/supports.md)")
      ->check(CLI::IsMember({"ct", "none"}))
      ->capture_default_str();
  app.add_option("--attachment-radius", o->support.attachment_radius_mm,
                 "Supports: the surface against tissue within this distance of the fixed point is attached (bare "
                 "area, ligaments), mm")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--support-depth", o->support.yielding_depth_mm,
                 "Supports: the depth of neighbouring tissue that yields under the organ, mm; the foundation modulus "
                 "is E over it")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--section-samples", b.beams.samples_per_side, "Section sampling grid per side")
      ->capture_default_str();
  app.add_option("--threads", b.beams.threads, "Threads for the beam tables and the site compliances (0: all cores)")
      ->capture_default_str();
  app.add_option("--young-modulus", b.material.young_modulus, "E, Pa")->capture_default_str();
  app.add_option("--poisson-ratio", b.material.poisson_ratio, "nu")->capture_default_str();
  app.add_option("--density", b.material.density, "rho, kg/m³")->capture_default_str();
  app.add_option("--alpha", b.material.attenuation_alpha, "Attenuation base alpha of s' = s / alpha^(beta d)")
      ->capture_default_str();
  app.add_option("--beta", b.material.attenuation_beta, "Attenuation rate beta, 1/m")->capture_default_str();
  app.add_option("--intermediates", b.intermediates_dir,
                 "Also write mask.nii.gz, surface.vtp/.stl and tetrahedra.vtu (LPS, mm) into this directory");
  app.add_flag("--json", o->json, "Print the report as one JSON object on stdout");
}

}  // namespace

Command add_bake_command(CLI::App& app) {
  auto o = std::make_shared<BakeCommandOptions>();
  add_bake_options(app, o);
  return [o] { return run_bake(*o); };
}

std::string bake_report_json(pipeline::BakeOptions options) {
  if (options.output_path.empty()) throw std::runtime_error("bake: no output path; pass the model file to write");
  options.program_version = kProgramVersion;
  const pipeline::BakeResult result = pipeline::bake(options);
  return report_json(result.report, result.model, options.output_path, std::filesystem::file_size(options.output_path))
      .dump();
}

}  // namespace organsim::cli
