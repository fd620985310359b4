#include "organsim/pipeline/segmentation.h"

#include <itkBinaryBallStructuringElement.h>
#include <itkBinaryFillholeImageFilter.h>
#include <itkBinaryMorphologicalClosingImageFilter.h>
#include <itkBinaryThresholdImageFilter.h>
#include <itkConnectedComponentImageFilter.h>
#include <itkConstantPadImageFilter.h>
#include <itkImageRegionConstIterator.h>
#include <itkImageRegionIterator.h>
#include <itkRegionOfInterestImageFilter.h>
#include <itkRelabelComponentImageFilter.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include <fmt/format.h>

namespace organsim::pipeline {
namespace {

MaskImage::Pointer fill_holes(const MaskImage& mask) {
  auto fill = itk::BinaryFillholeImageFilter<MaskImage>::New();
  fill->SetInput(&mask);
  fill->SetForegroundValue(1);
  fill->SetFullyConnected(false);
  fill->Update();
  return fill->GetOutput();
}

MaskImage::Pointer close(const MaskImage& mask, double radius_mm) {
  using Ball = itk::BinaryBallStructuringElement<std::uint8_t, 3>;
  Ball ball;
  Ball::SizeType radius;
  for (unsigned k = 0; k < 3; ++k)
    radius[k] = static_cast<itk::SizeValueType>(std::lround(radius_mm / mask.GetSpacing()[k]));
  // A radius below half a voxel closes nothing; the caller's mask is already hole-filled.
  if (radius[0] + radius[1] + radius[2] == 0) return fill_holes(mask);
  ball.SetRadius(radius);
  ball.CreateStructuringElement();
  // Pad first so that closing does not glue the organ to the volume border.
  auto pad = itk::ConstantPadImageFilter<MaskImage, MaskImage>::New();
  pad->SetInput(&mask);
  pad->SetPadBound(radius);
  pad->SetConstant(0);
  auto closing = itk::BinaryMorphologicalClosingImageFilter<MaskImage, MaskImage, Ball>::New();
  closing->SetInput(pad->GetOutput());
  closing->SetKernel(ball);
  closing->SetForegroundValue(1);
  auto crop = itk::RegionOfInterestImageFilter<MaskImage, MaskImage>::New();
  crop->SetInput(closing->GetOutput());
  crop->SetRegionOfInterest(mask.GetLargestPossibleRegion());
  crop->Update();
  MaskImage::Pointer result = crop->GetOutput();
  result->CopyInformation(&mask);
  return result;
}

MaskImage::Pointer largest_component(const MaskImage& mask) {
  using LabelImage = itk::Image<std::uint32_t, 3>;
  auto components = itk::ConnectedComponentImageFilter<MaskImage, LabelImage>::New();
  components->SetInput(&mask);
  components->SetFullyConnected(false);
  auto relabel = itk::RelabelComponentImageFilter<LabelImage, LabelImage>::New();
  relabel->SetInput(components->GetOutput());  // label 1 is the largest
  auto select = itk::BinaryThresholdImageFilter<LabelImage, MaskImage>::New();
  select->SetInput(relabel->GetOutput());
  select->SetLowerThreshold(1);
  select->SetUpperThreshold(1);
  select->SetInsideValue(1);
  select->SetOutsideValue(0);
  select->Update();
  return select->GetOutput();
}

}  // namespace

MaskImage::RegionType organ_bounding_box(const MaskImage& mask, const std::array<long, 3>& margin) {
  const MaskImage::RegionType full = mask.GetLargestPossibleRegion();
  const long nx = static_cast<long>(full.GetSize(0)), ny = static_cast<long>(full.GetSize(1)),
             nz = static_cast<long>(full.GetSize(2));
  long lower[3] = {nx, ny, nz}, upper[3] = {-1, -1, -1};
  const std::uint8_t* v = mask.GetBufferPointer();
  for (long k = 0; k < nz; ++k)
    for (long j = 0; j < ny; ++j) {
      const std::uint8_t* row = v + (k * ny + j) * nx;
      const std::uint8_t* first = std::find_if(row, row + nx, [](std::uint8_t x) { return x != 0; });
      if (first == row + nx) continue;
      const std::uint8_t* last = std::find_if(std::make_reverse_iterator(row + nx), std::make_reverse_iterator(row),
                                              [](std::uint8_t x) { return x != 0; })
                                     .base() -
                                 1;
      lower[0] = std::min(lower[0], static_cast<long>(first - row)),
      upper[0] = std::max(upper[0], static_cast<long>(last - row));
      lower[1] = std::min(lower[1], j), upper[1] = std::max(upper[1], j);
      lower[2] = std::min(lower[2], k), upper[2] = std::max(upper[2], k);
    }
  if (upper[0] < 0) throw std::runtime_error("the segmentation is empty");
  MaskImage::RegionType box;
  for (unsigned k = 0; k < 3; ++k) {
    const long first = std::max(0L, lower[k] - margin[k]);
    const long last = std::min(static_cast<long>(full.GetSize(k)) - 1, upper[k] + margin[k]);
    box.SetIndex(k, full.GetIndex(k) + first);
    box.SetSize(k, static_cast<itk::SizeValueType>(last - first + 1));
  }
  return box;
}

std::size_t count_voxels(const MaskImage& mask) {
  const std::uint8_t* v = mask.GetBufferPointer();
  const std::size_t n = mask.GetLargestPossibleRegion().GetNumberOfPixels();
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) count += v[i] != 0;
  return count;
}

double dice_coefficient(const MaskImage& a, const MaskImage& b) {
  const std::size_t n = a.GetLargestPossibleRegion().GetNumberOfPixels();
  if (n != b.GetLargestPossibleRegion().GetNumberOfPixels())
    throw std::invalid_argument("dice_coefficient: the masks have different grids");
  const std::uint8_t *va = a.GetBufferPointer(), *vb = b.GetBufferPointer();
  std::size_t both = 0, sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    both += (va[i] != 0) & (vb[i] != 0);
    sum += (va[i] != 0) + (vb[i] != 0);
  }
  return sum == 0 ? 1.0 : 2.0 * static_cast<double>(both) / static_cast<double>(sum);
}

std::array<long, 3> voxel_of_point(const CtImage& ct, const std::array<double, 3>& point_mm) {
  CtImage::PointType point;
  for (unsigned k = 0; k < 3; ++k) point[k] = point_mm[k];
  CtImage::IndexType index;
  if (!ct.TransformPhysicalPointToIndex(point, index)) {
    const auto size = ct.GetLargestPossibleRegion().GetSize();
    throw std::runtime_error(fmt::format(
        "point ({:.1f}, {:.1f}, {:.1f}) mm lies outside the volume ({}x{}x{} voxels); give LPS millimetres inside "
        "the CT, or a voxel index",
        point_mm[0], point_mm[1], point_mm[2], size[0], size[1], size[2]));
  }
  return {index[0], index[1], index[2]};
}

MaskImage::Pointer clean_mask(const MaskImage& mask, double closing_radius_mm) {
  // Clean only the organ's bounding box with a margin wider than the closing
  // ball: an organ fills a fraction of a CT, and every filter here is
  // linear in the voxel count. Outside the box nothing can change.
  const MaskImage::RegionType full = mask.GetLargestPossibleRegion();
  std::array<long, 3> margin{};
  for (unsigned k = 0; k < 3; ++k)
    margin[k] = static_cast<long>(std::ceil(std::max(closing_radius_mm, 0.0) / mask.GetSpacing()[k])) + 2;
  const MaskImage::RegionType box = organ_bounding_box(mask, margin);
  auto crop = itk::RegionOfInterestImageFilter<MaskImage, MaskImage>::New();
  crop->SetInput(&mask);
  crop->SetRegionOfInterest(box);
  crop->Update();
  MaskImage::Pointer filled = fill_holes(*crop->GetOutput());
  MaskImage::Pointer closed = closing_radius_mm > 0 ? close(*filled, closing_radius_mm) : filled;
  const MaskImage::Pointer cleaned = fill_holes(*largest_component(*closed));

  // Back onto the input's grid.
  auto result = MaskImage::New();
  result->CopyInformation(&mask);
  result->SetRegions(full);
  result->Allocate(true);
  itk::ImageRegionConstIterator<MaskImage> from(cleaned, cleaned->GetLargestPossibleRegion());
  itk::ImageRegionIterator<MaskImage> to(result, box);
  for (; !from.IsAtEnd(); ++from, ++to) to.Set(from.Get());
  return result;
}

}  // namespace organsim::pipeline
