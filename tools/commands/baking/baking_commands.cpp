#include "baking_commands.h"

namespace organsim::cli {

void add_baking_commands(CLI::App& app, CommandTable& table) {
  add_command(app, table, "bake", "Bake a model file from a CT: segmentation, surface, tetrahedra, beam tables",
              add_bake_command);
  add_command(app, table, "segment", "Segment the organ of a CT from seeds into a mask (the bake's first stage alone)",
              add_segment_command);
  add_command(app, table, "phantom", "Make a synthetic abdominal CT with a liver-like organ", add_phantom_command);
  add_command(app, table, "calibrate",
              "Fit the multi-beam and mass-spring models' attenuation and stiffness to a FEM reference on this organ, "
              "or measure them against it (--evaluate)",
              add_calibrate_command);
}

}  // namespace organsim::cli
