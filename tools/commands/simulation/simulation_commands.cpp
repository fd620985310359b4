#include "simulation_commands.h"

namespace organsim::cli {

void add_simulation_commands(CLI::App& app, CommandTable& table) {
  add_command(app, table, "compare",
              "Press the organ the same way with every deformation model and measure each against a reference (psh)",
              add_compare_command);
  add_command(app, table, "export",
              "Write a model's surface (.vtp/.stl/.obj), tetrahedra (.vtu) or a beam table (.csv) for other programs",
              add_export_command);
  add_command(app, table, "fem",
              "Solve a static FEM problem file (linear, corotational, stvk, mooney-rivlin): displacements, pressures",
              add_fem_command);
  add_command(app, table, "info", "Summarize a model file (counts, size, volume, material, provenance)",
              add_info_command);
  add_command(app, table, "plot", "Plot columns of a CSV file (forces, a springs trace) as a PNG line chart",
              add_plot_command);
  add_command(app, table, "poke",
              "Press the organ with tools: the force each tool feels and the deformed organ (any model; --model)",
              add_poke_command);
  add_command(app, table, "replay",
              "Replay a recorded multi-tool session through the real-time engine: forces, contacts, loop timings",
              add_replay_command);
  add_command(app, table, "report",
              "Rebuild a training report (web page and metrics) from a run recorded with --report", add_report_command);
  add_command(app, table, "serve",
              "Serve the real-time engine over OpenIGTLink (3D Slicer, PLUS): tool poses in, organ and forces out",
              add_serve_command);
  add_command(app, table, "springs",
              "The mass-spring model's experiment: a grid or an organ, an integrator, a force; positions and energy",
              add_springs_command);
  add_command(app, table, "touch", "Feel the organ with PHANToM / Touch devices (OpenHaptics, loaded at run time)",
              add_touch_command);
  add_command(app, table, "view",
              "The trainee's view: the organ deforming under replayed or mouse-driven tools (VTK + OpenCV)",
              add_view_command);
}

}  // namespace organsim::cli
