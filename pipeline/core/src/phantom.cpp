#include "organsim/pipeline/phantom.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace organsim::pipeline {
namespace {

using Vec = std::array<double, 3>;

// The anatomy below is laid out for a 384 × 312 × 192 mm field of view and
// scaled down uniformly for smaller ones.
constexpr Vec kReferenceFieldOfViewMm{384.0, 312.0, 192.0};

double length(const Vec& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

/// Approximate signed distance to an ellipsoid (exact on the axes, smooth
/// everywhere), mm.
double ellipsoid_distance(const Vec& p, const Vec& centre, const Vec& radii) {
  const Vec q{(p[0] - centre[0]) / radii[0], (p[1] - centre[1]) / radii[1], (p[2] - centre[2]) / radii[2]};
  return (length(q) - 1.0) * std::min({radii[0], radii[1], radii[2]});
}

/// Polynomial smooth minimum: unions two shapes with a fillet of width k.
double smooth_min(double a, double b, double k) {
  const double h = std::clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0);
  return b + (a - b) * h - k * h * (1.0 - h);
}

/// Signed distance (mm, reference anatomy) to the liver: right lobe, left lobe
/// and caudate lobe, smoothly united, with a low-frequency bumpy surface.
double liver_distance(const Vec& p) {
  const double right = ellipsoid_distance(p, {-65.0, 5.0, 0.0}, {65.0, 65.0, 70.0});
  const double left = ellipsoid_distance(p, {15.0, -30.0, 25.0}, {70.0, 32.0, 38.0});
  const double caudate = ellipsoid_distance(p, {-40.0, 25.0, -45.0}, {38.0, 26.0, 30.0});
  const double lobes = smooth_min(smooth_min(right, left, 12.0), caudate, 10.0);
  const double bumps = 4.0 * std::sin(p[0] / 23.0 + 1.0) * std::sin(p[1] / 19.0) * std::sin(p[2] / 29.0 + 0.5);
  return lobes + bumps;
}

// Portal vein: a capsule from below the liver into the right lobe.
constexpr Vec kVeinStart{-20.0, 20.0, -110.0};
constexpr Vec kVeinEnd{-45.0, 10.0, -10.0};
constexpr double kVeinRadius = 7.0;

double segment_distance(const Vec& p, const Vec& a, const Vec& b) {
  const Vec ab{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const Vec ap{p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  const double t = std::clamp(
      (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / (ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]), 0.0, 1.0);
  return length({ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]});
}

/// Hounsfield value of everything but the liver and the portal vein at a
/// reference-anatomy point.
double background_hu(const Vec& p) {
  const double body = std::hypot(p[0] / 170.0, p[1] / 125.0);
  if (body >= 1.0) return -1000.0;  // air
  const double wall = std::hypot(p[0] / 158.0, p[1] / 113.0);
  if (wall >= 1.0) return -100.0;  // subcutaneous fat
  // Lower ribs: 10 mm thick hoops every 30 mm inside the anterior and lateral wall.
  const bool rib_level = p[2] > -40.0 && std::fmod(p[2] + 400.0, 30.0) < 10.0;
  if (wall >= 0.94 && wall < 0.99 && p[1] < 40.0 && rib_level) return 650.0;
  if (wall >= 0.93) return 50.0;  // muscle
  const double vertebra = std::hypot(p[0], p[1] - 75.0);
  if (vertebra < 20.0) return vertebra > 16.0 ? 800.0 : 350.0;    // cortical rim, cancellous core
  if (std::hypot(p[0] - 15.0, p[1] - 50.0) < 11.0) return 180.0;  // contrast-filled aorta
  if (ellipsoid_distance(p, {-75.0, 85.0, -70.0}, {22.0, 15.0, 40.0}) < 0.0) return 30.0;  // kidney
  return -100.0;                                                                           // visceral fat
}

/// Deterministic standard normal numbers on every platform (std::normal_distribution
/// is not specified bit-for-bit).
class GaussianNoise {
 public:
  explicit GaussianNoise(std::uint64_t seed) : engine_(seed) {}
  double next() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }

 private:
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

void check_options(const PhantomOptions& o) {
  std::uint64_t voxels = 1;
  for (int k = 0; k < 3; ++k) {
    if (o.size[k] < 16)
      throw std::invalid_argument("phantom size must be at least 16 voxels along each axis (got " +
                                  std::to_string(o.size[k]) + ")");
    if (!(std::isfinite(o.spacing_mm[k]) && o.spacing_mm[k] > 0.0))
      throw std::invalid_argument("phantom spacing must be positive millimetres along each axis");
    voxels *= o.size[k];
  }
  if (voxels > (std::uint64_t{1} << 31))
    throw std::invalid_argument("phantom has " + std::to_string(voxels) +
                                " voxels, more than the 2^31 supported; reduce --size");
  if (!(std::isfinite(o.noise_sigma_hu) && o.noise_sigma_hu >= 0.0))
    throw std::invalid_argument("phantom noise must be zero or a positive number of HU");
}

template <typename ImageType>
typename ImageType::Pointer allocate(const PhantomOptions& o, const Vec& origin) {
  auto image = ImageType::New();
  typename ImageType::RegionType region;
  typename ImageType::SpacingType spacing;
  typename ImageType::PointType image_origin;
  for (unsigned k = 0; k < 3; ++k) {
    region.SetSize(k, o.size[k]);
    spacing[k] = o.spacing_mm[k];
    image_origin[k] = origin[k];
  }
  image->SetRegions(region);
  image->SetSpacing(spacing);
  image->SetOrigin(image_origin);  // direction: identity (LPS axes)
  image->Allocate();
  return image;
}

}  // namespace

Phantom make_phantom(const PhantomOptions& o) {
  check_options(o);
  Vec origin{};
  double scale = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double field_of_view = o.size[k] * o.spacing_mm[k];
    origin[k] = -0.5 * (o.size[k] - 1) * o.spacing_mm[k];
    scale = std::min(scale, field_of_view / kReferenceFieldOfViewMm[k]);
  }
  Phantom phantom;
  phantom.ct = allocate<CtImage>(o, origin);
  phantom.liver_mask = allocate<MaskImage>(o, origin);

  // Partial-volume width: the liver edge blends over about one voxel.
  const double blend_mm = (o.spacing_mm[0] + o.spacing_mm[1] + o.spacing_mm[2]) / 3.0;
  GaussianNoise noise(o.seed);
  std::int16_t* ct = phantom.ct->GetBufferPointer();
  std::uint8_t* mask = phantom.liver_mask->GetBufferPointer();
  std::size_t liver_voxels = 0;
  std::size_t index = 0;
  for (unsigned k = 0; k < o.size[2]; ++k)
    for (unsigned j = 0; j < o.size[1]; ++j)
      for (unsigned i = 0; i < o.size[0]; ++i, ++index) {
        const Vec physical{origin[0] + i * o.spacing_mm[0], origin[1] + j * o.spacing_mm[1],
                           origin[2] + k * o.spacing_mm[2]};
        const Vec p{physical[0] / scale, physical[1] / scale, physical[2] / scale};
        const double liver_mm = liver_distance(p) * scale;
        const double liver_fraction = std::clamp(0.5 - liver_mm / blend_mm, 0.0, 1.0);
        // Gentle parenchymal texture so the organ is not a flat plateau.
        const double liver_hu = 55.0 + 5.0 * std::sin(p[0] / 17.0) * std::cos(p[2] / 13.0);
        double hu = liver_fraction * liver_hu + (1.0 - liver_fraction) * background_hu(p);
        if (segment_distance(p, kVeinStart, kVeinEnd) < kVeinRadius) hu = 180.0;
        if (hu > -1000.0) hu += o.noise_sigma_hu * noise.next();
        ct[index] = static_cast<std::int16_t>(std::lround(std::clamp(hu, -1024.0, 3071.0)));
        mask[index] = liver_mm < 0.0 ? 1 : 0;
        liver_voxels += mask[index];
      }
  phantom.liver_volume_ml = liver_voxels * o.spacing_mm[0] * o.spacing_mm[1] * o.spacing_mm[2] / 1000.0;

  // The vein starts outside the liver and ends inside: bisect for the crossing.
  double outside = 0.0, inside = 1.0;
  auto vein_point = [](double t) {
    return Vec{kVeinStart[0] + t * (kVeinEnd[0] - kVeinStart[0]), kVeinStart[1] + t * (kVeinEnd[1] - kVeinStart[1]),
               kVeinStart[2] + t * (kVeinEnd[2] - kVeinStart[2])};
  };
  for (int iteration = 0; iteration < 60; ++iteration) {
    const double t = 0.5 * (outside + inside);
    (liver_distance(vein_point(t)) > 0.0 ? outside : inside) = t;
  }
  const Vec crossing = vein_point(0.5 * (outside + inside));
  phantom.fixed_point_mm = {crossing[0] * scale, crossing[1] * scale, crossing[2] * scale};
  return phantom;
}

}  // namespace organsim::pipeline
