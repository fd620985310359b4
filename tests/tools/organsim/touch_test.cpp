// `organsim touch`: OpenHaptics devices from a library loaded at run time (here
// the stand-in HD library).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

TEST_F(Cli, TouchRunsOpenHapticsDevicesFromALibraryLoadedAtRunTime) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const CommandRun run =
      run_organsim("touch " + model + " --hd-library " + std::string(FAKE_HD_LIBRARY) + " --seconds 0.5 --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_NEAR(j["servo_rate_hz"].get<double>(), 1000.0, 300.0);  // wide: CI runs two test programs at once
  EXPECT_GE(j["deformation_frames"].get<int>(), 25);
  EXPECT_DOUBLE_EQ(j["tools"][0]["max_force_n"].get<double>(), 2.5);  // the stand-in device's limit
  const CommandRun missing = run_organsim("touch " + model + " --hd-library /nonexistent/libHD.so --seconds 0.1", dir_);
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("cannot load the OpenHaptics HD library"), std::string::npos) << missing.err;
  EXPECT_EQ(std::count(missing.err.begin(), missing.err.end(), '\n'), 1) << missing.err;
}

}  // namespace
}  // namespace organsim
