// What the `organsim` program's tests share (tests/tools/organsim/): running
// the program as users and scripts do, capturing its stdout, stderr and exit
// code, a fresh directory for each test, and the inputs several tests use.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>

#include "temp_directory.h"

namespace organsim::cli::testing {

namespace fs = std::filesystem;

/// What one run of the program gave.
struct CommandRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// Runs `program` (a path, or a command line's start) with `arguments` (already
/// shell-quoted); stderr goes through a file in `dir`.
CommandRun run_program(const std::string& program, const std::string& arguments, const std::filesystem::path& dir);
/// Runs the organsim binary with `arguments` (already shell-quoted), after
/// `prefix` (e.g. a wrapper command); stderr goes through a file in `dir`.
CommandRun run_organsim_with_prefix(const std::string& prefix, const std::string& arguments,
                                    const std::filesystem::path& dir);
CommandRun run_organsim(const std::string& arguments, const std::filesystem::path& dir);

/// The shipped sample data (data_samples/).
extern const std::filesystem::path kSamples;

/// The whole file, as bytes.
std::string read_bytes(const std::filesystem::path& path);

/// Small, quick bake options for the shipped phantom (a few seconds), writing `output`.
std::string quick_phantom_bake(const std::filesystem::path& output);

/// The fixture of every `organsim` test: `dir_`, an empty directory of its own.
class Cli : public organsim::testing::TempDirectoryTest {
 protected:
  std::size_t files_in_dir() const { return static_cast<std::size_t>(entries()); }
};

}  // namespace organsim::cli::testing
