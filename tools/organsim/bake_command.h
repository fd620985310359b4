// `organsim bake` for other programs (the Python module's organsim.bake).
#pragma once

#include <string>
#include <vector>

namespace organsim::cli {

/// Bakes with the command's own option definitions: `arguments` are what
/// follows `organsim bake` on a command line (the CT, `-o MODEL`, options).
/// Writes the model file and returns the report exactly as `bake --json` prints
/// it. Prints nothing. Throws std::invalid_argument for arguments the command
/// would refuse (CLI11's message) and std::runtime_error with the pipeline's
/// one-line messages.
std::string bake_report_for_arguments(std::vector<std::string> arguments);

}  // namespace organsim::cli
