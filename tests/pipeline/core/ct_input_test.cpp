#include <gtest/gtest.h>

#include <itkImageFileWriter.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <fstream>

#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/phantom.h"
#include "oversized_ct.h"
#include "temp_directory.h"

namespace organsim::pipeline {
namespace {

namespace fs = std::filesystem;

class CtInput : public organsim::testing::TempDirectoryTest {
 protected:
  void SetUp() override {
    TempDirectoryTest::SetUp();
    PhantomOptions o;
    o.size = {40, 36, 20};
    o.spacing_mm = {9.0, 9.0, 9.5};
    phantom_ = make_phantom(o);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  Phantom phantom_;
};

bool same_voxels(const CtImage& a, const CtImage& b) {
  const std::size_t n = a.GetLargestPossibleRegion().GetNumberOfPixels();
  return n == b.GetLargestPossibleRegion().GetNumberOfPixels() &&
         std::memcmp(a.GetBufferPointer(), b.GetBufferPointer(), n * sizeof(CtImage::PixelType)) == 0;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST_F(CtInput, VolumeFilesKeepVoxelsAndGeometry) {
  for (const char* name : {"ct.nii.gz", "ct.nrrd", "ct.mha"}) {
    write_ct_image(*phantom_.ct, path(name));
    const CtImage::Pointer ct = read_ct(path(name));
    EXPECT_TRUE(same_voxels(*ct, *phantom_.ct)) << name;
    for (unsigned k = 0; k < 3; ++k) {
      EXPECT_NEAR(ct->GetSpacing()[k], phantom_.ct->GetSpacing()[k], 1e-6);
      EXPECT_NEAR(ct->GetOrigin()[k], phantom_.ct->GetOrigin()[k], 1e-4);
    }
  }
}

TEST_F(CtInput, DicomSeriesIsSortedByPositionNotByFileName) {
  write_dicom_series(*phantom_.ct, path("dicom"), DicomSeriesInfo{});
  // Reverse the file names: slice 1 gets the last name and so on.
  const int slices = 20;
  for (int s = 1; s <= slices; ++s)
    fs::rename(dir_ / "dicom" / ("slice" + std::string(4 - std::to_string(s).size(), '0') + std::to_string(s) + ".dcm"),
               dir_ / "dicom" / ("tmp" + std::to_string(slices + 1 - s) + ".dcm"));
  const CtImage::Pointer ct = read_ct(path("dicom"));
  EXPECT_TRUE(same_voxels(*ct, *phantom_.ct));
  for (unsigned k = 0; k < 3; ++k) EXPECT_NEAR(ct->GetOrigin()[k], phantom_.ct->GetOrigin()[k], 1e-3);
  EXPECT_NEAR(ct->GetSpacing()[2], 9.5, 1e-3);
}

TEST_F(CtInput, SeveralSeriesNeedAChoice) {
  write_dicom_series(*phantom_.ct, path("a"), DicomSeriesInfo{"A^B", "X", "first series", 1});
  write_dicom_series(*phantom_.ct, path("b"), DicomSeriesInfo{"A^B", "X", "second series", 2});
  fs::create_directories(dir_ / "both");
  for (const char* sub : {"a", "b"})
    for (const auto& f : fs::directory_iterator(dir_ / sub))
      fs::copy_file(f.path(), dir_ / "both" / (std::string(sub) + f.path().filename().string()));
  const std::string error = error_of([&] { read_ct(path("both")); });
  EXPECT_NE(error.find("holds 2 DICOM series; choose one with --series"), std::string::npos) << error;
  EXPECT_NE(error.find("second series"), std::string::npos) << error;
  EXPECT_EQ(error.find("A^B"), std::string::npos) << "a patient name reached an error message";
  const auto series = list_dicom_series(path("both"));
  ASSERT_EQ(series.size(), 2u);
  const CtImage::Pointer chosen = read_ct(path("both"), series[1].uid);
  EXPECT_TRUE(same_voxels(*chosen, *phantom_.ct));
}

TEST_F(CtInput, BadFilesGetOneLineErrors) {
  EXPECT_NE(error_of([&] { read_ct(path("missing.nii.gz")); }).find("no such file"), std::string::npos);
  std::ofstream(path("garbage.nii.gz")) << "not an image at all";
  EXPECT_NE(error_of([&] { read_ct(path("garbage.nii.gz")); }).find("'"), std::string::npos);
  std::ofstream(path("notes.txt")) << "text";
  EXPECT_NE(error_of([&] { read_ct(path("notes.txt")); }).find("is not an image ITK can read"), std::string::npos);
  fs::create_directories(dir_ / "empty");
  EXPECT_NE(error_of([&] { read_ct(path("empty")); }).find("holds no DICOM series"), std::string::npos);

  using Slice = itk::Image<std::int16_t, 2>;
  auto slice = Slice::New();
  Slice::RegionType region;
  region.SetSize({{16, 16}});
  slice->SetRegions(region);
  slice->Allocate(true);
  auto writer = itk::ImageFileWriter<Slice>::New();
  writer->SetInput(slice);
  writer->SetFileName(path("slice.nii.gz"));
  writer->Update();
  EXPECT_NE(error_of([&] { read_ct(path("slice.nii.gz")); }).find("2-D image"), std::string::npos);

  write_ct_image(*phantom_.ct, path("ct.nii.gz"));
  std::vector<char> bytes(fs::file_size(path("ct.nii.gz")));
  std::ifstream(path("ct.nii.gz"), std::ios::binary).read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  std::ofstream(path("truncated.nii.gz"), std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  const std::string truncated = error_of([&] { read_ct(path("truncated.nii.gz")); });
  EXPECT_NE(truncated.find("probably truncated"), std::string::npos) << truncated;
  EXPECT_EQ(truncated.find('\n'), std::string::npos) << truncated;
}

// A CT whose header announces more voxels than the machine can hold is
// refused before a voxel is read, in one line saying how much it needs: a tiny
// file with a huge header, and a compressed one that would inflate past the
// memory (its stream is never inflated). The same for a label map.
TEST_F(CtInput, ACtLargerThanTheMemoryIsRefusedUpFrontInOneLine) {
  ASSERT_GT(available_memory_bytes(), 0.0) << "/proc/meminfo's MemAvailable";
  write_ct_image(*phantom_.ct, path("ct.nii"));
  // 30,000³ voxels of int16 are 49 TiB.
  organsim::testing::write_oversized_nifti(path("ct.nii"), path("huge.nii"), 30000);
  organsim::testing::write_oversized_nifti(path("ct.nii"), path("huge.nii.gz"), 30000);
  for (const std::string name : {"huge.nii", "huge.nii.gz"}) {
    const std::string error = error_of([&] { read_ct(path(name), "", {2.0, 0.0, "baking it"}); });
    EXPECT_NE(error.find("is 30000x30000x30000 voxels; baking it needs about 50291.4 GiB of memory and this machine "
                         "has "),
              std::string::npos)
        << error;
    EXPECT_NE(error.find("crop the CT"), std::string::npos) << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
    const std::string label = error_of([&] { read_label_mask(path(name), 1, *phantom_.ct); });
    EXPECT_NE(label.find("reading it as a label map"), std::string::npos) << label;
  }
}

TEST_F(CtInput, LabelMapsMustMatchTheGridAndHoldTheLabel) {
  write_mask_image(*phantom_.liver_mask, path("labels.nii.gz"));
  const MaskImage::Pointer mask = read_label_mask(path("labels.nii.gz"), 1, *phantom_.ct);
  EXPECT_EQ(std::memcmp(mask->GetBufferPointer(), phantom_.liver_mask->GetBufferPointer(),
                        mask->GetLargestPossibleRegion().GetNumberOfPixels()),
            0);
  EXPECT_NE(
      error_of([&] { read_label_mask(path("labels.nii.gz"), 5, *phantom_.ct); }).find("no voxel has label value 5"),
      std::string::npos);
  PhantomOptions other;
  other.size = {40, 36, 21};
  const Phantom different = make_phantom(other);
  EXPECT_NE(error_of([&] { read_label_mask(path("labels.nii.gz"), 1, *different.ct); }).find("does not match"),
            std::string::npos);
}

}  // namespace
}  // namespace organsim::pipeline
