// The commands that load a model and simulate it (and plot what they wrote):
// they link the runtime, never the offline pipeline.
#pragma once

#include "command_line/command_line.h"

namespace organsim::cli {

Command add_compare_command(CLI::App& app);
Command add_export_command(CLI::App& app);
Command add_fem_command(CLI::App& app);
Command add_info_command(CLI::App& app);
Command add_plot_command(CLI::App& app);
Command add_poke_command(CLI::App& app);
Command add_replay_command(CLI::App& app);
Command add_report_command(CLI::App& app);
Command add_serve_command(CLI::App& app);
Command add_springs_command(CLI::App& app);
Command add_touch_command(CLI::App& app);
Command add_view_command(CLI::App& app);

/// compare, export, fem, info, plot, poke, replay, report, serve, springs,
/// touch, view, registered on `app`.
void add_simulation_commands(CLI::App& app, CommandTable& table);

}  // namespace organsim::cli
