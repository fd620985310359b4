// A model added in a test folder alone (tests/models/rigid/: a rigid organ,
// each contact a spring of its --rigid-stiffness) runs through every command
// as the runtime's models do: the program built with it takes its name and its
// setting in poke, compare and replay, and says both in --help.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

CommandRun run_with_test_models(const std::string& arguments, const fs::path& dir) {
  return run_program(ORGANSIM_WITH_TEST_MODELS, arguments, dir);
}

std::string write_cylinder(const fs::path& dir) {
  const std::string model = (dir / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  return model;
}

TEST_F(Cli, PokeRunsATestOnlyModelWithItsOwnSetting) {
  const std::string model = write_cylinder(dir_);
  // 5 mm down at the far cap's rim, held (no slip): F = -k d.
  const CommandRun run = run_with_test_models(
      "poke " + model + " --model rigid --rigid-stiffness 300 --tool 150,0,30/0,0,-5 --friction inf --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["deformation_model"], "rigid");
  EXPECT_EQ(j["rigid-stiffness"], 300.0);
  const nlohmann::json& force = j["tools"][0]["force_n"];
  EXPECT_NEAR(force[0].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(force[1].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(force[2].get<double>(), 300.0 * 0.005, 1e-9);
  EXPECT_EQ(j["organ"]["max_displacement_mm"].get<double>(), 0.0);  // it never deforms

  const CommandRun refused =
      run_with_test_models("poke " + model + " --model rigid --rigid-stiffness -1 --tool 150,0,30/0,0,-5 --json", dir_);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("--rigid-stiffness"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("positive"), std::string::npos) << refused.err;
}

TEST_F(Cli, CompareMeasuresATestOnlyModelAgainstTheReference) {
  const std::string model = write_cylinder(dir_);
  const CommandRun run = run_with_test_models(
      "compare " + model + " --tool 150,0,30/0,0,-5 --fixed-radius 31 --friction inf --models rigid,psh --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  ASSERT_TRUE(j["models"].contains("rigid"));
  EXPECT_NEAR(j["models"]["rigid"]["forces_n"][0][2].get<double>(), 200.0 * 0.005, 1e-9);  // the default stiffness
  EXPECT_GT(j["models"]["rigid"]["mean_difference"].get<double>(), 0.0);  // the reference deforms; it does not
}

TEST_F(Cli, ReplayRunsATestOnlyModelThroughTheEngine) {
  const std::string model = write_cylinder(dir_);
  const fs::path session = dir_ / "press.session";
  std::ofstream(session) << "# organsim session 1\n0,1,160,0,0\n0.3,1,145,2,0\n0.6,1,160,0,0\n";
  const CommandRun run =
      run_with_test_models("replay " + model + " " + session.string() + " --model rigid --fast --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["rigid-stiffness"], 200.0);
  EXPECT_GE(j["tools"][0]["contacts"].get<int>(), 1);
  // 5 mm into the cap at the deepest, the spring gives about k 5 mm (the force loop's ramp aside).
  EXPECT_GT(j["tools"][0]["peak_force_n"].get<double>(), 0.5);
  EXPECT_LT(j["tools"][0]["peak_force_n"].get<double>(), 200.0 * 0.0055);
}

TEST_F(Cli, HelpListsATestOnlyModelAndItsSettingOnlyWhereItIsBuiltIn) {
  const CommandRun with = run_with_test_models("replay --help", dir_);
  ASSERT_EQ(with.exit_code, 0) << with.err;
  EXPECT_NE(with.out.find("rigid (a rigid organ"), std::string::npos) << with.out;
  EXPECT_NE(with.out.find("--rigid-stiffness"), std::string::npos) << with.out;
  const CommandRun without = run_organsim("replay --help", dir_);
  ASSERT_EQ(without.exit_code, 0) << without.err;
  EXPECT_EQ(without.out.find("rigid"), std::string::npos) << without.out;
}

}  // namespace
}  // namespace organsim
