// The commands that run the offline pipeline: bake, segment, phantom, and
// calibrate (which re-meshes the organ around each press for its reference).
#pragma once

#include "command_line/command_line.h"

namespace organsim::cli {

Command add_bake_command(CLI::App& app);
Command add_calibrate_command(CLI::App& app);
Command add_phantom_command(CLI::App& app);
Command add_segment_command(CLI::App& app);

/// bake, segment, phantom, calibrate, registered on `app`.
void add_baking_commands(CLI::App& app, CommandTable& table);

}  // namespace organsim::cli
