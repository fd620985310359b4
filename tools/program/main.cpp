// organsim: one program, one subcommand per job. See README.md and docs/cli.md.
#include "baking_commands.h"
#include "simulation_commands.h"
#ifdef ORGANSIM_CHOOSES_BLAS_KERNELS
#include "blas_kernels.h"
#endif

int main(int argc, char** argv) {
#ifdef ORGANSIM_CHOOSES_BLAS_KERNELS
  organsim::fem::use_the_cpus_blas_kernels(argv);  // may start the program over once (blas_kernels.h)
#endif
  CLI::App app{"organsim: patient-specific organ models from CT, and real-time simulation of them"};
  organsim::cli::CommandTable commands;
  organsim::cli::add_baking_commands(app, commands);
  organsim::cli::add_simulation_commands(app, commands);
  return organsim::cli::run_program(app, commands, argc, argv);
}
