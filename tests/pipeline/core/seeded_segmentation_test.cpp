// Seeded segmentation on the shipped real CTs (against TotalSegmentator's
// liver labels) and on the phantom: the Dice coefficients the issue asks for,
// the errors for seeds that cannot be the organ, and the report's warnings.
#include <gtest/gtest.h>

#include <itkBinShrinkImageFilter.h>
#include <itkCastImageFilter.h>
#include <itkImageRegionConstIteratorWithIndex.h>
#include <itkImageRegionIteratorWithIndex.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>

#include <fmt/format.h>

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

/// A CT (150 × 90 × 90 mm, `spacing_mm` voxels, fat at −100 HU) holding a body of liver tissue
/// (100 HU, a 60 × 50 × 50 mm box) and a lobe (a sphere of radius
/// `lobe_radius_mm`, `lobe_contrast_hu` from the body's HU) joined to it by a
/// neck (a cylinder along x of diameter `neck_mm`, 15 mm long,
/// `neck_contrast_hu` from the body's HU); the truth is all three. A
/// neighbour of the organ's HU (a 12 mm slab, not in the truth) may lie
/// `neighbour_gap_mm` beside the body across fat (0: none).
struct NeckedOrgan {
  CtImage::Pointer ct;
  MaskImage::Pointer truth;
  std::array<double, 3> body_centre_mm{}, lobe_centre_mm{};
};

NeckedOrgan necked_organ(double neck_mm, double lobe_radius_mm = 22.0, double neighbour_gap_mm = 0.0,
                         int lobe_contrast_hu = 0, int neck_contrast_hu = 0, double spacing_mm = 1.5) {
  NeckedOrgan o;
  const double kSpacing = spacing_mm;
  const auto voxels = [&](double mm) { return static_cast<itk::SizeValueType>(std::lround(mm / spacing_mm)); };
  const CtImage::SizeType size = {{voxels(150.0), voxels(90.0), voxels(90.0)}};
  o.ct = CtImage::New();
  o.ct->SetRegions(CtImage::RegionType(size));
  CtImage::SpacingType spacing;
  spacing.Fill(kSpacing);
  o.ct->SetSpacing(spacing);
  o.ct->Allocate();
  o.truth = MaskImage::New();
  o.truth->CopyInformation(o.ct);
  o.truth->SetRegions(o.ct->GetLargestPossibleRegion());
  o.truth->Allocate(true);
  o.body_centre_mm = {40.0, 45.0, 45.0};
  const double body_end = 70.0, neck_end = body_end + 15.0;
  o.lobe_centre_mm = {neck_end + lobe_radius_mm - 2.0, 45.0, 45.0};
  itk::ImageRegionIteratorWithIndex<CtImage> it(o.ct, o.ct->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it) {
    CtImage::PointType p;
    o.ct->TransformIndexToPhysicalPoint(it.GetIndex(), p);
    const bool body =
        p[0] >= 10.0 && p[0] <= body_end && std::abs(p[1] - 45.0) <= 25.0 && std::abs(p[2] - 45.0) <= 25.0;
    const bool neck =
        p[0] > body_end && p[0] <= neck_end + 2.0 && std::hypot(p[1] - 45.0, p[2] - 45.0) <= neck_mm / 2.0;
    const bool lobe = std::hypot(p[0] - o.lobe_centre_mm[0], std::hypot(p[1] - 45.0, p[2] - 45.0)) <= lobe_radius_mm;
    // A neighbour of the organ's HU (a muscle): a slab beside the body, across a gap of fat.
    const bool neighbour = neighbour_gap_mm > 0.0 && p[0] >= 10.0 && p[0] <= body_end &&
                           std::abs(p[2] - 45.0) <= 25.0 && p[1] > 70.0 + neighbour_gap_mm &&
                           p[1] <= 70.0 + neighbour_gap_mm + 12.0;
    // A little texture, the same on every run: a liver is not a flat grey.
    const int texture =
        static_cast<int>((it.GetIndex()[0] * 7 + it.GetIndex()[1] * 13 + it.GetIndex()[2] * 5) % 11) - 5;
    const int hu = body || neighbour ? 100 : lobe ? 100 + lobe_contrast_hu : neck ? 100 + neck_contrast_hu : -100;
    it.Set(static_cast<short>(hu + texture));
    if (body || neck || lobe) o.truth->SetPixel(it.GetIndex(), 1);
  }
  return o;
}

bool holds(const MaskImage& mask, const std::array<double, 3>& point_mm) {
  CtImage::PointType p;
  for (unsigned k = 0; k < 3; ++k) p[k] = point_mm[k];
  CtImage::IndexType at;
  mask.TransformPhysicalPointToIndex(p, at);
  return mask.GetPixel(at) != 0;
}

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::hypot(a[0] - b[0], std::hypot(a[1] - b[1], a[2] - b[2]));
}

// A lobe joined through a neck thinner than the leak control's opening is
// cut, and the report says so: its volume, its HU beside the organ core's, the
// neck's width, and a seed inside it that takes it back.
TEST(SeededSegmentation, ALobeCutAtANeckIsReportedWithASeedThatTakesItBack) {
  const NeckedOrgan organ = necked_organ(8.0);
  SeededSegmentationOptions o;
  o.seeds = {SeedPoint::at_mm(organ.body_centre_mm)};
  o.explain = true;
  const SeededSegmentation one = segment_from_seeds(*organ.ct, o);
  const double lobe_ml = 4.0 / 3.0 * M_PI * std::pow(22.0, 3) * 1e-3;
  ASSERT_FALSE(one.report.cut_regions.empty());
  const CutRegion& cut = one.report.cut_regions.front();
  EXPECT_EQ(cut.cause, "leak control");
  EXPECT_NEAR(cut.volume_ml, lobe_ml, 0.25 * lobe_ml);
  EXPECT_NEAR(cut.median_hu, 100.0, 4.0);
  EXPECT_GT(cut.neck_width_mm, 4.0);
  EXPECT_LT(cut.neck_width_mm, 14.0);
  for (unsigned k = 0; k < 3; ++k) {
    EXPECT_LE(cut.box_low_mm[k], organ.lobe_centre_mm[k]);
    EXPECT_GE(cut.box_high_mm[k], organ.lobe_centre_mm[k]);
  }
  const double seed_to_centre =
      std::hypot(cut.seed_mm[0] - organ.lobe_centre_mm[0],
                 std::hypot(cut.seed_mm[1] - organ.lobe_centre_mm[1], cut.seed_mm[2] - organ.lobe_centre_mm[2]));
  EXPECT_LT(seed_to_centre, 22.0 - 5.0) << "the suggested seed lies well inside the lobe";
  // The explanation: the organ, and the lobe as cut by leak control.
  ASSERT_TRUE(one.explanation);
  CtImage::IndexType at;
  CtImage::PointType p;
  for (unsigned k = 0; k < 3; ++k) p[k] = organ.lobe_centre_mm[k];
  organ.ct->TransformPhysicalPointToIndex(p, at);
  EXPECT_EQ(one.explanation->GetPixel(at), kCutByLeakControl);
  for (unsigned k = 0; k < 3; ++k) p[k] = organ.body_centre_mm[k];
  organ.ct->TransformPhysicalPointToIndex(p, at);
  EXPECT_EQ(one.explanation->GetPixel(at), kOrgan);
  // The seed the report prints brings the lobe back.
  const double dice_one = dice_coefficient(*one.mask, *organ.truth);
  o.seeds.push_back(SeedPoint::at_mm(cut.seed_mm));
  const SeededSegmentation two = segment_from_seeds(*organ.ct, o);
  const double dice_two = dice_coefficient(*two.mask, *organ.truth);
  EXPECT_LT(dice_one, 0.9);
  EXPECT_GE(dice_two, 0.95);
  RecordProperty("dice_one_seed", std::to_string(dice_one));
  RecordProperty("dice_with_the_printed_seed", std::to_string(dice_two));
}

// The neck sweep: a lobe of the organ's tissue joined through a neck thinner
// than the opening radius (10 mm) is cut and reported, with a seed inside it;
// through a thicker neck it is kept, outright (24 mm and more, wider than the
// opening's diameter) or given back by the neck rule (12 and 16 mm). Reported
// or kept, nothing of it is lost silently.
TEST(SeededSegmentation, NeckSweepKeepsALobeBehindANeckThickerThanTheOpeningRadius) {
  const double lobe_ml = 4.0 / 3.0 * M_PI * std::pow(22.0, 3) * 1e-3;
  for (const double neck : {4.0, 8.0, 12.0, 16.0, 24.0, 32.0}) {
    const NeckedOrgan organ = necked_organ(neck);
    SeededSegmentationOptions o;
    o.seeds = {SeedPoint::at_mm(organ.body_centre_mm)};
    o.explain = true;
    const SeededSegmentation result = segment_from_seeds(*organ.ct, o);
    const bool kept = holds(*result.mask, organ.lobe_centre_mm);
    const auto reported = std::find_if(result.report.cut_regions.begin(), result.report.cut_regions.end(),
                                       [&](const CutRegion& r) { return r.volume_ml > 0.5 * lobe_ml; });
    const bool given_back = !result.report.taken_back.empty();
    const double dice = dice_coefficient(*result.mask, *organ.truth);
    RecordProperty(fmt::format("neck_{}_mm", neck),
                   fmt::format("{} dice {:.3f}", kept ? (given_back ? "given back" : "kept") : "cut", dice));
    if (neck < 10.0) {
      EXPECT_FALSE(kept) << neck << " mm";
      ASSERT_NE(reported, result.report.cut_regions.end()) << "a cut lobe is reported: " << neck << " mm";
      EXPECT_TRUE(reported->like_organ);
      EXPECT_NE(reported->kept_out_because.find("neck"), std::string::npos) << reported->kept_out_because;
      EXPECT_LT(distance(reported->seed_mm, organ.lobe_centre_mm), 17.0) << neck << " mm";
    } else {
      EXPECT_TRUE(kept) << neck << " mm";
      EXPECT_EQ(reported, result.report.cut_regions.end()) << neck << " mm";
      EXPECT_GE(dice, 0.95) << neck << " mm";
      EXPECT_EQ(given_back, neck < 20.0) << neck << " mm";
      if (given_back) {
        EXPECT_NEAR(result.report.taken_back.front().volume_ml, lobe_ml, 0.25 * lobe_ml);
        EXPECT_GE(result.report.taken_back.front().neck_thickness_mm, 10.0);
        CtImage::PointType p;
        for (unsigned k = 0; k < 3; ++k) p[k] = organ.lobe_centre_mm[k];
        CtImage::IndexType at;
        organ.ct->TransformPhysicalPointToIndex(p, at);
        EXPECT_EQ(result.explanation->GetPixel(at), kTakenBack) << neck << " mm";
        // Without the neck rule the same lobe is cut.
        o.take_back_lobes = false;
        EXPECT_FALSE(holds(*segment_from_seeds(*organ.ct, o).mask, organ.lobe_centre_mm)) << neck << " mm";
      }
    }
  }
}

// The neck rule on other grids: 0.8 mm voxels (segmented on 2.4 mm blocks)
// and 2 mm voxels. A lobe behind an 8 mm neck stays cut; one behind a 16 mm
// neck is given back, and the mask is then as good as where the opening never
// cut the lobe (a 32 mm neck) on the same grid.
TEST(SeededSegmentation, TheNeckRuleHoldsOnFinerAndCoarserGrids) {
  for (const double spacing : {0.8, 2.0}) {
    std::map<double, double> dice;
    for (const double neck : {8.0, 16.0, 32.0}) {
      const NeckedOrgan organ = necked_organ(neck, 22.0, 0.0, 0, 0, spacing);
      SeededSegmentationOptions o;
      o.seeds = {SeedPoint::at_mm(organ.body_centre_mm)};
      const SeededSegmentation result = segment_from_seeds(*organ.ct, o);
      dice[neck] = dice_coefficient(*result.mask, *organ.truth);
      RecordProperty(fmt::format("spacing_{}_neck_{}_mm", spacing, neck), fmt::format("dice {:.3f}", dice[neck]));
      EXPECT_EQ(holds(*result.mask, organ.lobe_centre_mm), neck > 10.0) << spacing << " mm voxels, " << neck << " mm";
    }
    EXPECT_NEAR(dice[16.0], dice[32.0], 0.01) << spacing << " mm voxels";
    EXPECT_GT(dice[16.0], dice[8.0] + 0.05) << spacing << " mm voxels";
  }
}

// What the neck rule does not give back, behind a 16 mm neck: a piece 15 HU
// darker than the organ (a muscle on a CT without contrast), and a piece of the
// organ's HU behind a neck 40 HU darker (two organs meeting at a partial-volume
// dip). Each is cut, reported with the reason and a seed inside it.
TEST(SeededSegmentation, TheNeckRuleLeavesOutADarkerPieceAndAPieceBehindADarkNeck) {
  const double lobe_ml = 4.0 / 3.0 * M_PI * std::pow(22.0, 3) * 1e-3;
  const struct {
    int lobe_contrast_hu, neck_contrast_hu;
    const char* reason;
  } cases[] = {{-15, 0, "HU is not the organ core's"}, {0, -40, "neck is darker than the organ"}};
  for (const auto& c : cases) {
    const NeckedOrgan organ = necked_organ(16.0, 22.0, 0.0, c.lobe_contrast_hu, c.neck_contrast_hu);
    SeededSegmentationOptions o;
    o.seeds = {SeedPoint::at_mm(organ.body_centre_mm)};
    const SeededSegmentation result = segment_from_seeds(*organ.ct, o);
    EXPECT_FALSE(holds(*result.mask, organ.lobe_centre_mm)) << c.reason;
    EXPECT_TRUE(result.report.taken_back.empty()) << c.reason;
    const auto reported = std::find_if(result.report.cut_regions.begin(), result.report.cut_regions.end(),
                                       [&](const CutRegion& r) { return r.volume_ml > 0.5 * lobe_ml; });
    ASSERT_NE(reported, result.report.cut_regions.end()) << c.reason;
    EXPECT_NE(reported->kept_out_because.find(c.reason), std::string::npos) << reported->kept_out_because;
    EXPECT_LT(distance(reported->seed_mm, organ.lobe_centre_mm), 17.0) << c.reason;
  }
}

// A background seed takes only what lies nearer to it than to the organ's
// seeds through the window: with the organ seeded in the body and a background
// seed in the lobe (one stretch of tissue, 24 mm neck), no voxel of the body
// nearer the organ's seed is given to the background.
TEST(SeededSegmentation, BackgroundSeedsNeverTakeAVoxelNearerToAnOrganSeed) {
  const NeckedOrgan organ = necked_organ(24.0);
  SeededSegmentationOptions o;
  o.seeds = {SeedPoint::at_mm(organ.body_centre_mm)};
  o.background_seeds = {SeedPoint::at_mm(organ.lobe_centre_mm)};
  o.explain = true;
  const SeededSegmentation result = segment_from_seeds(*organ.ct, o);
  ASSERT_TRUE(result.explanation);
  // The window's distance is counted in 6-connected steps (an L1 distance);
  // inside the body, which holds the organ's seed and is convex, it is the
  // straight one to that seed, and no shorter to the background's.
  const auto steps = [](const CtImage::PointType& p, const std::array<double, 3>& q) {
    return std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2]);
  };
  std::size_t given = 0, nearer_organ = 0;
  itk::ImageRegionConstIteratorWithIndex<MaskImage> it(result.explanation,
                                                       result.explanation->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it) {
    if (it.Get() != kGivenToBackground) continue;
    ++given;
    CtImage::PointType p;
    result.explanation->TransformIndexToPhysicalPoint(it.GetIndex(), p);
    const bool in_body = p[0] >= 10.0 && p[0] <= 70.0 && std::abs(p[1] - 45.0) <= 25.0 && std::abs(p[2] - 45.0) <= 25.0;
    if (in_body && steps(p, organ.body_centre_mm) < steps(p, organ.lobe_centre_mm)) ++nearer_organ;
  }
  EXPECT_GT(given, 0u) << "the background seed takes the lobe";
  EXPECT_EQ(nearer_organ, 0u) << "of " << given << " voxels given to the background";
  CtImage::PointType body;
  for (unsigned k = 0; k < 3; ++k) body[k] = organ.body_centre_mm[k];
  CtImage::IndexType at;
  organ.ct->TransformPhysicalPointToIndex(body, at);
  EXPECT_EQ(result.mask->GetPixel(at), 1);
}

// A neighbour of the organ's HU across a gap of fat stays out, down to a gap
// of one voxel.
TEST(SeededSegmentation, ANeighbourOfTheOrgansHuAcrossAOneVoxelGapStaysOut) {
  for (const double gap : {1.5, 3.0, 6.0}) {
    const NeckedOrgan organ = necked_organ(32.0, 22.0, gap);
    SeededSegmentationOptions o;
    o.seeds = {SeedPoint::at_mm(organ.body_centre_mm)};
    const SeededSegmentation result = segment_from_seeds(*organ.ct, o);
    CtImage::PointType inside_neighbour;
    inside_neighbour[0] = 40.0, inside_neighbour[1] = 70.0 + gap + 6.0, inside_neighbour[2] = 45.0;
    CtImage::IndexType at;
    organ.ct->TransformPhysicalPointToIndex(inside_neighbour, at);
    EXPECT_EQ(result.mask->GetPixel(at), 0) << "gap " << gap << " mm";
    EXPECT_GE(dice_coefficient(*result.mask, *organ.truth), 0.95) << "gap " << gap << " mm";
  }
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
