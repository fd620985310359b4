// organsim: one program, one subcommand per job. See README.md and docs/cli.md.
#include "command_line.h"

int main(int argc, char** argv) {
  CLI::App app{"organsim: patient-specific organ models from CT, and real-time simulation of them"};
  organsim::cli::CommandTable commands;
  organsim::cli::add_baking_commands(app, commands);
  organsim::cli::add_simulation_commands(app, commands);
  return organsim::cli::run_program(app, commands, argc, argv);
}
