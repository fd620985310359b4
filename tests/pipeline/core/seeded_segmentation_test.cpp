// Seeded segmentation on the shipped real CTs (against TotalSegmentator's
// liver labels) and on the phantom: the Dice coefficients the issue asks for,
// the errors for seeds that cannot be the organ, and the report's warnings.
#include <gtest/gtest.h>

#include <itkBinShrinkImageFilter.h>
#include <itkCastImageFilter.h>

#include <cstring>
#include <filesystem>

#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/phantom.h"
#include "organsim/pipeline/seeded_segmentation.h"
#include "organsim/pipeline/segmentation.h"

namespace organsim::pipeline {
namespace {

namespace fs = std::filesystem;
const fs::path kRealCt = fs::path(ORGANSIM_DATA_SAMPLES) / "real_ct_totalseg";

struct Case {
  CtImage::Pointer ct;
  MaskImage::Pointer label;
};

Case load_case(const char* ct, const char* label) {
  Case c;
  c.ct = read_ct((kRealCt / ct).string());
  c.label = read_label_mask((kRealCt / label).string(), 1, *c.ct);
  return c;
}

const Case& nifti_case() {
  static const Case c = load_case("example_ct.nii.gz", "liver_mask_ct.nii.gz");
  return c;
}

const Case& dicom_case() {
  static const Case c = load_case("example_ct_dicom", "liver_mask_dicom.nii.gz");
  return c;
}

double dice_from(const Case& c, const SeededSegmentationOptions& o) {
  return dice_coefficient(*segment_from_seeds(*c.ct, o).mask, *c.label);
}

std::string fmt_seed(const std::array<long, 3>& seed) {
  return "dice_seed_" + std::to_string(seed[0]) + "_" + std::to_string(seed[1]) + "_" + std::to_string(seed[2]);
}

SeededSegmentationOptions one_seed_voxel(long i, long j, long k) {
  SeededSegmentationOptions o;
  o.seeds = {SeedPoint::at_voxel({i, j, k})};
  return o;
}

// Seeds a user might click: spread over the liver (right lobe, dome, centre,
// posterior), each at least a few voxels inside the label.
TEST(SeededSegmentation, RealCtNiftiFromOneSeedAnywhereInTheLiver) {
  for (const auto& seed : {std::array<long, 3>{86, 47, 108}, {93, 41, 93}, {69, 69, 106}, {93, 61, 87}}) {
    const double dice = dice_from(nifti_case(), one_seed_voxel(seed[0], seed[1], seed[2]));
    EXPECT_GE(dice, 0.90) << "seed " << seed[0] << "," << seed[1] << "," << seed[2];
    RecordProperty(fmt_seed(seed), std::to_string(dice));
  }
}

TEST(SeededSegmentation, RealCtDicomSeriesFromOneSeed) {
  for (const auto& seed : {std::array<long, 3>{184, 287, 14}, {142, 286, 15}, {234, 208, 5}}) {
    const double dice = dice_from(dicom_case(), one_seed_voxel(seed[0], seed[1], seed[2]));
    EXPECT_GE(dice, 0.90) << "seed " << seed[0] << "," << seed[1] << "," << seed[2];
    RecordProperty(fmt_seed(seed), std::to_string(dice));
  }
}

// A seed in the liver's darker posterior part (about 65 HU in this contrast
// phase, 100 HU elsewhere) finds the whole liver: the first window reaches
// higher than the final one, which comes from the organ's certain part. A
// second seed in the rest changes nothing.
TEST(SeededSegmentation, RealCtDicomSeriesFromASeedInTheDarkerPart) {
  SeededSegmentationOptions o = one_seed_voxel(189, 347, 12);
  const double one = dice_from(dicom_case(), o);
  o.seeds.push_back(SeedPoint::at_voxel({184, 287, 14}));
  const double two = dice_from(dicom_case(), o);
  EXPECT_GE(one, 0.93);
  EXPECT_GE(two, 0.93);
  RecordProperty("dice_one_seed", std::to_string(one));
  RecordProperty("dice_two_seeds", std::to_string(two));
}

TEST(SeededSegmentation, BackgroundSeedsHoldBackTheNeighbours) {
  SeededSegmentationOptions o = one_seed_voxel(86, 47, 108);
  const double alone = dice_from(nifti_case(), o);
  // Where the one-seed mask holds what the label leaves out, as a user sees it
  // in 3D Slicer: the body wall beside the right lobe, a structure in the
  // hilum, the body wall below the lobe.
  o.background_seeds = {SeedPoint::at_voxel({106, 51, 98}), SeedPoint::at_voxel({65, 51, 106}),
                        SeedPoint::at_voxel({98, 71, 81})};
  const SeededSegmentation with_background = segment_from_seeds(*nifti_case().ct, o);
  const double dice = dice_coefficient(*with_background.mask, *nifti_case().label);
  // 0.93 before lesions and vessels at the surface were taken in: the label
  // leaves out 13 mL of vessels at the hilum that the segmentation now keeps.
  EXPECT_GE(dice, 0.925);
  EXPECT_GT(dice, alone + 0.003);
  EXPECT_GT(with_background.report.background_split_ml, 0.0);
  RecordProperty("dice_one_seed", std::to_string(alone));
  RecordProperty("dice_with_background_seeds", std::to_string(dice));
}

TEST(SeededSegmentation, PhantomLiverFromOneSeed) {
  const Phantom phantom = make_phantom(PhantomOptions{});
  SeededSegmentationOptions o;
  o.seeds = {SeedPoint::at_mm({-65.0, 5.0, 0.0})};
  const SeededSegmentation result = segment_from_seeds(*phantom.ct, o);
  const double dice = dice_coefficient(*result.mask, *phantom.liver_mask);
  EXPECT_GE(dice, 0.95);
  EXPECT_TRUE(result.report.warnings.empty());
  EXPECT_NEAR(result.report.volume_ml, phantom.liver_volume_ml, 0.08 * phantom.liver_volume_ml);
  RecordProperty("dice", std::to_string(dice));
}

TEST(SeededSegmentation, TheSameSeedsGiveTheSameMask) {
  const SeededSegmentationOptions o = one_seed_voxel(86, 47, 108);
  const MaskImage::Pointer a = segment_from_seeds(*nifti_case().ct, o).mask;
  const MaskImage::Pointer b = segment_from_seeds(*nifti_case().ct, o).mask;
  EXPECT_EQ(dice_coefficient(*a, *b), 1.0);
  EXPECT_EQ(a->GetSpacing(), nifti_case().ct->GetSpacing());
  EXPECT_EQ(a->GetOrigin(), nifti_case().ct->GetOrigin());
}

void expect_one_line_error(const SeededSegmentationOptions& o, const std::string& fragment) {
  try {
    segment_from_seeds(*nifti_case().ct, o);
    ADD_FAILURE() << "no error; expected one mentioning \"" << fragment << "\"";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
}

TEST(SeededSegmentation, SeedsThatCannotBeTheOrganAreOneLineErrors) {
  expect_one_line_error(one_seed_voxel(2, 2, 60), "air");  // outside the body
  expect_one_line_error(one_seed_voxel(60, 50, 200), "outside the volume");
  SeededSegmentationOptions point;
  point.seeds = {SeedPoint::at_mm({5000.0, 0.0, 0.0})};
  expect_one_line_error(point, "outside the volume");
  expect_one_line_error(SeededSegmentationOptions{}, "no seed");
  SeededSegmentationOptions window = one_seed_voxel(86, 47, 108);
  window.hu_window = std::make_pair(200.0, 300.0);
  expect_one_line_error(window, "outside the window");
  SeededSegmentationOptions background = one_seed_voxel(86, 47, 108);
  background.background_seeds = {SeedPoint::at_voxel({86, 47, 500})};
  expect_one_line_error(background, "background seed 1");
}

TEST(SeededSegmentation, PlausibilityWarnings) {
  EXPECT_TRUE(liver_plausibility_warnings(1500.0, 0, 60).empty());
  EXPECT_EQ(liver_plausibility_warnings(400.0, 0, 60).size(), 1u);
  EXPECT_EQ(liver_plausibility_warnings(5000.0, 0, 60).size(), 1u);
  EXPECT_EQ(liver_plausibility_warnings(1500.0, 20, 60).size(), 1u);
  EXPECT_EQ(liver_plausibility_warnings(5000.0, 20, 60).size(), 2u);
  // A mask that fills the volume touches the side on every slice.
  auto full = MaskImage::New();
  full->SetRegions(nifti_case().label->GetLargestPossibleRegion());
  full->Allocate();
  full->FillBuffer(1);
  const auto [border, slices] = border_and_organ_slices(*full);
  EXPECT_EQ(border, slices);
  EXPECT_EQ(slices, full->GetLargestPossibleRegion().GetSize(2));
}

// The working grid is binned straight from the int16 CT: BinShrink sums in
// double either way, so it is the grid a float copy of the CT gave, bit for
// bit, on anisotropic factors and a phantom with noise.
TEST(SeededSegmentation, TheWorkingGridOfTheInt16CtHasTheFloatCopysBits) {
  using FloatImage = itk::Image<float, 3>;
  const Phantom phantom = make_phantom(PhantomOptions{});
  for (const std::array<unsigned, 3>& factors : {std::array<unsigned, 3>{2, 2, 2}, std::array<unsigned, 3>{3, 1, 2}}) {
    auto direct = itk::BinShrinkImageFilter<CtImage, FloatImage>::New();
    direct->SetInput(phantom.ct);
    auto as_float = itk::CastImageFilter<CtImage, FloatImage>::New();
    as_float->SetInput(phantom.ct);
    auto from_float = itk::BinShrinkImageFilter<FloatImage, FloatImage>::New();
    from_float->SetInput(as_float->GetOutput());
    for (unsigned k = 0; k < 3; ++k) direct->SetShrinkFactor(k, factors[k]), from_float->SetShrinkFactor(k, factors[k]);
    direct->Update();
    from_float->Update();
    const FloatImage& a = *direct->GetOutput();
    const FloatImage& b = *from_float->GetOutput();
    const std::size_t n = a.GetLargestPossibleRegion().GetNumberOfPixels();
    ASSERT_EQ(n, b.GetLargestPossibleRegion().GetNumberOfPixels());
    EXPECT_EQ(a.GetSpacing(), b.GetSpacing());
    EXPECT_EQ(a.GetOrigin(), b.GetOrigin());
    EXPECT_EQ(std::memcmp(a.GetBufferPointer(), b.GetBufferPointer(), n * sizeof(float)), 0)
        << factors[0] << "," << factors[1] << "," << factors[2];
  }
}

}  // namespace
}  // namespace organsim::pipeline
