#include "organsim/pipeline/bake.h"

#include <itkImageRegionConstIteratorWithIndex.h>
#include <itkRegionOfInterestImageFilter.h>
#include <itkSignedMaurerDistanceMapImageFilter.h>

#include <openssl/evp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>

#include <fmt/format.h>

#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/mesh_io.h"
#include "organsim/pipeline/segmentation.h"

namespace organsim::pipeline {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMetresPerMillimetre = 1e-3;
constexpr double kMillilitresPerCubicMetre = 1e6;

std::string format_triple(const std::array<double, 3>& v) { return fmt::format("{},{},{}", v[0], v[1], v[2]); }
std::string format_triple(const std::array<long, 3>& v) { return fmt::format("{},{},{}", v[0], v[1], v[2]); }

/// Times the stages and tells the progress callback about them.
class StageClock {
 public:
  StageClock(const BakeProgress& progress, BakeReport& report) : progress_(progress), report_(report) {}
  template <typename Work>
  auto run(const std::string& stage, Work&& work) {
    notify(stage, 0.0);
    const auto start = std::chrono::steady_clock::now();
    if constexpr (std::is_void_v<decltype(work())>) {
      work();
      finish(stage, start);
    } else {
      auto result = work();
      finish(stage, start);
      return result;
    }
  }
  void notify(const std::string& stage, double fraction) const {
    if (progress_) progress_(stage, fraction);
  }

 private:
  void finish(const std::string& stage, std::chrono::steady_clock::time_point start) {
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    report_.stage_seconds.emplace_back(stage, seconds);
    report_.total_seconds += seconds;
    notify(stage, 1.0);
  }
  const BakeProgress& progress_;
  BakeReport& report_;
};

void check_options(const BakeOptions& o) {
  const bool label = !o.label_path.empty(), seed = o.seed_mm || o.seed_voxel;
  if (label && seed) throw std::runtime_error("give either --label or a seed (--seed/--seed-voxel), not both");
  if (!label && !seed)
    throw std::runtime_error(
        "no segmentation: give --label MASK (a label map) or --seed X,Y,Z / --seed-voxel I,J,K (region growing)");
  if (o.seed_mm && o.seed_voxel) throw std::runtime_error("give either --seed or --seed-voxel, not both");
  if (o.fixed_point_mm && o.fixed_point_voxel)
    throw std::runtime_error("give either --fixed-point or --fixed-point-voxel, not both");
  if (!(o.hu_low < o.hu_high))
    throw std::runtime_error(fmt::format("--hu-window {},{} is empty; give LOW,HIGH with LOW < HIGH", o.hu_low, o.hu_high));
  const Material& m = o.material;
  if (!(std::isfinite(m.young_modulus) && m.young_modulus > 0.0))
    throw std::runtime_error(fmt::format("--young-modulus must be a positive number of pascals (got {})", m.young_modulus));
  if (!(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5))
    throw std::runtime_error(fmt::format("--poisson-ratio must lie in (-1, 0.5) (got {})", m.poisson_ratio));
  if (!(std::isfinite(m.density) && m.density > 0.0))
    throw std::runtime_error(fmt::format("--density must be a positive number of kg/m³ (got {})", m.density));
  if (!(std::isfinite(m.attenuation_alpha) && m.attenuation_alpha > 0.0))
    throw std::runtime_error(fmt::format("--alpha must be positive (got {})", m.attenuation_alpha));
  if (!(std::isfinite(m.attenuation_beta) && m.attenuation_beta >= 0.0))
    throw std::runtime_error(fmt::format("--beta must be a non-negative number per metre (got {})", m.attenuation_beta));
  if (o.beams.stations < 1 || o.beams.stations > 4096)
    throw std::runtime_error(fmt::format("--stations must lie in 1..4096 (got {})", o.beams.stations));
  if (o.surface.target_vertices < 100)
    throw std::runtime_error(fmt::format("--surface-vertices must be at least 100 (got {})", o.surface.target_vertices));
}

MaskImage::Pointer segment(const CtImage& ct, const BakeOptions& o, BakeReport& report) {
  MaskImage::Pointer mask;
  if (!o.label_path.empty()) {
    mask = clean_mask(*read_label_mask(o.label_path, o.label_value, ct), o.closing_radius_mm.value_or(0.0));
    report.segmentation = fmt::format("label map (value {})", o.label_value);
  } else {
    RegionGrowingOptions growing;
    growing.seed_voxel = o.seed_voxel ? *o.seed_voxel : voxel_of_point(ct, *o.seed_mm);
    growing.hu_low = o.hu_low;
    growing.hu_high = o.hu_high;
    growing.closing_radius_mm = o.closing_radius_mm.value_or(3.0);
    growing.minimum_voxels = o.minimum_voxels;
    mask = segment_by_region_growing(ct, growing);
    report.segmentation = fmt::format("region growing from voxel ({}) in [{}, {}] HU", format_triple(growing.seed_voxel),
                                      o.hu_low, o.hu_high);
  }
  report.mask_voxels = count_voxels(*mask);
  if (report.mask_voxels < o.minimum_voxels)
    throw std::runtime_error(fmt::format(
        "the segmentation has only {} voxels (fewer than {}); check the label value or the seed and HU window",
        report.mask_voxels, o.minimum_voxels));
  const auto spacing = mask->GetSpacing();
  report.mask_volume_ml = static_cast<double>(report.mask_voxels) * spacing[0] * spacing[1] * spacing[2] * 1e-3;
  return mask;
}

std::array<double, 3> to_array(const itk::Point<double, 3>& p) { return {p[0], p[1], p[2]}; }

/// A fixed point "on" the organ may sit in the notch where a vessel enters
/// (the portal vein is excluded from a liver mask), so a little way outside.
constexpr double kFixedPointToleranceMm = 10.0;

/// Distance (mm) from `point` to the nearest organ voxel centre, 0 inside;
/// any value above `limit` means "farther than limit".
double distance_to_organ_mm(const MaskImage& mask, const std::array<double, 3>& point, double limit) {
  itk::Point<double, 3> physical;
  for (unsigned k = 0; k < 3; ++k) physical[k] = point[k];
  itk::ContinuousIndex<double, 3> centre;
  mask.TransformPhysicalPointToContinuousIndex(physical, centre);
  const auto size = mask.GetLargestPossibleRegion().GetSize();
  const auto spacing = mask.GetSpacing();
  long low[3], high[3];
  for (unsigned k = 0; k < 3; ++k) {
    low[k] = std::max(0L, static_cast<long>(std::floor(centre[k] - limit / spacing[k])));
    high[k] = std::min(static_cast<long>(size[k]) - 1, static_cast<long>(std::ceil(centre[k] + limit / spacing[k])));
  }
  double nearest = std::numeric_limits<double>::infinity();
  MaskImage::IndexType index;
  for (index[2] = low[2]; index[2] <= high[2]; ++index[2])
    for (index[1] = low[1]; index[1] <= high[1]; ++index[1])
      for (index[0] = low[0]; index[0] <= high[0]; ++index[0]) {
        if (!mask.GetPixel(index)) continue;
        double d2 = 0.0;
        for (unsigned k = 0; k < 3; ++k) d2 += std::pow((index[k] - centre[k]) * spacing[k], 2);
        nearest = std::min(nearest, std::sqrt(d2));
      }
  return nearest;
}

/// The fixed point (mm) from the options, checked to lie in or on the organ.
std::array<double, 3> choose_fixed_point(const MaskImage& mask, const BakeOptions& o, BakeReport& report) {
  if (!o.fixed_point_mm && !o.fixed_point_voxel) {
    const auto [point, depth] = deepest_interior_point(mask);
    report.fixed_point_source = "deepest interior point";
    report.fixed_point_depth_mm = depth;
    return point;
  }
  std::array<double, 3> point{};
  if (o.fixed_point_voxel) {
    const auto& v = *o.fixed_point_voxel;
    const auto size = mask.GetLargestPossibleRegion().GetSize();
    for (unsigned k = 0; k < 3; ++k)
      if (v[k] < 0 || v[k] >= static_cast<long>(size[k]))
        throw std::runtime_error(fmt::format("--fixed-point-voxel {} is outside the image ({}×{}×{} voxels)",
                                             format_triple(v), size[0], size[1], size[2]));
    MaskImage::IndexType index;
    for (unsigned k = 0; k < 3; ++k) index[k] = v[k];
    itk::Point<double, 3> physical;
    mask.TransformIndexToPhysicalPoint(index, physical);
    point = to_array(physical);
    report.fixed_point_source = "given voxel";
  } else {
    point = *o.fixed_point_mm;
    report.fixed_point_source = "given point";
  }
  const double distance = distance_to_organ_mm(mask, point, kFixedPointToleranceMm);
  if (distance > kFixedPointToleranceMm)
    throw std::runtime_error(fmt::format(
        "the fixed point ({}) mm lies more than {} mm outside the organ; give a point in or on the segmented organ, or "
        "omit it to use the deepest interior point",
        format_triple(point), kFixedPointToleranceMm));
  report.fixed_point_outside_mm = distance;
  return point;
}

/// Where an intermediate goes: `name` in the intermediates directory (created
/// on first use), or "" when the user did not ask for intermediates.
std::string intermediate_path(const std::string& directory, const char* name) {
  if (directory.empty()) return "";
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error)
    throw std::runtime_error(fmt::format("cannot create the intermediates directory '{}': {}", directory, error.message()));
  return (std::filesystem::path(directory) / name).string();
}

std::map<std::string, std::string> provenance_parameters(const BakeOptions& o, const BakeReport& report) {
  std::map<std::string, std::string> p;
  p["segmentation"] = report.segmentation;
  p["closing_radius_mm"] = fmt::format("{}", o.closing_radius_mm.value_or(o.label_path.empty() ? 3.0 : 0.0));
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
  p["mesh_optimization"] = o.tetrahedra.optimize ? "lloyd+exude" : "none";
  p["stations"] = fmt::format("{}", o.beams.stations);
  p["section_samples_per_side"] = fmt::format("{}", o.beams.samples_per_side);
  return p;
}

}  // namespace

std::string image_sha256(const CtImage& ct) {
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
  if (!context || EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("cannot compute SHA-256: OpenSSL failed to initialise");
  std::vector<unsigned char> bytes;
  auto put_u64 = [&](std::uint64_t v) {
    for (int b = 0; b < 8; ++b) bytes.push_back(static_cast<unsigned char>(v >> (8 * b)));
  };
  auto put_f64 = [&](double v) {
    std::uint64_t u;
    std::memcpy(&u, &v, sizeof u);
    put_u64(u);
  };
  const auto size = ct.GetLargestPossibleRegion().GetSize();
  for (unsigned k = 0; k < 3; ++k) put_u64(size[k]);
  for (unsigned k = 0; k < 3; ++k) put_f64(ct.GetSpacing()[k]);
  for (unsigned k = 0; k < 3; ++k) put_f64(ct.GetOrigin()[k]);
  for (unsigned r = 0; r < 3; ++r)
    for (unsigned c = 0; c < 3; ++c) put_f64(ct.GetDirection()[r][c]);
  EVP_DigestUpdate(context.get(), bytes.data(), bytes.size());
  // Voxels in chunks, little-endian whatever the host.
  const std::int16_t* voxels = ct.GetBufferPointer();
  const std::size_t count = size[0] * size[1] * size[2];
  std::vector<unsigned char> chunk;
  for (std::size_t start = 0; start < count; start += 1 << 16) {
    const std::size_t end = std::min(count, start + (std::size_t{1} << 16));
    chunk.resize(2 * (end - start));
    for (std::size_t i = start; i < end; ++i) {
      const auto u = static_cast<std::uint16_t>(voxels[i]);
      chunk[2 * (i - start)] = static_cast<unsigned char>(u & 0xff);
      chunk[2 * (i - start) + 1] = static_cast<unsigned char>(u >> 8);
    }
    EVP_DigestUpdate(context.get(), chunk.data(), chunk.size());
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned length = 0;
  EVP_DigestFinal_ex(context.get(), digest, &length);
  std::string hex;
  for (unsigned i = 0; i < length; ++i) hex += fmt::format("{:02x}", digest[i]);
  return hex;
}

std::pair<std::array<double, 3>, double> deepest_interior_point(const MaskImage& mask) {
  // The distance map is computed on the organ's bounding box (plus a margin of
  // one voxel, so the boundary is seen): a liver fills a fraction of a CT.
  const MaskImage::RegionType box = organ_bounding_box(mask, {1, 1, 1});
  auto crop = itk::RegionOfInterestImageFilter<MaskImage, MaskImage>::New();
  crop->SetInput(&mask);
  crop->SetRegionOfInterest(box);
  using DistanceImage = itk::Image<float, 3>;
  auto distance = itk::SignedMaurerDistanceMapImageFilter<MaskImage, DistanceImage>::New();
  distance->SetInput(crop->GetOutput());
  distance->SetUseImageSpacing(true);
  distance->SetSquaredDistance(false);
  // The organ is the filter's "background" and the voxels outside it are the
  // object: an organ voxel's (positive) value is then its distance to the
  // nearest voxel outside the organ. (With the organ as the object, the inside
  // values measured to its contour came out up to 2 voxels short.)
  distance->SetInsideIsPositive(false);
  distance->SetBackgroundValue(1);
  distance->SetNumberOfWorkUnits(1);  // the same result on every machine
  distance->Update();
  const DistanceImage& map = *distance->GetOutput();
  itk::ImageRegionConstIteratorWithIndex<DistanceImage> at(&map, map.GetLargestPossibleRegion());
  float deepest = -std::numeric_limits<float>::infinity();
  DistanceImage::IndexType best{};
  for (; !at.IsAtEnd(); ++at)
    if (at.Get() > deepest) deepest = at.Get(), best = at.GetIndex();
  itk::Point<double, 3> point;
  map.TransformIndexToPhysicalPoint(best, point);
  return {to_array(point), static_cast<double>(deepest)};
}

std::vector<TexCoord> spherical_texture_coordinates(const std::vector<Point3>& vertices) {
  Point3 centre{0.0, 0.0, 0.0};
  for (const Point3& v : vertices)
    for (int k = 0; k < 3; ++k) centre[k] += v[k] / static_cast<double>(vertices.size());
  std::vector<TexCoord> coordinates;
  coordinates.reserve(vertices.size());
  for (const Point3& v : vertices) {
    const double x = v[0] - centre[0], y = v[1] - centre[1], z = v[2] - centre[2];
    const double r = std::sqrt(x * x + y * y + z * z);
    if (r == 0.0) {
      coordinates.push_back({0.5, 0.5});
      continue;
    }
    coordinates.push_back({0.5 + std::atan2(y, x) / (2.0 * kPi), std::acos(std::clamp(z / r, -1.0, 1.0)) / kPi});
  }
  return coordinates;
}

BakeResult bake(const BakeOptions& o, const BakeProgress& progress) {
  check_options(o);
  BakeResult result;
  BakeReport& report = result.report;
  StageClock clock(progress, report);

  const CtImage::Pointer ct = clock.run("read CT", [&] { return read_ct(o.ct_path, o.series_uid); });
  const auto size = ct->GetLargestPossibleRegion().GetSize();
  for (unsigned k = 0; k < 3; ++k) report.image_size[k] = size[k], report.image_spacing_mm[k] = ct->GetSpacing()[k];

  // Intermediates are written as soon as they exist, so that a later failure
  // (say, meshing) leaves them for inspection.
  const MaskImage::Pointer mask = clock.run("segment", [&] {
    MaskImage::Pointer segmented = segment(*ct, o, report);
    if (const std::string path = intermediate_path(o.intermediates_dir, "mask.nii.gz"); !path.empty())
      write_mask_image(*segmented, path);
    return segmented;
  });
  report.fixed_point_mm = clock.run("fixed point", [&] { return choose_fixed_point(*mask, o, report); });
  const SurfaceMesh surface = clock.run("surface", [&] {
    SurfaceMesh extracted = extract_surface(*mask, o.surface);
    if (const std::string path = intermediate_path(o.intermediates_dir, "surface.vtp"); !path.empty()) {
      write_surface_vtp(extracted, path);
      write_surface_stl(extracted, intermediate_path(o.intermediates_dir, "surface.stl"));
    }
    return extracted;
  });
  report.surface_vertices = surface.vertices.size();
  report.surface_triangles = surface.triangles.size();
  report.surface_area_cm2 = surface_area(surface) * 1e4;
  report.surface_volume_ml = enclosed_volume(surface) * kMillilitresPerCubicMetre;

  const TetrahedralMesh tetrahedra = clock.run("tetrahedra", [&] {
    TetrahedralMesh meshed = make_tetrahedra(surface, o.tetrahedra);
    if (const std::string path = intermediate_path(o.intermediates_dir, "tetrahedra.vtu"); !path.empty())
      write_tetrahedra_vtu(meshed, path);
    return meshed;
  });
  report.tetrahedra = measure_quality(tetrahedra);
  report.volume_vertices = tetrahedra.vertices.size();
  report.tetrahedra_volume_ml = report.tetrahedra.total_volume_m3 * kMillilitresPerCubicMetre;

  const Point3 fixed_point_m{report.fixed_point_mm[0] * kMetresPerMillimetre,
                             report.fixed_point_mm[1] * kMetresPerMillimetre,
                             report.fixed_point_mm[2] * kMetresPerMillimetre};
  OrganModel& model = result.model;
  model.beams = clock.run("beam tables", [&] {
    return bake_beam_tables(*mask, surface.vertices, fixed_point_m, o.beams,
                            [&](double fraction) { clock.notify("beam tables", fraction); });
  });
  report.stations = model.beams.stations_per_beam;
  report.beam_sections = model.beams.sections.size();

  clock.run("assemble", [&] {
    model.provenance.coordinate_frame = "LPS";
    model.provenance.program_version = o.program_version;
    model.provenance.input_sha256 = image_sha256(*ct);
    model.provenance.parameters = provenance_parameters(o, report);
    model.surface_vertices = surface.vertices;
    model.surface_triangles = surface.triangles;
    model.surface_texcoords = spherical_texture_coordinates(surface.vertices);
    model.volume_vertices = tetrahedra.vertices;
    model.tetrahedra = tetrahedra.tetrahedra;
    model.fixed_points = {fixed_point_m};
    model.material = o.material;
    const std::string problem = validate_organ_model(model);
    if (!problem.empty()) throw std::runtime_error("the baked model is not valid: " + problem);
  });
  return result;
}

}  // namespace organsim::pipeline
