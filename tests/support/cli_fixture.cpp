#include "cli_fixture.h"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <iterator>

namespace organsim::cli::testing {

CommandRun run_program(const std::string& program, const std::string& arguments, const fs::path& dir) {
  const fs::path err_file = dir / "stderr.txt";
  const std::string command = program + " " + arguments + " 2>" + err_file.string();
  CommandRun run;
  FILE* pipe = ::popen(command.c_str(), "r");
  std::array<char, 4096> buffer{};
  std::size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) run.out.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  std::ifstream err(err_file);
  run.err.assign(std::istreambuf_iterator<char>(err), {});
  fs::remove(err_file);
  return run;
}

CommandRun run_organsim_with_prefix(const std::string& prefix, const std::string& arguments, const fs::path& dir) {
  return run_program(prefix + ORGANSIM_EXECUTABLE, arguments, dir);
}

CommandRun run_organsim(const std::string& arguments, const fs::path& dir) {
  return run_organsim_with_prefix("", arguments, dir);
}

const fs::path kSamples = ORGANSIM_DATA_SAMPLES;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string quick_phantom_bake(const fs::path& output) {
  // Coarse everywhere, the clamp too (--clamp-cells 0): its 12 mm cells put
  // no node within the FEM clamp's 10 mm, so the bake skips the site
  // compliances, and tests that run a FEM model on it widen --fixed-radius.
  return (kSamples / "phantom_ct.nii.gz").string() + " --seed -65,5,0 --surface-vertices 800 --tet-size 12 " +
         "--clamp-cells 0 --stations 8 --section-samples 32 -o " + output.string();
}

}  // namespace organsim::cli::testing
