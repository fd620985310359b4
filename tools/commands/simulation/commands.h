// The subcommands of the `organsim` program. Each registers its options on the
// given CLI11 app and returns the function that runs it; the function returns
// the process exit code and throws std::exception with a one-line message on
// failure.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace organsim::cli {

using Command = std::function<int()>;

Command add_bake_command(CLI::App& app);
Command add_calibrate_command(CLI::App& app);
Command add_compare_command(CLI::App& app);
Command add_export_command(CLI::App& app);
Command add_fem_command(CLI::App& app);
Command add_info_command(CLI::App& app);
Command add_phantom_command(CLI::App& app);
Command add_plot_command(CLI::App& app);
Command add_poke_command(CLI::App& app);
Command add_replay_command(CLI::App& app);
Command add_report_command(CLI::App& app);
Command add_segment_command(CLI::App& app);
Command add_serve_command(CLI::App& app);
Command add_springs_command(CLI::App& app);
Command add_touch_command(CLI::App& app);
Command add_view_command(CLI::App& app);

}  // namespace organsim::cli
