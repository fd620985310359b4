// The `organsim` program without `bake` and `phantom`: built only to check that
// the simulation commands link the runtime and never the offline pipeline
// (tests/CMakeLists.txt, simulation_commands_link_no_pipeline_libraries).
#include "simulation_commands.h"

int main(int argc, char** argv) {
  CLI::App app{"organsim simulation commands"};
  organsim::cli::CommandTable commands;
  organsim::cli::add_simulation_commands(app, commands);
  return organsim::cli::run_program(app, commands, argc, argv);
}
