#include "organsim/pipeline/seeded_segmentation.h"

#include <itkAndImageFilter.h>
#include <itkBinShrinkImageFilter.h>
#include <itkBinaryFillholeImageFilter.h>
#include <itkBinaryThresholdImageFilter.h>
#include <itkCastImageFilter.h>
#include <itkConnectedComponentImageFilter.h>
#include <itkGradientMagnitudeRecursiveGaussianImageFilter.h>
#include <itkImageRegionConstIterator.h>
#include <itkImageRegionConstIteratorWithIndex.h>
#include <itkImageRegionIterator.h>
#include <itkLinearInterpolateImageFunction.h>
#include <itkMorphologicalWatershedFromMarkersImageFilter.h>
#include <itkResampleImageFilter.h>
#include <itkSignedMaurerDistanceMapImageFilter.h>
#include <itkSliceBySliceImageFilter.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <set>
#include <tuple>
#include <stdexcept>

#include <fmt/format.h>

#include "organsim/pipeline/curvature_diffusion.h"
#include "organsim/pipeline/segmentation.h"

namespace organsim::pipeline {
namespace {

using LabelImage = itk::Image<std::uint32_t, 3>;

constexpr double kMillilitresPerCubicMillimetre = 1e-3;
// ITK's stability limit for curvature anisotropic diffusion in three dimensions.
constexpr double kStableTimeStep = 0.0625;

/// Times the steps into the report.
class StepClock {
 public:
  explicit StepClock(SeededSegmentationReport& report) : report_(report) {}
  void lap(const char* step) {
    const auto now = std::chrono::steady_clock::now();
    report_.step_seconds.emplace_back(step, std::chrono::duration<double>(now - last_).count());
    last_ = now;
  }

 private:
  SeededSegmentationReport& report_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

double voxel_volume_ml(const itk::ImageBase<3>& image) {
  const auto s = image.GetSpacing();
  return s[0] * s[1] * s[2] * kMillilitresPerCubicMillimetre;
}

/// The seed's voxel on the CT grid; one-line error when it is outside.
CtImage::IndexType ct_voxel(const CtImage& ct, const SeedPoint& seed, const char* what) {
  std::array<long, 3> v{};
  if (seed.point_mm) {
    try {
      v = voxel_of_point(ct, *seed.point_mm);
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(fmt::format("{}: {}", what, e.what()));
    }
  } else if (seed.voxel) {
    v = *seed.voxel;
  } else {
    throw std::invalid_argument("a seed has neither a point nor a voxel");
  }
  const auto size = ct.GetLargestPossibleRegion().GetSize();
  for (unsigned k = 0; k < 3; ++k)
    if (v[k] < 0 || v[k] >= static_cast<long>(size[k]))
      throw std::runtime_error(
          fmt::format("{} voxel ({}, {}, {}) lies outside the volume ({}x{}x{} voxels); choose a "
                      "voxel inside the organ",
                      what, v[0], v[1], v[2], size[0], size[1], size[2]));
  CtImage::IndexType index;
  for (unsigned k = 0; k < 3; ++k) index[k] = v[k];
  return index;
}

/// The same physical place on another grid (the working grid holds every CT voxel centre).
template <typename Image>
typename Image::IndexType on_grid(const CtImage& ct, const CtImage::IndexType& index, const Image& grid) {
  CtImage::PointType point;
  ct.TransformIndexToPhysicalPoint(index, point);
  typename Image::IndexType result;
  grid.TransformPhysicalPointToIndex(point, result);
  const auto size = grid.GetLargestPossibleRegion().GetSize();
  for (unsigned k = 0; k < 3; ++k) result[k] = std::clamp<long>(result[k], 0, static_cast<long>(size[k]) - 1);
  return result;
}

/// Calls visit(index) for each voxel whose centre lies within radius_mm of `centre`.
template <typename Image, typename Visit>
void for_each_in_ball(const Image& image, const typename Image::IndexType& centre, double radius_mm, Visit&& visit) {
  const auto spacing = image.GetSpacing();
  const auto size = image.GetLargestPossibleRegion().GetSize();
  long reach[3];
  for (unsigned k = 0; k < 3; ++k) reach[k] = static_cast<long>(std::floor(radius_mm / spacing[k]));
  typename Image::IndexType index;
  for (long dk = -reach[2]; dk <= reach[2]; ++dk)
    for (long dj = -reach[1]; dj <= reach[1]; ++dj)
      for (long di = -reach[0]; di <= reach[0]; ++di) {
        const double x = di * spacing[0], y = dj * spacing[1], z = dk * spacing[2];
        if (x * x + y * y + z * z > radius_mm * radius_mm) continue;
        index[0] = centre[0] + di, index[1] = centre[1] + dj, index[2] = centre[2] + dk;
        bool inside = true;
        for (unsigned k = 0; k < 3; ++k) inside &= index[k] >= 0 && index[k] < static_cast<long>(size[k]);
        if (inside) visit(index);
      }
}

struct RobustStatistics {
  double median = 0.0, sigma = 0.0;  ///< sigma: 1.4826 × median absolute deviation (σ for a normal distribution)
};

RobustStatistics robust_statistics(std::vector<float> values) {
  RobustStatistics s;
  if (values.empty()) return s;
  auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  s.median = *middle;
  for (float& v : values) v = static_cast<float>(std::abs(v - s.median));
  std::nth_element(values.begin(), middle, values.end());
  s.sigma = 1.4826 * *middle;
  return s;
}

/// Below this a seed's neighbourhood reads as fat (HU).
constexpr double kFatBelowHu = -30.0;

/// What a seed's neighbourhood says about where it lies: an organ seed in
/// air, lung, fat or bone is a user error, not a region to grow.
void check_soft_tissue(double median_hu, const std::string& what) {
  if (median_hu < -300.0)
    throw std::runtime_error(
        fmt::format("{} lies in air or lung ({:.0f} HU); place it inside the organ (liver: 20 to "
                    "200 HU)",
                    what, median_hu));
  if (median_hu < kFatBelowHu)
    throw std::runtime_error(
        fmt::format("{} lies in fat ({:.0f} HU); place it inside the organ (liver: 20 to 200 HU)", what, median_hu));
  if (median_hu > 300.0)
    throw std::runtime_error(
        fmt::format("{} lies in bone or a contrast-filled vessel ({:.0f} HU); place it in the "
                    "organ's tissue (liver: 20 to 200 HU)",
                    what, median_hu));
}

MaskImage::Pointer threshold(const FloatImage& image, double low, double high) {
  auto filter = itk::BinaryThresholdImageFilter<FloatImage, MaskImage>::New();
  filter->SetInput(&image);
  filter->SetLowerThreshold(static_cast<float>(low));
  filter->SetUpperThreshold(static_cast<float>(high));
  filter->SetInsideValue(1);
  filter->SetOutsideValue(0);
  filter->Update();
  return filter->GetOutput();
}

/// Euclidean distance (mm) from each voxel to the nearest voxel whose value is
/// not `background`; ≤ 0 on those voxels themselves.
FloatImage::Pointer distance_map(const MaskImage& mask, std::uint8_t background) {
  auto distance = itk::SignedMaurerDistanceMapImageFilter<MaskImage, FloatImage>::New();
  distance->SetInput(&mask);
  distance->SetBackgroundValue(background);
  distance->SetUseImageSpacing(true);
  distance->SetSquaredDistance(false);
  distance->SetInsideIsPositive(false);
  distance->Update();
  return distance->GetOutput();
}

/// Erosion and dilation by a Euclidean ball of radius r mm through distance
/// maps: linear time whatever the radius.
/// `depth`: the mask's distance_map(mask, 1), where it is at hand.
MaskImage::Pointer erode_at_depth(const FloatImage& depth, double radius_mm) {
  // Strictly farther than the radius from the outside: the dual of dilate's "within".
  const float beyond = std::nextafter(static_cast<float>(radius_mm), std::numeric_limits<float>::max());
  return threshold(depth, beyond, std::numeric_limits<float>::max());
}
MaskImage::Pointer erode(const MaskImage& mask, double radius_mm) {
  return erode_at_depth(*distance_map(mask, 1), radius_mm);
}
MaskImage::Pointer dilate(const MaskImage& mask, double radius_mm) {
  return threshold(*distance_map(mask, 0), std::numeric_limits<float>::lowest(), radius_mm);
}

MaskImage::Pointer logical_and(const MaskImage& a, const MaskImage& b) {
  auto filter = itk::AndImageFilter<MaskImage, MaskImage, MaskImage>::New();
  filter->SetInput1(&a);
  filter->SetInput2(&b);
  filter->Update();
  return filter->GetOutput();
}

LabelImage::Pointer components(const MaskImage& mask) {
  auto filter = itk::ConnectedComponentImageFilter<MaskImage, LabelImage>::New();
  filter->SetInput(&mask);
  filter->SetFullyConnected(false);
  filter->Update();
  return filter->GetOutput();
}

/// The components of `mask` that hold a voxel of `indices`.
MaskImage::Pointer components_holding(const MaskImage& mask, const std::vector<MaskImage::IndexType>& indices) {
  const LabelImage::Pointer labels = components(mask);
  std::set<std::uint32_t> wanted;
  for (const auto& index : indices)
    if (const std::uint32_t label = labels->GetPixel(index)) wanted.insert(label);
  auto result = MaskImage::New();
  result->CopyInformation(&mask);
  result->SetRegions(mask.GetLargestPossibleRegion());
  result->Allocate();
  const std::uint32_t* from = labels->GetBufferPointer();
  std::uint8_t* to = result->GetBufferPointer();
  const std::size_t n = mask.GetLargestPossibleRegion().GetNumberOfPixels();
  for (std::size_t i = 0; i < n; ++i) to[i] = from[i] != 0 && wanted.count(from[i]) != 0;
  return result;
}

/// The voxel of `mask` nearest to `index` within radius_mm, if any.
std::optional<MaskImage::IndexType> nearest_set_voxel(const MaskImage& mask, const MaskImage::IndexType& index,
                                                      double radius_mm) {
  std::optional<MaskImage::IndexType> best;
  double best_distance = std::numeric_limits<double>::infinity();
  const auto spacing = mask.GetSpacing();
  for_each_in_ball(mask, index, radius_mm, [&](const MaskImage::IndexType& v) {
    if (!mask.GetPixel(v)) return;
    double d = 0.0;
    for (unsigned k = 0; k < 3; ++k) d += std::pow((v[k] - index[k]) * spacing[k], 2);
    if (d < best_distance) best_distance = d, best = v;
  });
  return best;
}

/// The part of `grown` that is certainly organ: its erosion by the opening
/// radius, the components at (or nearest to) the seeds.
/// `depth`: grown's distance_map(grown, 1), where it is at hand.
MaskImage::Pointer certain_part(const MaskImage& grown, const std::vector<MaskImage::IndexType>& seeds,
                                const SeededSegmentationOptions& o, const FloatImage* depth = nullptr) {
  const MaskImage::Pointer eroded =
      depth ? erode_at_depth(*depth, o.opening_radius_mm) : erode(grown, o.opening_radius_mm);
  std::vector<MaskImage::IndexType> anchors;
  for (const auto& seed : seeds) {
    const auto anchor = nearest_set_voxel(*eroded, seed, 2.0 * o.opening_radius_mm + o.seed_radius_mm);
    if (anchor) anchors.push_back(*anchor);
  }
  if (anchors.empty())
    throw std::runtime_error(fmt::format(
        "the seeds lie in a structure thinner than the leak control's opening ({} mm across); move a seed into the "
        "organ's bulk or lower --opening",
        2.0 * o.opening_radius_mm));
  return components_holding(*eroded, anchors);
}

constexpr std::uint32_t kOrganMarker = 1, kOutsideMarker = 2, kBackgroundSeedMarker = 3;

/// Watershed markers: outside `region` not the organ, inside to decide.
LabelImage::Pointer outside_as_background(const MaskImage& region) {
  auto markers = LabelImage::New();
  markers->CopyInformation(&region);
  markers->SetRegions(region.GetLargestPossibleRegion());
  markers->Allocate();
  const std::uint8_t* r = region.GetBufferPointer();
  std::uint32_t* m = markers->GetBufferPointer();
  const std::size_t n = region.GetLargestPossibleRegion().GetNumberOfPixels();
  for (std::size_t i = 0; i < n; ++i) m[i] = r[i] ? 0u : kOutsideMarker;
  return markers;
}

FloatImage::Pointer gradient_magnitude(const FloatImage& image) {
  auto gradient = itk::GradientMagnitudeRecursiveGaussianImageFilter<FloatImage, FloatImage>::New();
  gradient->SetInput(&image);
  const auto s = image.GetSpacing();
  gradient->SetSigma(std::min({s[0], s[1], s[2]}));
  gradient->Update();
  return gradient->GetOutput();
}

/// Floods the gradient magnitude from the markers: borders fall on the
/// strongest edges between them. Returns the organ markers' voxels and adds
/// the background seeds' voxels to `claimed_by_background`.
MaskImage::Pointer watershed_organ(const FloatImage& gradient, const LabelImage& markers,
                                   MaskImage& claimed_by_background) {
  auto watershed = itk::MorphologicalWatershedFromMarkersImageFilter<FloatImage, LabelImage>::New();
  watershed->SetInput(&gradient);
  watershed->SetMarkerImage(&markers);
  watershed->SetMarkWatershedLine(false);
  watershed->SetFullyConnected(false);
  watershed->Update();
  auto organ = MaskImage::New();
  organ->CopyInformation(&gradient);
  organ->SetRegions(gradient.GetLargestPossibleRegion());
  organ->Allocate();
  const std::uint32_t* label = watershed->GetOutput()->GetBufferPointer();
  std::uint8_t* to = organ->GetBufferPointer();
  std::uint8_t* claimed = claimed_by_background.GetBufferPointer();
  const std::size_t n = gradient.GetLargestPossibleRegion().GetNumberOfPixels();
  for (std::size_t i = 0; i < n; ++i) {
    to[i] = label[i] == kOrganMarker;
    if (label[i] == kBackgroundSeedMarker) claimed[i] = 1;
  }
  return organ;
}

MaskImage::Pointer fill_holes_3d_then_axial(const MaskImage& mask) {
  auto fill = itk::BinaryFillholeImageFilter<MaskImage>::New();
  fill->SetInput(&mask);
  fill->SetForegroundValue(1);
  fill->SetFullyConnected(false);
  using Slice = itk::Image<std::uint8_t, 2>;
  auto fill_slice = itk::BinaryFillholeImageFilter<Slice>::New();
  fill_slice->SetForegroundValue(1);
  fill_slice->SetFullyConnected(false);
  auto by_slice = itk::SliceBySliceImageFilter<MaskImage, MaskImage>::New();
  by_slice->SetInput(fill->GetOutput());
  by_slice->SetFilter(fill_slice);
  by_slice->SetDimension(2);
  by_slice->Update();
  MaskImage::Pointer result = by_slice->GetOutput();
  result->DisconnectPipeline();
  return result;
}

MaskImage::Pointer largest_component(const MaskImage& mask) {
  const LabelImage::Pointer labels = components(mask);
  std::vector<std::size_t> sizes;
  const std::uint32_t* l = labels->GetBufferPointer();
  const std::size_t n = mask.GetLargestPossibleRegion().GetNumberOfPixels();
  for (std::size_t i = 0; i < n; ++i) {
    if (l[i] >= sizes.size()) sizes.resize(l[i] + 1, 0);
    ++sizes[l[i]];
  }
  std::uint32_t largest = 0;
  for (std::uint32_t label = 1; label < sizes.size(); ++label)
    if (sizes[label] > (largest ? sizes[largest] : 0)) largest = label;
  auto result = MaskImage::New();
  result->CopyInformation(&mask);
  result->SetRegions(mask.GetLargestPossibleRegion());
  result->Allocate();
  std::uint8_t* to = result->GetBufferPointer();
  for (std::size_t i = 0; i < n; ++i) to[i] = largest != 0 && l[i] == largest;
  return result;
}

/// The working-grid mask on the CT's grid: linear interpolation of the mask
/// as a fraction, cut at one half, over the organ's bounding box only.
MaskImage::Pointer onto_ct_grid(const MaskImage& working, const CtImage& ct) {
  auto fraction = itk::CastImageFilter<MaskImage, FloatImage>::New();
  fraction->SetInput(&working);
  fraction->Update();

  // The organ's box on the CT grid, one working voxel wider on each side.
  const MaskImage::RegionType box = organ_bounding_box(working, {1, 1, 1});
  MaskImage::IndexType low = box.GetIndex(), high;
  for (unsigned k = 0; k < 3; ++k) high[k] = low[k] + static_cast<long>(box.GetSize(k)) - 1;
  CtImage::PointType p_low, p_high;
  working.TransformIndexToPhysicalPoint(low, p_low);
  working.TransformIndexToPhysicalPoint(high, p_high);
  CtImage::IndexType c_low, c_high;
  ct.TransformPhysicalPointToIndex(p_low, c_low);
  ct.TransformPhysicalPointToIndex(p_high, c_high);
  const auto size = ct.GetLargestPossibleRegion().GetSize();
  CtImage::RegionType region;
  for (unsigned k = 0; k < 3; ++k) {
    const long a = std::clamp<long>(std::min(c_low[k], c_high[k]), 0, static_cast<long>(size[k]) - 1);
    const long b = std::clamp<long>(std::max(c_low[k], c_high[k]), 0, static_cast<long>(size[k]) - 1);
    region.SetIndex(k, a);
    region.SetSize(k, static_cast<itk::SizeValueType>(b - a + 1));
  }

  auto resample = itk::ResampleImageFilter<FloatImage, FloatImage>::New();
  resample->SetInput(fraction->GetOutput());
  resample->SetInterpolator(itk::LinearInterpolateImageFunction<FloatImage, double>::New());
  resample->SetOutputOrigin(ct.GetOrigin());
  resample->SetOutputSpacing(ct.GetSpacing());
  resample->SetOutputDirection(ct.GetDirection());
  resample->SetOutputStartIndex(region.GetIndex());
  resample->SetSize(region.GetSize());
  resample->SetDefaultPixelValue(0.0f);
  resample->Update();

  auto result = MaskImage::New();
  result->CopyInformation(&ct);
  result->SetRegions(ct.GetLargestPossibleRegion());
  result->Allocate(true);
  itk::ImageRegionConstIterator<FloatImage> from(resample->GetOutput(), region);
  itk::ImageRegionIterator<MaskImage> to(result, region);
  for (; !from.IsAtEnd(); ++from, ++to) to.Set(from.Get() >= 0.5f ? 1 : 0);
  return result;
}

/// The dents of `organ` that lesions and vessels at its surface leave: what a
/// closing by the lesion radius adds within the lesion and vessel HU range, by
/// connected pieces. A piece joins the organ when the organ encloses it (that
/// fraction of its border faces touch the organ) and most of it lies outside
/// the organ's HU window (a piece of tissue inside the window was cut off on
/// purpose, by leak control or a background seed). A gallbladder or a
/// bowel loop in a fossa borders the organ on one side only.
MaskImage::Pointer with_enclosed_dents(const MaskImage& organ, const FloatImage& image, const MaskImage& window,
                                       const MaskImage& claimed_by_background, const SeededSegmentationOptions& o) {
  const MaskImage::Pointer closed = erode(*dilate(organ, o.lesion_radius_mm), o.lesion_radius_mm);
  const MaskImage::Pointer tissue = threshold(image, o.lesion_low_hu, o.vessel_high_hu);
  auto candidates = MaskImage::New();
  candidates->CopyInformation(&organ);
  candidates->SetRegions(organ.GetLargestPossibleRegion());
  candidates->Allocate();
  const std::size_t n = organ.GetLargestPossibleRegion().GetNumberOfPixels();
  {
    const std::uint8_t *in_organ = organ.GetBufferPointer(), *in_closed = closed->GetBufferPointer(),
                       *in_tissue = tissue->GetBufferPointer(), *claimed = claimed_by_background.GetBufferPointer();
    std::uint8_t* c = candidates->GetBufferPointer();
    for (std::size_t i = 0; i < n; ++i) c[i] = in_closed[i] && !in_organ[i] && in_tissue[i] && !claimed[i];
  }
  const LabelImage::Pointer labels = components(*candidates);
  const std::uint32_t* label = labels->GetBufferPointer();
  const std::uint8_t* in_organ = organ.GetBufferPointer();
  const std::uint8_t* in_window = window.GetBufferPointer();
  std::vector<std::size_t> touching_organ, border, voxels, window_voxels;
  const auto size = organ.GetLargestPossibleRegion().GetSize();
  const long nx = static_cast<long>(size[0]), ny = static_cast<long>(size[1]), nz = static_cast<long>(size[2]);
  const long stride[3] = {1, nx, nx * ny};
  for (long k = 0; k < nz; ++k)
    for (long j = 0; j < ny; ++j)
      for (long i = 0; i < nx; ++i) {
        const long at = (k * ny + j) * nx + i;
        const std::uint32_t l = label[at];
        if (l == 0) continue;
        if (l >= border.size())
          border.resize(l + 1, 0), touching_organ.resize(l + 1, 0), voxels.resize(l + 1, 0),
              window_voxels.resize(l + 1, 0);
        ++voxels[l];
        window_voxels[l] += in_window[at] != 0;
        const long index[3] = {i, j, k}, extent[3] = {nx, ny, nz};
        for (int axis = 0; axis < 3; ++axis)
          for (const long step : {-1L, 1L}) {
            const long next = index[axis] + step;
            if (next < 0 || next >= extent[axis]) {
              ++border[l];
              continue;
            }
            const long neighbour = at + step * stride[axis];
            if (label[neighbour] == l) continue;
            ++border[l];
            touching_organ[l] += in_organ[neighbour] != 0;
          }
      }
  auto result = MaskImage::New();
  result->CopyInformation(&organ);
  result->SetRegions(organ.GetLargestPossibleRegion());
  result->Allocate();
  std::uint8_t* to = result->GetBufferPointer();
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t l = label[i];
    to[i] = in_organ[i] ||
            (l != 0 && static_cast<double>(touching_organ[l]) >= o.lesion_enclosure * static_cast<double>(border[l]) &&
             2 * window_voxels[l] < voxels[l]);
  }
  return result;
}

}  // namespace

std::pair<std::size_t, std::size_t> border_and_organ_slices(const MaskImage& mask) {
  const auto size = mask.GetLargestPossibleRegion().GetSize();
  const long nx = static_cast<long>(size[0]), ny = static_cast<long>(size[1]), nz = static_cast<long>(size[2]);
  const std::uint8_t* v = mask.GetBufferPointer();
  std::size_t border = 0, organ = 0;
  for (long k = 0; k < nz; ++k) {
    const std::uint8_t* slice = v + k * nx * ny;
    bool any = false, touches = false;
    for (long j = 0; j < ny; ++j)
      for (long i = 0; i < nx; ++i)
        if (slice[j * nx + i]) {
          any = true;
          touches |= i == 0 || j == 0 || i == nx - 1 || j == ny - 1;
        }
    organ += any;
    border += touches;
  }
  return {border, organ};
}

std::vector<std::string> liver_plausibility_warnings(double volume_ml, std::size_t border_slices,
                                                     std::size_t organ_slices) {
  std::vector<std::string> warnings;
  if (volume_ml < 600.0 || volume_ml > 3500.0)
    warnings.push_back(fmt::format(
        "the organ is {:.0f} mL; an adult liver is 0.6 to 3.5 L: check the mask (--intermediates), add seeds or "
        "background seeds, or use a label map",
        volume_ml));
  if (border_slices * 10 > organ_slices && border_slices >= 3)
    warnings.push_back(fmt::format(
        "the organ touches the side of the volume on {} of its {} slices: it is cut off by the field of view, or the "
        "segmentation leaked into the body wall",
        border_slices, organ_slices));
  return warnings;
}

/// A mask of zeros on `grid`'s grid.
MaskImage::Pointer empty_mask_like(const itk::ImageBase<3>& grid) {
  auto mask = MaskImage::New();
  mask->CopyInformation(&grid);
  mask->SetRegions(grid.GetLargestPossibleRegion());
  mask->Allocate(true);
  return mask;
}

/// The voxels of `a` that are not in `b`.
MaskImage::Pointer without(const MaskImage& a, const MaskImage& b) {
  auto result = MaskImage::New();
  result->CopyInformation(&a);
  result->SetRegions(a.GetLargestPossibleRegion());
  result->Allocate();
  const std::uint8_t *x = a.GetBufferPointer(), *y = b.GetBufferPointer();
  std::uint8_t* to = result->GetBufferPointer();
  const std::size_t n = a.GetLargestPossibleRegion().GetNumberOfPixels();
  for (std::size_t i = 0; i < n; ++i) to[i] = x[i] && !y[i];
  return result;
}

/// The pieces of `cut` (left out of `organ`), each described for the user:
/// volume, HU, the neck it was joined by, its box and its deepest point.
struct CutPieces {
  LabelImage::Pointer labels;       ///< each piece's voxels, label k + 1 for piece k
  std::vector<CutRegion> pieces;    ///< by label; empty pieces have volume 0
  std::vector<bool> holds_claimed;  ///< by label: it holds a voxel of `claimed` (a background seed's)
};

/// `window_depth`: mm from each voxel to the nearest voxel outside the
/// window's region (distance_map(grown, 1)): the thickness of the tissue, of
/// the neck, and each piece's deepest voxel (where a seed takes it back).
CutPieces cut_pieces(const MaskImage& cut, const MaskImage& organ, const FloatImage& image,
                     const FloatImage& window_depth, const MaskImage* claimed = nullptr) {
  CutPieces result;
  result.labels = components(cut);
  struct Piece {
    std::size_t voxels = 0;
    MaskImage::IndexType low, high, deepest;
    float deepest_depth = -1.0f, neck_depth = 0.0f;
    double contact_mm2 = 0.0, surface_mm2 = 0.0;
    std::vector<float> values, neck_values;
    bool holds_claimed = false;
  };
  std::vector<Piece> pieces;
  const auto region = cut.GetLargestPossibleRegion();
  const auto spacing = cut.GetSpacing();
  const double face_mm2[3] = {spacing[1] * spacing[2], spacing[0] * spacing[2], spacing[0] * spacing[1]};
  itk::ImageRegionConstIteratorWithIndex<LabelImage> it(result.labels, region);
  for (; !it.IsAtEnd(); ++it) {
    const std::uint32_t label = it.Get();
    if (label == 0) continue;
    if (pieces.size() < label) pieces.resize(label);
    Piece& p = pieces[label - 1];
    const MaskImage::IndexType index = it.GetIndex();
    if (p.voxels++ == 0) p.low = p.high = index;
    for (unsigned k = 0; k < 3; ++k) p.low[k] = std::min(p.low[k], index[k]), p.high[k] = std::max(p.high[k], index[k]);
    const float value = image.GetPixel(index);
    p.values.push_back(value);
    if (claimed && claimed->GetPixel(index)) p.holds_claimed = true;
    if (const float d = window_depth.GetPixel(index); d > p.deepest_depth) p.deepest_depth = d, p.deepest = index;
    bool at_neck = false;
    for (unsigned k = 0; k < 3; ++k)
      for (const long step : {-1L, 1L}) {
        MaskImage::IndexType next = index;
        next[k] += step;
        if (!region.IsInside(next) || !cut.GetPixel(next)) p.surface_mm2 += face_mm2[k];
        if (region.IsInside(next) && organ.GetPixel(next)) {
          p.contact_mm2 += face_mm2[k];
          p.neck_values.push_back(image.GetPixel(next));
          at_neck = true;
        }
      }
    if (at_neck) p.neck_values.push_back(value), p.neck_depth = std::max(p.neck_depth, window_depth.GetPixel(index));
  }
  const double voxel_ml = voxel_volume_ml(cut);
  for (Piece& p : pieces) {
    CutRegion r;
    result.holds_claimed.push_back(p.holds_claimed);
    if (p.voxels == 0) {
      result.pieces.push_back(r);
      continue;
    }
    r.volume_ml = static_cast<double>(p.voxels) * voxel_ml;
    const RobustStatistics hu = robust_statistics(std::move(p.values));
    r.median_hu = hu.median;
    r.sigma_hu = hu.sigma;
    r.neck_width_mm = 2.0 * std::sqrt(p.contact_mm2 / M_PI);
    r.neck_thickness_mm = 2.0 * p.neck_depth;
    r.contact_fraction = p.contact_mm2 / p.surface_mm2;
    if (!p.neck_values.empty()) r.neck_median_hu = robust_statistics(std::move(p.neck_values)).median;
    r.depth_mm = p.deepest_depth;
    r.box_low_mm = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity()};
    r.box_high_mm = {-r.box_low_mm[0], -r.box_low_mm[1], -r.box_low_mm[2]};
    for (int corner = 0; corner < 8; ++corner) {
      MaskImage::IndexType index;
      for (unsigned k = 0; k < 3; ++k) index[k] = (corner >> k) & 1 ? p.high[k] : p.low[k];
      CtImage::PointType point;
      cut.TransformIndexToPhysicalPoint(index, point);
      for (unsigned k = 0; k < 3; ++k)
        r.box_low_mm[k] = std::min(r.box_low_mm[k], point[k]), r.box_high_mm[k] = std::max(r.box_high_mm[k], point[k]);
    }
    CtImage::PointType seed;
    cut.TransformIndexToPhysicalPoint(p.deepest, seed);
    r.seed_mm = {seed[0], seed[1], seed[2]};
    result.pieces.push_back(r);
  }
  return result;
}

/// The pieces of `cut` (left out of `organ` for `cause`) of at least `minimum_ml`.
/// A piece that holds a voxel of `claimed` (a background seed's) says so as
/// why it was kept out.
std::vector<CutRegion> describe_cut(const MaskImage& cut, const MaskImage& organ, const FloatImage& image,
                                    const FloatImage& window_depth, const char* cause, double minimum_ml,
                                    const MaskImage* claimed = nullptr) {
  std::vector<CutRegion> described;
  CutPieces pieces = cut_pieces(cut, organ, image, window_depth, claimed);
  for (std::size_t k = 0; k < pieces.pieces.size(); ++k) {
    CutRegion& r = pieces.pieces[k];
    if (!(r.volume_ml > 0.0 && r.volume_ml >= minimum_ml)) continue;
    r.cause = cause;
    if (pieces.holds_claimed[k]) r.kept_out_because = "a background seed lies in it";
    described.push_back(r);
  }
  return described;
}

/// The voxels of `region` that an organ seed reaches (in 6-connected steps
/// through the region) in no more steps than every background seed: the
/// organ's by distance. Voxels the organ's seeds cannot reach are not.
MaskImage::Pointer nearer_to_organ(const MaskImage& region, const std::vector<MaskImage::IndexType>& organ_seeds,
                                   const std::vector<MaskImage::IndexType>& background_seeds) {
  const auto whole = region.GetLargestPossibleRegion();
  const auto size = whole.GetSize();
  const std::size_t n = whole.GetNumberOfPixels();
  const std::uint8_t* inside = region.GetBufferPointer();
  std::vector<std::uint8_t> owner(n, 0);  // 0 unreached, 1 organ, 2 background
  const auto offset = [&](const MaskImage::IndexType& i) {
    return static_cast<std::size_t>(i[0]) +
           size[0] * (static_cast<std::size_t>(i[1]) + size[1] * static_cast<std::size_t>(i[2]));
  };
  std::vector<std::size_t> organ_front, background_front;
  for (const auto& seed : organ_seeds)
    if (whole.IsInside(seed) && owner[offset(seed)] == 0) owner[offset(seed)] = 1, organ_front.push_back(offset(seed));
  for (const auto& seed : background_seeds)
    if (whole.IsInside(seed) && owner[offset(seed)] == 0)
      owner[offset(seed)] = 2, background_front.push_back(offset(seed));
  const long steps[3] = {1, static_cast<long>(size[0]), static_cast<long>(size[0] * size[1])};
  // Level by level, the organ's front first: a voxel both reach in as many steps is the organ's.
  while (!organ_front.empty() || !background_front.empty()) {
    std::vector<std::size_t> next_organ, next_background;
    for (auto [front, next, mine] : {std::tuple{&organ_front, &next_organ, std::uint8_t{1}},
                                     std::tuple{&background_front, &next_background, std::uint8_t{2}}})
      for (const std::size_t at : *front) {
        const std::size_t x = at % size[0], y = (at / size[0]) % size[1], z = at / (size[0] * size[1]);
        const std::size_t coordinate[3] = {x, y, z};
        for (unsigned k = 0; k < 3; ++k)
          for (const int direction : {-1, 1}) {
            if ((direction < 0 && coordinate[k] == 0) || (direction > 0 && coordinate[k] + 1 == size[k])) continue;
            const std::size_t neighbour = at + direction * steps[k];
            if (owner[neighbour] != 0 || !inside[neighbour]) continue;
            owner[neighbour] = mine;
            next->push_back(neighbour);
          }
      }
    organ_front.swap(next_organ);
    background_front.swap(next_background);
  }
  auto nearer = MaskImage::New();
  nearer->CopyInformation(&region);
  nearer->SetRegions(whole);
  nearer->Allocate();
  std::uint8_t* to = nearer->GetBufferPointer();
  for (std::size_t i = 0; i < n; ++i) to[i] = owner[i] == 1;
  return nearer;
}

/// The least HU spread a match is judged against (a CT smoothed flat).
constexpr double kMatchSigmaFloorHu = 2.0;

std::string why_not_taken_back(const CutRegion& piece, double core_median_hu, double core_sigma_hu, double organ_ml,
                               const SeededSegmentationOptions& o) {
  // Within the core's own robust σ (of the smoothed CT, not floored as the
  // window's is): on a CT without contrast a muscle lies 10 to 15 HU below
  // the liver, 1.4 σ on the shipped CT, where the window's floor would let it in.
  const double sigma = std::max(core_sigma_hu, kMatchSigmaFloorHu);
  if (std::abs(piece.median_hu - core_median_hu) > sigma)
    return fmt::format("its HU is not the organ core's ({:.0f} against {:.0f} ± {:.0f})", piece.median_hu,
                       core_median_hu, sigma);
  if (piece.sigma_hu > 1.5 * sigma)
    return fmt::format("its HU spreads more than the organ core's (robust sigma {:.0f} against {:.0f})", piece.sigma_hu,
                       sigma);
  // A leak runs through a bridge of partial volume one or two voxels across;
  // a neck as thick as the opening radius is tissue, not a bridge.
  if (piece.neck_thickness_mm < o.opening_radius_mm)
    return fmt::format("its neck ({:.1f} mm thick) is thinner than the opening radius ({:.1f} mm): it may be a leak",
                       piece.neck_thickness_mm, o.opening_radius_mm);
  // Two organs that touch meet at a fat plane or a partial-volume dip; the
  // organ's tissue running through a neck has none.
  if (piece.neck_median_hu < core_median_hu - sigma)
    return fmt::format("its neck is darker than the organ ({:.0f} HU): an interface between two structures",
                       piece.neck_median_hu);
  // A lobe hangs from the organ by its neck; a muscle or an organ that lies
  // along it touches it over a large part of its surface.
  if (piece.contact_fraction > 0.1)
    return fmt::format("it lies along the organ ({:.0f} % of its surface touches it), not behind a neck",
                       100.0 * piece.contact_fraction);
  // A lobe survives the opening itself; a wall (the stomach's, the diaphragm)
  // or a sheet of muscle does not.
  if (piece.depth_mm <= o.opening_radius_mm)
    return fmt::format("it is thinner than the opening's diameter ({:.0f} mm thick at most): a wall, not a lobe",
                       2.0 * piece.depth_mm);
  if (piece.volume_ml > organ_ml)
    return fmt::format("it is larger than the organ kept ({:.0f} against {:.0f} mL)", piece.volume_ml, organ_ml);
  return {};
}

SeededSegmentation segment_from_seeds(const CtImage& ct, const SeededSegmentationOptions& o) {
  if (o.seeds.empty()) throw std::runtime_error("no seed: give at least one point inside the organ (--seed X,Y,Z)");
  if (o.hu_window && !(o.hu_window->first < o.hu_window->second))
    throw std::runtime_error(fmt::format("HU window {},{} is empty; give LOW,HIGH with LOW < HIGH", o.hu_window->first,
                                         o.hu_window->second));
  if (!(o.opening_radius_mm >= 0.0 && o.reach_mm >= 0.0 && o.closing_radius_mm >= 0.0 && o.lesion_radius_mm >= 0.0 &&
        o.seed_radius_mm > 0.0 && o.window_sigmas_below > 0.0 && o.window_sigmas_above > 0.0 &&
        o.discovery_sigmas_above > 0.0 && o.working_spacing_mm >= 0.0 && o.smoothing_iterations >= 0))
    throw std::runtime_error("segmentation radii, the window width and the working spacing must be non-negative");

  SeededSegmentation result;
  SeededSegmentationReport& report = result.report;
  StepClock clock(report);

  std::vector<CtImage::IndexType> seeds, background;
  for (std::size_t s = 0; s < o.seeds.size(); ++s)
    seeds.push_back(ct_voxel(ct, o.seeds[s], fmt::format("seed {}", s + 1).c_str()));
  for (std::size_t s = 0; s < o.background_seeds.size(); ++s)
    background.push_back(ct_voxel(ct, o.background_seeds[s], fmt::format("background seed {}", s + 1).c_str()));

  // 1. Working grid.
  // Straight from the CT's int16: BinShrink sums in double either way (an
  // int16 and its float are the same double), so the working grid is the
  // same as from a float copy of the CT, without that copy (twice the CT).
  auto shrink = itk::BinShrinkImageFilter<CtImage, FloatImage>::New();
  shrink->SetInput(&ct);
  for (unsigned k = 0; k < 3; ++k) {
    const double spacing = ct.GetSpacing()[k];
    const unsigned factor = o.working_spacing_mm > 0.0
                                ? std::max(1u, static_cast<unsigned>(std::floor(o.working_spacing_mm / spacing + 1e-6)))
                                : 1u;
    shrink->SetShrinkFactor(k, factor);
  }
  shrink->Update();
  FloatImage::Pointer image = shrink->GetOutput();
  for (unsigned k = 0; k < 3; ++k) report.working_spacing_mm[k] = image->GetSpacing()[k];
  clock.lap("working grid");

  // 2. Smoothing.
  if (o.smoothing_iterations > 0) {
    CurvatureDiffusionOptions diffusion;
    diffusion.iterations = static_cast<unsigned>(o.smoothing_iterations);
    diffusion.time_step = kStableTimeStep;
    diffusion.conductance = o.smoothing_conductance;
    image = curvature_diffusion(*image, diffusion);
  }
  clock.lap("smoothing");

  // 3. The window.
  // A seed that reads as fat but not below a lesion's darkest inside, given
  // beside a seed in the organ's tissue, was put in a hypodense lesion (on a
  // CT without contrast a lesion 80 HU below the parenchyma's 45 HU): it
  // marks a lesion to take into the organ, and stays out of the window's
  // statistics. Alone, or darker, it is the user error it looks like.
  std::vector<FloatImage::IndexType> work_seeds, work_background, work_lesions;
  std::vector<float> pooled;
  std::vector<std::pair<std::string, RobustStatistics>> lesion_like;
  for (std::size_t s = 0; s < seeds.size(); ++s) {
    const FloatImage::IndexType at = on_grid(ct, seeds[s], *image);
    std::vector<float> values;
    for_each_in_ball(*image, at, o.seed_radius_mm,
                     [&](const FloatImage::IndexType& v) { values.push_back(image->GetPixel(v)); });
    const RobustStatistics local = robust_statistics(values);
    const std::string what = fmt::format("seed {}", s + 1);
    if (o.hu_window) {
      if (local.median < o.hu_window->first || local.median > o.hu_window->second)
        throw std::runtime_error(
            fmt::format("{} lies at {:.0f} HU, outside the window {},{}; move the seed into the "
                        "organ or widen --hu-window",
                        what, local.median, o.hu_window->first, o.hu_window->second));
    } else if (local.median < kFatBelowHu && local.median >= o.lesion_low_hu && o.lesion_radius_mm > 0.0) {
      lesion_like.emplace_back(what, local);
      work_lesions.push_back(at);
      continue;
    } else {
      check_soft_tissue(local.median, what);
    }
    work_seeds.push_back(at);
    pooled.insert(pooled.end(), values.begin(), values.end());
  }
  if (work_seeds.empty())  // every seed reads as fat: that is what the user is told
    for (const auto& [what, local] : lesion_like) check_soft_tissue(local.median, what);
  report.lesion_seeds = work_lesions.size();
  for (const auto& b : background) work_background.push_back(on_grid(ct, b, *image));
  const RobustStatistics statistics = robust_statistics(pooled);
  report.seed_median_hu = statistics.median;
  report.seed_sigma_hu = statistics.sigma;
  report.window_given = o.hu_window.has_value();
  const auto window_from = [&](const RobustStatistics& st, double sigmas_above) {
    const double sigma = std::max(st.sigma, o.minimum_sigma_hu);
    report.hu_low = st.median - o.window_sigmas_below * sigma;
    report.hu_high = st.median + sigmas_above * sigma;
  };
  if (o.hu_window) {
    report.hu_low = o.hu_window->first, report.hu_high = o.hu_window->second;
  } else {
    // The first window reaches higher than the final one: a seed in a part of
    // the organ that enhances less (the posterior liver in a portal phase is
    // 30 HU darker) must still find the brighter rest.
    window_from(statistics, o.opening_radius_mm > 0.0 ? std::max(o.discovery_sigmas_above, o.window_sigmas_above)
                                                      : o.window_sigmas_above);
    // A seed's neighbourhood sees a few centimetres of an organ whose HU
    // drifts across it (enhancement, beam hardening) or a darker patch
    // (a vessel, a lesion): the window is taken again from the organ's
    // certain part that the first window finds.
    if (o.opening_radius_mm > 0.0) {
      const MaskImage::Pointer first =
          components_holding(*threshold(*image, report.hu_low, report.hu_high), work_seeds);
      if (count_voxels(*first) > 0) {
        const MaskImage::Pointer certain = certain_part(*first, work_seeds, o);
        std::vector<float> values;
        const std::uint8_t* c = certain->GetBufferPointer();
        const float* v = image->GetBufferPointer();
        const std::size_t n = certain->GetLargestPossibleRegion().GetNumberOfPixels();
        for (std::size_t i = 0; i < n; ++i)
          if (c[i]) values.push_back(v[i]);
        const RobustStatistics organ = robust_statistics(std::move(values));
        report.organ_median_hu = organ.median;
        report.organ_sigma_hu = organ.sigma;
        window_from(organ, o.window_sigmas_above);
      }
    }
  }
  MaskImage::Pointer window = threshold(*image, report.hu_low, report.hu_high);
  const double working_voxel_ml = voxel_volume_ml(*image);
  clock.lap("window");

  // 4. Background seeds take their share of the window. Their markers are
  // small (a background seed is often put in a thin structure); the organ's
  // markers are its opened region less the reach, less what lies near a
  // background seed (a bridge thicker than the opening can carry the heart into it).
  const MaskImage::Pointer claimed_by_background = empty_mask_like(*image);
  const auto spacing = image->GetSpacing();
  const double background_marker_radius_mm = 1.01 * std::max({spacing[0], spacing[1], spacing[2]});
  const auto mark_background_seeds = [&](LabelImage& markers) {
    for (const auto& b : work_background)
      for_each_in_ball(*image, b, background_marker_radius_mm,
                       [&](const FloatImage::IndexType& v) { markers.SetPixel(v, kBackgroundSeedMarker); });
  };
  MaskImage::Pointer joined_before_split;  // the window's region at the seeds before the background took its share
  if (!work_background.empty()) {
    joined_before_split = components_holding(*window, work_seeds);
    const std::size_t before = count_voxels(*window);
    auto markers = outside_as_background(*window);
    const MaskImage::Pointer grown = components_holding(*window, work_seeds);
    if (o.opening_radius_mm > 0.0 && count_voxels(*grown) > 0) {
      // The organ's markers reach to within the leak control's reach of its
      // border (the opened organ less that margin), not only to its certain
      // core: a 10 mm shell left undecided let the background flood the
      // organ up to the first ridge inside it (a lesion's enhancing rim), and
      // cost the contrast series up to 0.0076 of Dice.
      MaskImage::Pointer certain = certain_part(*grown, work_seeds, o);
      if (o.opening_radius_mm > o.reach_mm)
        certain = logical_and(*dilate(*certain, o.opening_radius_mm - o.reach_mm), *grown);
      const double keep_away_mm = 2.0 * o.opening_radius_mm;
      itk::ImageRegionConstIteratorWithIndex<MaskImage> it(certain, certain->GetLargestPossibleRegion());
      for (; !it.IsAtEnd(); ++it) {
        if (!it.Get()) continue;
        bool near_background = false;
        for (const auto& b : work_background) {
          double d2 = 0.0;
          for (unsigned k = 0; k < 3; ++k) d2 += std::pow((it.GetIndex()[k] - b[k]) * spacing[k], 2);
          near_background |= d2 < keep_away_mm * keep_away_mm;
        }
        if (!near_background) markers->SetPixel(it.GetIndex(), kOrganMarker);
      }
    }
    for (const auto& f : work_seeds)
      for_each_in_ball(*image, f, o.seed_radius_mm / 2.0, [&](const FloatImage::IndexType& v) {
        if (window->GetPixel(v)) markers->SetPixel(v, kOrganMarker);
      });
    mark_background_seeds(*markers);
    const MaskImage::Pointer whole_window = window;
    window = watershed_organ(*gradient_magnitude(*image), *markers, *claimed_by_background);
    // The split takes only what lies nearer to a background seed than to the
    // organ's seeds through the window: its watershed may run along an edge
    // deep into the organ (a lobe behind a fissure), which stays the organ's
    // to decide (leak control still does).
    {
      const MaskImage::Pointer nearer = nearer_to_organ(*whole_window, work_seeds, work_background);
      std::uint8_t* claimed = claimed_by_background->GetBufferPointer();
      std::uint8_t* in_window = window->GetBufferPointer();
      const std::uint8_t *was_window = whole_window->GetBufferPointer(), *near_organ = nearer->GetBufferPointer();
      const std::size_t n = window->GetLargestPossibleRegion().GetNumberOfPixels();
      for (std::size_t i = 0; i < n; ++i)
        if (was_window[i] && !in_window[i] && near_organ[i]) claimed[i] = 0, in_window[i] = 1;
    }
    report.background_split_ml = static_cast<double>(before - count_voxels(*window)) * working_voxel_ml;
    clock.lap("background seeds");
  }

  // 5. Leak control.
  const MaskImage::Pointer grown = components_holding(*window, work_seeds);
  const std::size_t grown_voxels = count_voxels(*grown);
  if (grown_voxels == 0)
    throw std::runtime_error("the seeds are not inside the HU window's region; move them into the organ");
  report.grown_ml = static_cast<double>(grown_voxels) * working_voxel_ml;
  MaskImage::Pointer organ = grown;
  // How deep each voxel lies in the window's region: the opening's erosion,
  // and the thickness of what it cuts.
  const FloatImage::Pointer window_depth = distance_map(*grown, 1);
  if (o.opening_radius_mm > 0.0) {
    // The organ's certain part: the eroded region at the seeds. Everything
    // farther than the opening radius plus the reach from it, or outside the
    // window, is certainly not the organ; the watershed on the gradient puts
    // the border in between on the strongest edge.
    const MaskImage::Pointer certain = certain_part(*grown, work_seeds, o, window_depth.GetPointer());
    const MaskImage::Pointer possible = logical_and(*dilate(*certain, o.opening_radius_mm + o.reach_mm), *grown);
    auto markers = outside_as_background(*possible);
    {
      const std::uint8_t* c = certain->GetBufferPointer();
      std::uint32_t* m = markers->GetBufferPointer();
      const std::size_t n = certain->GetLargestPossibleRegion().GetNumberOfPixels();
      for (std::size_t i = 0; i < n; ++i)
        if (c[i]) m[i] = kOrganMarker;
    }
    // Background seeds next to the organ (a muscle it touches, the vena
    // cava in it) compete for the undecided rim too.
    mark_background_seeds(*markers);
    organ = watershed_organ(*gradient_magnitude(*image), *markers, *claimed_by_background);
  }
  // The organ core's HU: what a cut piece is compared with.
  const bool core_known = report.organ_sigma_hu > 0.0;
  const double core_median = core_known ? report.organ_median_hu : report.seed_median_hu;
  const double core_sigma = core_known ? report.organ_sigma_hu : report.seed_sigma_hu;
  // The opening cuts a lobe joined through a neck narrower than its diameter
  // as it cuts a leak; the neck rule gives back what is the organ's own tissue.
  MaskImage::Pointer taken_back;
  if (o.opening_radius_mm > 0.0 && o.take_back_lobes) {
    const CutPieces cut =
        cut_pieces(*without(*grown, *organ), *organ, *image, *window_depth, claimed_by_background.GetPointer());
    const double organ_ml = static_cast<double>(count_voxels(*organ)) * working_voxel_ml;
    std::vector<bool> take(cut.pieces.size() + 1, false);
    for (std::size_t k = 0; k < cut.pieces.size(); ++k) {
      CutRegion piece = cut.pieces[k];
      if (piece.volume_ml <= 0.0 || piece.volume_ml < o.reported_cut_ml || cut.holds_claimed[k]) continue;
      piece.cause = "leak control";
      piece.like_organ = true;
      if (!why_not_taken_back(piece, core_median, core_sigma, organ_ml, o).empty()) continue;
      take[k + 1] = true;
      report.taken_back.push_back(piece);
    }
    if (!report.taken_back.empty()) {
      taken_back = empty_mask_like(*grown);
      const std::uint32_t* label = cut.labels->GetBufferPointer();
      std::uint8_t *into = organ->GetBufferPointer(), *given = taken_back->GetBufferPointer();
      const std::size_t n = organ->GetLargestPossibleRegion().GetNumberOfPixels();
      for (std::size_t i = 0; i < n; ++i)
        if (label[i] && take[label[i]]) into[i] = given[i] = 1;
      std::stable_sort(report.taken_back.begin(), report.taken_back.end(),
                       [](const CutRegion& a, const CutRegion& b) { return a.volume_ml > b.volume_ml; });
    }
  }
  report.cut_by_opening_ml = static_cast<double>(grown_voxels - count_voxels(*organ)) * working_voxel_ml;
  clock.lap("leak control");

  // 6. Holes, notches, one piece, the CT's grid.
  organ = fill_holes_3d_then_axial(*organ);
  if (o.closing_radius_mm > 0.0) organ = erode(*dilate(*organ, o.closing_radius_mm), o.closing_radius_mm);
  if (o.lesion_radius_mm > 0.0) {
    const std::size_t before = count_voxels(*organ);
    organ = with_enclosed_dents(*organ, *image, *threshold(*image, report.hu_low, report.hu_high),
                                *claimed_by_background, o);
    report.enclosed_dents_ml = static_cast<double>(count_voxels(*organ) - before) * working_voxel_ml;
  }
  // A lesion seed's lesion: the region darker than the window but not fat
  // that holds the seed, within the lesion radius of it (so that it cannot
  // run along a dark neighbour: the gallbladder, the stomach's fluid).
  if (!work_lesions.empty()) {
    const std::size_t before = count_voxels(*organ);
    const MaskImage::Pointer dark = threshold(*image, o.lesion_low_hu, report.hu_low);
    const MaskImage::Pointer near_seed = empty_mask_like(*image);
    for (const auto& l : work_lesions)
      for_each_in_ball(*image, l, o.lesion_radius_mm,
                       [&](const FloatImage::IndexType& v) { near_seed->SetPixel(v, 1); });
    const MaskImage::Pointer lesions = components_holding(*logical_and(*dark, *near_seed), work_lesions);
    std::uint8_t* v = organ->GetBufferPointer();
    const std::uint8_t* l = lesions->GetBufferPointer();
    const std::size_t n = organ->GetLargestPossibleRegion().GetNumberOfPixels();
    for (std::size_t i = 0; i < n; ++i) v[i] = v[i] || l[i];
    report.lesion_seed_ml = static_cast<double>(count_voxels(*organ) - before) * working_voxel_ml;
  }
  organ = fill_holes_3d_then_axial(*organ);
  // What the background seeds claimed stays out, even where it is a hole (the vena cava).
  {
    std::uint8_t* v = organ->GetBufferPointer();
    const std::uint8_t* c = claimed_by_background->GetBufferPointer();
    const std::size_t n = organ->GetLargestPossibleRegion().GetNumberOfPixels();
    for (std::size_t i = 0; i < n; ++i) v[i] = v[i] && !c[i];
  }
  // The pieces holding the seeds (a lobe the user seeded apart from the rest,
  // cut from it at its neck, is theirs to keep); the largest piece where no
  // seed lies in the organ.
  {
    const MaskImage::Pointer seeded = components_holding(*organ, work_seeds);
    organ = count_voxels(*seeded) > 0 ? seeded : largest_component(*organ);
  }
  clock.lap("holes and closing");

  // What was left out of the window's region at the seeds, for the user to
  // judge (and to take back with a seed where it is organ).
  const MaskImage::Pointer cut = without(*grown, *organ);
  const MaskImage::Pointer given =
      joined_before_split ? without(*without(*joined_before_split, *window), *organ) : MaskImage::Pointer();
  report.cut_regions = describe_cut(*cut, *organ, *image, *window_depth, "leak control", o.reported_cut_ml,
                                    claimed_by_background.GetPointer());
  if (given)
    for (CutRegion& r : describe_cut(*given, *organ, *image, *distance_map(*joined_before_split, 1), "background seed",
                                     o.reported_cut_ml))
      report.cut_regions.push_back(r);
  {
    const double organ_ml = static_cast<double>(count_voxels(*organ)) * working_voxel_ml;
    for (CutRegion& r : report.cut_regions) {
      r.like_organ = std::abs(r.median_hu - core_median) <= 2.0 * std::max(core_sigma, o.minimum_sigma_hu);
      if (r.cause == "background seed") r.kept_out_because = "a background seed is nearer";
      if (r.kept_out_because.empty()) r.kept_out_because = why_not_taken_back(r, core_median, core_sigma, organ_ml, o);
      // It passes the tests now, on the organ's final shape (holes filled), not
      // on the shape leak control judged it on.
      if (r.kept_out_because.empty())
        r.kept_out_because = "it failed the neck rule on the organ before its holes were filled";
    }
  }
  std::stable_sort(report.cut_regions.begin(), report.cut_regions.end(),
                   [](const CutRegion& a, const CutRegion& b) { return a.volume_ml > b.volume_ml; });
  clock.lap("what was cut");

  const bool shrunk = image->GetSpacing() != ct.GetSpacing();
  result.mask = shrunk ? onto_ct_grid(*organ, ct) : organ;
  if (!shrunk) result.mask->CopyInformation(&ct);
  clock.lap("CT grid");

  if (o.explain) {
    // Each class on the CT's grid as the organ is put there; the organ wins.
    const auto on_ct = [&](const MaskImage::Pointer& mask) {
      if (!mask) return MaskImage::Pointer();
      if (count_voxels(*mask) == 0) return MaskImage::Pointer();
      if (shrunk) return onto_ct_grid(*mask, ct);
      mask->CopyInformation(&ct);
      return mask;
    };
    const MaskImage::Pointer cut_on_ct = on_ct(cut), given_on_ct = on_ct(given), taken_back_on_ct = on_ct(taken_back);
    const MaskImage::Pointer labels = empty_mask_like(ct);
    std::uint8_t* to = labels->GetBufferPointer();
    const std::uint8_t* organ_on_ct = result.mask->GetBufferPointer();
    const std::size_t n = ct.GetLargestPossibleRegion().GetNumberOfPixels();
    for (std::size_t i = 0; i < n; ++i) {
      if (organ_on_ct[i])
        to[i] = taken_back_on_ct && taken_back_on_ct->GetBufferPointer()[i] ? kTakenBack : kOrgan;
      else if (cut_on_ct && cut_on_ct->GetBufferPointer()[i])
        to[i] = kCutByLeakControl;
      else if (given_on_ct && given_on_ct->GetBufferPointer()[i])
        to[i] = kGivenToBackground;
    }
    result.explanation = labels;
    clock.lap("explanation");
  }

  report.voxels = count_voxels(*result.mask);
  report.volume_ml = static_cast<double>(report.voxels) * voxel_volume_ml(ct);
  if (report.voxels < o.minimum_voxels)
    throw std::runtime_error(fmt::format("the segmentation has only {} voxels (at least {} expected); check the seeds",
                                         report.voxels, o.minimum_voxels));
  const auto [border, slices] = border_and_organ_slices(*result.mask);
  report.border_slices = border;
  report.warnings = liver_plausibility_warnings(report.volume_ml, border, slices);
  return result;
}

}  // namespace organsim::pipeline
