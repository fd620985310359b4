// Writing images: the format follows the extension, every file and the DICOM
// series directory appear whole or not at all, and nothing is half-written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/phantom.h"
#include "organsim/pipeline/segmentation.h"
#include "temp_directory.h"

namespace organsim::pipeline {
namespace {

namespace fs = std::filesystem;

class ImageIo : public organsim::testing::TempDirectoryTest {
 protected:
  void SetUp() override {
    TempDirectoryTest::SetUp();
    PhantomOptions o;
    o.size = {32, 28, 20};
    o.spacing_mm = {6.0, 6.0, 6.0};
    phantom_ = make_phantom(o);
  }
  Phantom phantom_;
};

TEST_F(ImageIo, MasksRoundTripInEveryWritableFormat) {
  for (const char* name : {"mask.nii.gz", "mask.nii", "mask.nrrd", "mask.mha"}) {
    const fs::path path = dir_ / name;
    write_mask_image(*phantom_.liver_mask, path.string());
    const MaskImage::Pointer read = read_label_mask(path.string(), 1, *phantom_.ct);
    EXPECT_EQ(count_voxels(*read), count_voxels(*phantom_.liver_mask)) << name;
    EXPECT_DOUBLE_EQ(dice_coefficient(*read, *phantom_.liver_mask), 1.0) << name;
  }
  EXPECT_EQ(entries(dir_), 4);  // no temporary file left behind
}

TEST_F(ImageIo, AnUnsupportedExtensionIsRefusedAndWritesNothing) {
  try {
    write_ct_image(*phantom_.ct, (dir_ / "ct.png").string());
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("use .nii.gz, .nii, .nrrd or .mha"), std::string::npos) << e.what();
  }
  EXPECT_EQ(entries(dir_), 0);
}

TEST_F(ImageIo, AWriteThatCannotBePublishedLeavesNoTemporaryFile) {
  // The image is written, but renaming it over a directory fails at the end.
  const fs::path target = dir_ / "mask.nrrd";
  fs::create_directories(target / "inside");
  EXPECT_THROW(write_mask_image(*phantom_.liver_mask, target.string()), std::runtime_error);
  EXPECT_TRUE(fs::is_directory(target / "inside"));
  EXPECT_EQ(entries(dir_), 1);
}

TEST_F(ImageIo, ADicomSeriesAppearsWholeAndReadsBack) {
  const fs::path series = dir_ / "dicom";
  write_dicom_series(*phantom_.ct, series.string(), DicomSeriesInfo{});
  EXPECT_EQ(entries(series), 20);
  EXPECT_EQ(entries(dir_), 1);  // the temporary directory became the series
  const CtImage::Pointer read = read_ct(series.string());
  EXPECT_EQ(read->GetLargestPossibleRegion().GetSize(), phantom_.ct->GetLargestPossibleRegion().GetSize());
}

TEST_F(ImageIo, ADicomSeriesNeverMixesWithAnExistingOne) {
  const fs::path series = dir_ / "dicom";
  fs::create_directories(series);
  std::ofstream(series / "slice0001.dcm") << "someone else's file";
  try {
    write_dicom_series(*phantom_.ct, series.string(), DicomSeriesInfo{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("choose a new directory"), std::string::npos) << e.what();
  }
  EXPECT_EQ(entries(series), 1);
  EXPECT_EQ(entries(dir_), 1);
}

}  // namespace
}  // namespace organsim::pipeline
