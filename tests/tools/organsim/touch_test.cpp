// `organsim touch`: OpenHaptics devices from a library loaded at run time (here
// the stand-in HD library).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
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

// A device lost mid-session: the user is told when it fails and when it is
// back, and the summary counts it; the program goes on with the other device.
TEST_F(Cli, TouchReportsADeviceThatFailsMidSession) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const CommandRun run = run_organsim_with_prefix("FAKEHD_FAIL=1:0.2:0.5:770 ",
                                                  "touch " + model + " --hd-library " + std::string(FAKE_HD_LIBRARY) +
                                                      " --device a --device b --seconds 0.8 --json",
                                                  dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("device 2 reported HD error 0x0302 at 0."), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("its force fades to zero and the other devices go on"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("device 2 is back at"), std::string::npos) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["tools"][0]["hd_error_ticks"], 0);
  EXPECT_GT(j["tools"][1]["hd_error_ticks"].get<int>(), 150);  // 0.3 s of 1 kHz ticks, with CI's jitter
  EXPECT_EQ(j["tools"][1]["last_hd_error"], 770);
  EXPECT_EQ(j["tools"][1]["pose_faults"], 1);
  EXPECT_GE(j["deformation_frames"].get<int>(), 40);  // the program went on
}

// A training report of a live session: the stand-in devices' ticks, and the
// failed device reported as such on the page.
TEST_F(Cli, TouchWritesATrainingReportThatShowsAFailedDevice) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const fs::path report = dir_ / "report";
  const CommandRun run =
      run_organsim_with_prefix("FAKEHD_FAIL=1:0.2:0.5:770 ",
                               "touch " + model + " --hd-library " + std::string(FAKE_HD_LIBRARY) +
                                   " --device a --device b --seconds 0.8 " + "--json --report " + report.string(),
                               dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(nlohmann::json::parse(run.out)["report"], (report / "index.html").string());
  std::ifstream in(report / "metrics.json");
  const nlohmann::json metrics = nlohmann::json::parse(in);
  ASSERT_EQ(metrics["tools"].size(), 2u);
  EXPECT_GT(metrics["tools"][0]["force_ticks"].get<int>(), 400);  // 0.8 s at 1 kHz, with CI's jitter
  EXPECT_EQ(metrics["loop_health"]["pose_faults"], 1);
  EXPECT_NEAR(metrics["loop_health"]["machine_floor"]["probe_s"].get<double>(), 0.8, 0.1);  // probed for as long
  std::ifstream page(report / "index.html");
  const std::string html{std::istreambuf_iterator<char>(page), {}};
  EXPECT_NE(html.find("<td class=\"warn\">1 — a tool's device stopped giving its pose</td>"), std::string::npos);
}

}  // namespace
}  // namespace organsim
