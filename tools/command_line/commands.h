// A subcommand of the `organsim` program registers its options on the given
// CLI11 app and returns the function that runs it; the function returns the
// process exit code and throws std::exception with a one-line message on
// failure (the two families: simulation_commands.h, baking_commands.h).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace organsim::cli {

using Command = std::function<int()>;

}  // namespace organsim::cli
