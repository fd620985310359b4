// A fresh, empty directory for each test (named after the test and the
// process, so parallel test runs never share one), removed afterwards.
#pragma once

#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

namespace organsim::testing {

class TempDirectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("organsim_" + std::string(test->test_suite_name()) + "_" + test->name() + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  /// How many entries `directory` holds (default: the test's directory).
  long entries(const std::filesystem::path& directory) const {
    return std::distance(std::filesystem::directory_iterator(directory), {});
  }
  long entries() const { return entries(dir_); }

  std::filesystem::path dir_;
};

}  // namespace organsim::testing
