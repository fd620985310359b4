// The conventions every `organsim` subcommand shares (tools/command_line/command_line.h,
// docs/cli.md#conventions): exit 0, 1 (input) or 2 (command line); one error
// line, `organsim CMD: error: …`; --help, --version, --quiet and --verbose on
// the program and on every subcommand. Each test checks every subcommand.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

/// A subcommand and the arguments its tests give it; "{dir}" stands for the
/// test's directory. No file named here exists: the command line is parsed
/// (and rejected) before any file is opened.
struct Subcommand {
  std::string name;
  std::vector<std::string> required;  ///< each of its required arguments, with a well-formed value
  std::string own_option;             ///< an option of its own, which its --help lists
  std::string bad_value;              ///< an option value that the command line rejects
  std::string input_error;            ///< arguments that parse, but name a missing or unusable input…
  std::string input_named;            ///< …which the error line names
};

const std::vector<Subcommand> kSubcommands = {
    {"bake",
     {"{dir}/ct.nii.gz", "-o {dir}/liver.organ"},
     "--surface-vertices",
     "--stations many",
     "{dir}/missing.nii.gz --seed 0,0,0 -o {dir}/liver.organ",
     "missing.nii.gz"},
    {"phantom", {"-o {dir}/ct.nii.gz"}, "--mask", "--size 16,16", "-o {dir}/ct.png --size 16,16,16", "ct.png"},
    {"fem", {"{dir}/problem.json"}, "--out", "--out {dir}/result.txt", "{dir}/missing.json", "missing.json"},
    {"info", {"{dir}/model.organ"}, "--beam", "--beam -1", "{dir}/missing.organ", "missing.organ"},
    {"plot",
     {"{dir}/trace.csv", "--x step", "--y dz", "-o {dir}/plot.png"},
     "--title",
     "--size 16,16",
     "{dir}/missing.csv --x step --y dz -o {dir}/plot.png",
     "missing.csv"},
    {"poke",
     {"{dir}/model.organ", "--tool 150,0,0/0,5,0"},
     "--merge",
     "--merge average",
     "{dir}/missing.organ --tool 150,0,0/0,5,0",
     "missing.organ"},
    {"replay",
     {"{dir}/model.organ", "{dir}/press.session"},
     "--forces",
     "--max-force -1",
     "{dir}/missing.organ {dir}/press.session --fast",
     "missing.organ"},
    {"springs", {}, "--integrator", "--dt 0", "{dir}/missing.organ", "missing.organ"},
    {"touch", {"{dir}/model.organ"}, "--hd-library", "--seconds 0", "{dir}/missing.organ", "missing.organ"},
    {"view", {"{dir}/model.organ"}, "--screenshot", "--frames -1", "{dir}/missing.organ --offscreen", "missing.organ"},
};

std::string prefix_of(const std::string& command) { return command.empty() ? "organsim" : "organsim " + command; }

/// `err` is exactly one line and starts "organsim COMMAND: error: ".
::testing::AssertionResult one_error_line(const std::string& err, const std::string& command) {
  if (err.empty() || err.back() != '\n' || std::count(err.begin(), err.end(), '\n') != 1)
    return ::testing::AssertionFailure() << "stderr is not one line:\n" << err;
  if (err.rfind(prefix_of(command) + ": error: ", 0) != 0)
    return ::testing::AssertionFailure() << "stderr does not start with \"" << prefix_of(command) << ": error: \":\n"
                                         << err;
  return ::testing::AssertionSuccess();
}

/// A usage error: exit 2, nothing on stdout, one error line that says `what`
/// and points to --help.
::testing::AssertionResult usage_error(const CommandRun& run, const std::string& command, const std::string& what) {
  if (run.exit_code != 2)
    return ::testing::AssertionFailure() << "exit code " << run.exit_code << ", not 2:\n" << run.err;
  if (!run.out.empty()) return ::testing::AssertionFailure() << "stdout is not empty:\n" << run.out;
  const ::testing::AssertionResult line = one_error_line(run.err, command);
  if (!line) return line;
  if (run.err.find(what) == std::string::npos)
    return ::testing::AssertionFailure() << "the error does not say \"" << what << "\":\n" << run.err;
  const std::string see = " (see " + prefix_of(command) + " --help)\n";
  if (run.err.size() < see.size() || run.err.compare(run.err.size() - see.size(), see.size(), see) != 0)
    return ::testing::AssertionFailure() << "the error does not end with \"" << see << "\":\n" << run.err;
  return ::testing::AssertionSuccess();
}

/// Arguments after a command's required ones, and what its usage error says about them.
using UsageCase = std::pair<std::string, std::string>;

class CliConventions : public Cli {
 protected:
  /// `arguments` with "{dir}" replaced by the test's directory.
  std::string in_dir(std::string arguments) const {
    for (std::size_t at = arguments.find("{dir}"); at != std::string::npos; at = arguments.find("{dir}", at))
      arguments.replace(at, 5, dir_.string());
    return arguments;
  }
  /// Runs `organsim COMMAND ARGUMENTS…` (skipping empty ones) in the test's directory.
  CommandRun run_command(const std::string& command, const std::vector<std::string>& arguments) const {
    std::string line = command;
    for (const std::string& argument : arguments)
      if (!argument.empty()) line += " " + in_dir(argument);
    return run_organsim(line, dir_);
  }
  CommandRun run_command(const Subcommand& command, const std::vector<std::string>& extra) const {
    std::vector<std::string> arguments = command.required;
    arguments.insert(arguments.end(), extra.begin(), extra.end());
    return run_command(command.name, arguments);
  }
  /// Writes the helper cylinder into the test's directory; returns its path.
  std::string write_cylinder() const {
    const std::string model = (dir_ / "cylinder.organ").string();
    model::write_organ_model_file(testing::make_cylinder_model(testing::CylinderSpec{}), model);
    return model;
  }
  /// How --verbose describes that model: "MODEL: N surface vertices, …".
  static std::string described(const std::string& model) {
    const testing::CylinderSpec spec;
    return model + ": " + std::to_string((spec.rings + 1) * spec.segments + 2) + " surface vertices, ";
  }
  /// Every subcommand, given its required arguments and then the arguments of
  /// `case_of(command)`, fails with a usage error that says what it names.
  void expect_usage_error_on_every_command(UsageCase (*case_of)(const Subcommand&)) const {
    for (const Subcommand& command : kSubcommands) {
      const auto [extra, what] = case_of(command);
      EXPECT_TRUE(usage_error(run_command(command, {extra}), command.name, what)) << command.name << " " << extra;
    }
  }
};

/// The lines of `text` that do not start with `skipped` (e.g. timings, which vary).
std::string lines_without(const std::string& text, const std::string& skipped) {
  std::istringstream in(text);
  std::string kept, line;
  while (std::getline(in, line))
    if (line.rfind(skipped, 0) != 0) kept += line + "\n";
  return kept;
}

TEST_F(CliConventions, VersionPrintsTheProgramNameAndVersionOnEveryCommand) {
  const CommandRun program = run_command("--version", {});
  ASSERT_EQ(program.exit_code, 0) << program.err;
  EXPECT_TRUE(std::regex_match(program.out, std::regex("organsim [0-9]+\\.[0-9]+\\.[0-9]+\n"))) << program.out;
  EXPECT_TRUE(program.err.empty()) << program.err;
  for (const Subcommand& command : kSubcommands) {
    // Without its required arguments: --version needs none.
    const CommandRun version = run_command(command.name, {"--version"});
    EXPECT_EQ(version.exit_code, 0) << command.name << ": " << version.err;
    EXPECT_EQ(version.out, program.out) << command.name;
    EXPECT_TRUE(version.err.empty()) << command.name << ": " << version.err;
  }
}

TEST_F(CliConventions, HelpListsTheOptionsOnStdoutOnEveryCommand) {
  const CommandRun program = run_command("--help", {});
  ASSERT_EQ(program.exit_code, 0) << program.err;
  for (const Subcommand& command : kSubcommands)
    EXPECT_NE(program.out.find("  " + command.name + " "), std::string::npos) << command.name << "\n" << program.out;
  for (const Subcommand& command : kSubcommands) {
    const CommandRun help = run_command(command.name, {"--help"});
    EXPECT_EQ(help.exit_code, 0) << command.name << ": " << help.err;
    EXPECT_TRUE(help.err.empty()) << command.name << ": " << help.err;
    EXPECT_NE(help.out.find("organsim " + command.name), std::string::npos) << help.out;
    for (const std::string& option : {std::string("--help"), std::string("--version"), std::string("--quiet"),
                                      std::string("--verbose"), command.own_option})
      EXPECT_NE(help.out.find(option), std::string::npos) << command.name << " --help lacks " << option << "\n"
                                                          << help.out;
  }
}

TEST_F(CliConventions, WithoutAKnownSubcommandTheProgramGivesAUsageError) {
  // Each says that a subcommand is required.
  for (const char* arguments : {"", "nosuchcommand", "--no-such-option"})
    EXPECT_TRUE(usage_error(run_command(arguments, {}), "", "subcommand")) << "organsim " << arguments;
}

TEST_F(CliConventions, AnUnknownOptionIsAUsageErrorThatNamesIt) {
  expect_usage_error_on_every_command([](const Subcommand&) {
    return UsageCase{"--no-such-option", "--no-such-option"};
  });
}

TEST_F(CliConventions, AMissingRequiredArgumentIsAUsageError) {
  for (const Subcommand& command : kSubcommands)
    for (std::size_t missing = 0; missing < command.required.size(); ++missing) {
      std::vector<std::string> arguments = command.required;
      arguments.erase(arguments.begin() + static_cast<std::ptrdiff_t>(missing));
      EXPECT_TRUE(usage_error(run_command(command.name, arguments), command.name, " is required"))
          << command.name << " without " << command.required[missing];
    }
}

TEST_F(CliConventions, ABadOptionValueIsAUsageErrorThatNamesTheOption) {
  expect_usage_error_on_every_command([](const Subcommand& command) {
    return UsageCase{command.bad_value, command.bad_value.substr(0, command.bad_value.find(' '))};
  });
}

TEST_F(CliConventions, QuietAndVerboseExcludeEachOther) {
  expect_usage_error_on_every_command([](const Subcommand&) {
    return UsageCase{"--quiet --verbose", "--quiet excludes --verbose"};
  });
}

TEST_F(CliConventions, AnInputErrorIsExitOneWithOneLineAndLeavesNothing) {
  for (const Subcommand& command : kSubcommands)
    for (const std::string& quiet : {std::string(), std::string("--quiet")}) {
      const CommandRun run = run_command(command.name, {command.input_error, quiet});
      EXPECT_EQ(run.exit_code, 1) << command.name << ": " << run.err;
      EXPECT_TRUE(run.out.empty()) << command.name << ": " << run.out;
      // Without --quiet, bake's progress comes first: the error is its last line.
      const std::string error =
          quiet.empty() && !run.err.empty() ? run.err.substr(run.err.rfind('\n', run.err.size() - 2) + 1) : run.err;
      EXPECT_TRUE(one_error_line(error, command.name)) << command.name << " " << quiet;
      EXPECT_EQ(run.err.find(": error: "), run.err.rfind(": error: ")) << "more than one error:\n" << run.err;
      EXPECT_NE(error.find(command.input_named), std::string::npos) << error;
      EXPECT_EQ(error.find("--help"), std::string::npos) << "an input error is not a usage error:\n" << error;
      EXPECT_EQ(files_in_dir(), 0u) << command.name;
    }
}

TEST_F(CliConventions, BakeQuietPrintsNothingOnStderrAndAPlainBakePrintsProgress) {
  const fs::path model = dir_ / "liver.organ";
  const CommandRun plain = run_organsim("bake " + quick_phantom_bake(model), dir_);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  // Not a terminal: one line as each stage starts and one as it ends.
  for (const char* stage : {"read CT", "segment", "fixed point", "surface", "tetrahedra", "beam tables", "assemble",
                            "supports", "site compliance"}) {
    EXPECT_NE(plain.err.find(std::string("organsim bake: ") + stage + " ...\n"), std::string::npos) << plain.err;
    EXPECT_NE(plain.err.find(std::string("organsim bake: ") + stage + " done in "), std::string::npos) << plain.err;
  }
  EXPECT_EQ(std::count(plain.err.begin(), plain.err.end(), '\n'), 18) << plain.err;
  const CommandRun quiet = run_organsim("bake " + quick_phantom_bake(model) + " --quiet", dir_);
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_TRUE(quiet.err.empty()) << quiet.err;
  // The report on stdout is the same (but for the time each stage took).
  EXPECT_FALSE(plain.out.empty());
  EXPECT_EQ(lines_without(quiet.out, "time "), lines_without(plain.out, "time "));
}

TEST_F(CliConventions, PokeVerboseDescribesTheModelQuietPrintsNothingAndTheReportStaysTheSame) {
  const std::string model = write_cylinder();
  const std::string poke = "poke " + model + " --tool 150,0,0/0,5,0";
  const CommandRun plain = run_organsim(poke, dir_);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_TRUE(plain.err.empty()) << plain.err;
  const CommandRun verbose = run_organsim(poke + " --verbose", dir_);
  ASSERT_EQ(verbose.exit_code, 0) << verbose.err;
  EXPECT_EQ(verbose.err.rfind("organsim poke: " + described(model), 0), 0u) << verbose.err;
  EXPECT_EQ(std::count(verbose.err.begin(), verbose.err.end(), '\n'), 1) << verbose.err;
  const CommandRun quiet = run_organsim(poke + " --quiet", dir_);
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_TRUE(quiet.err.empty()) << quiet.err;
  // The report on stdout is the same (but for the time each step took).
  EXPECT_NE(plain.out.find("force on the tool"), std::string::npos) << plain.out;
  EXPECT_EQ(lines_without(verbose.out, "time "), lines_without(plain.out, "time "));
  EXPECT_EQ(lines_without(quiet.out, "time "), lines_without(plain.out, "time "));
}

TEST_F(CliConventions, ReplayTouchAndViewDescribeTheirModelWithVerboseAndNotWithQuiet) {
  const std::string model = write_cylinder();
  const fs::path session = dir_ / "press.session";
  std::ofstream(session) << "# organsim session 1\n0,1,160,0,0\n0.1,1,150,0,0\n";
  const std::string hd = " --hd-library " + std::string(FAKE_HD_LIBRARY);
  // view: the model is described as it is loaded, before any window opens or
  // device is looked for; here the device library is missing (exit 1), so no
  // X server is needed.
  for (const auto& [command, arguments, exit_code] :
       {std::tuple<std::string, std::string, int>{"replay", session.string() + " --fast", 0},
        {"touch", hd + " --seconds 0.1", 0},
        {"view", "--phantom --hd-library /nonexistent/libHD.so", 1}}) {
    const CommandRun verbose = run_organsim(command + " " + model + " " + arguments + " --verbose", dir_);
    EXPECT_EQ(verbose.exit_code, exit_code) << command << ": " << verbose.err;
    EXPECT_NE(verbose.err.find("organsim " + command + ": " + described(model)), std::string::npos)
        << command << ": " << verbose.err;
    const CommandRun quiet = run_organsim(command + " " + model + " " + arguments + " --quiet", dir_);
    EXPECT_EQ(quiet.exit_code, exit_code) << command << ": " << quiet.err;
    EXPECT_EQ(quiet.err.find(described(model)), std::string::npos) << command << ": " << quiet.err;
    if (exit_code == 0) {
      EXPECT_TRUE(quiet.err.empty()) << command << ": " << quiet.err;
    }
  }
}

}  // namespace
}  // namespace organsim
