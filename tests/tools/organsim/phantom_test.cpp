// `organsim phantom`: the synthetic CT, byte-identical per seed, in every format.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "cli_fixture.h"

namespace organsim {
namespace {

using namespace cli::testing;

TEST_F(Cli, PhantomIsByteIdenticalForTheSameSeedInEveryFormat) {
  for (const char* extension : {".nii.gz", ".nrrd", ".mha"}) {
    const std::string a = (dir_ / (std::string("a") + extension)).string();
    const std::string b = (dir_ / (std::string("b") + extension)).string();
    const std::string options = " --size 48,40,24 --spacing 8,8,8 --seed 7";
    const CommandRun first =
        run_organsim("phantom -o " + a + " --mask " + (dir_ / "ma.nii.gz").string() + options, dir_);
    ASSERT_EQ(first.exit_code, 0) << first.err;
    ASSERT_EQ(run_organsim("phantom -o " + b + options, dir_).exit_code, 0);
    std::ifstream fa(a, std::ios::binary), fb(b, std::ios::binary);
    const std::string da((std::istreambuf_iterator<char>(fa)), {}), db((std::istreambuf_iterator<char>(fb)), {});
    EXPECT_GT(da.size(), 1000u);
    EXPECT_EQ(da, db) << extension;
    EXPECT_NE(first.out.find("fixed point"), std::string::npos);
  }
}

TEST_F(Cli, PhantomWritesADicomSeriesWithOneFilePerSlice) {
  const CommandRun run = run_organsim("phantom -o " + (dir_ / "ct.nii.gz").string() + " --dicom " +
                                          (dir_ / "dicom").string() + " --size 32,32,20 --spacing 12,12,10",
                                      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(run.err.empty()) << run.err;
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "dicom"), {}), 20);
  const CommandRun again = run_organsim(
      "phantom -o " + (dir_ / "ct2.nii.gz").string() + " --dicom " + (dir_ / "dicom").string() + " --size 32,32,20",
      dir_);
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("not an empty directory"), std::string::npos) << again.err;
}

TEST_F(Cli, PhantomRejectsBadOptionsAndUnknownExtensions) {
  const CommandRun small = run_organsim("phantom -o " + (dir_ / "ct.nii.gz").string() + " --size 8,8,8", dir_);
  EXPECT_EQ(small.exit_code, 1);
  EXPECT_NE(small.err.find("at least 16 voxels"), std::string::npos) << small.err;
  const CommandRun extension = run_organsim("phantom -o " + (dir_ / "ct.png").string() + " --size 16,16,16", dir_);
  EXPECT_EQ(extension.exit_code, 1);
  EXPECT_NE(extension.err.find("unsupported extension"), std::string::npos) << extension.err;
  EXPECT_EQ(files_in_dir(), 0u);
}

}  // namespace
}  // namespace organsim
