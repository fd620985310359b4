// organsim: one program, one subcommand per job. See README.md and docs/cli.md.
#include <cstdio>
#include <exception>
#include <map>
#include <string>

#include "commands.h"
#include "organsim/version.h"

int main(int argc, char** argv) {
  CLI::App app{"organsim: patient-specific organ models from CT, and real-time simulation of them"};
  app.set_version_flag("--version", std::string("organsim ") + organsim::kProgramVersion);
  app.require_subcommand(1);
  std::map<const CLI::App*, organsim::cli::Command> commands;
  auto add = [&](const char* name, const char* description, auto add_command) {
    CLI::App* sub = app.add_subcommand(name, description);
    commands[sub] = add_command(*sub);
  };
  add("bake", "Bake a model file from a CT: segmentation, surface, tetrahedra, beam tables",
      organsim::cli::add_bake_command);
  add("info", "Summarize a model file (counts, size, volume, material, provenance)", organsim::cli::add_info_command);
  add("poke", "Press the organ with tools: the force each tool feels and the deformed organ (multi-beam model)",
      organsim::cli::add_poke_command);
  add("replay", "Replay a recorded multi-tool session through the real-time engine: forces, contacts, loop timings",
      organsim::cli::add_replay_command);
  add("touch", "Feel the organ with PHANToM / Touch devices (OpenHaptics, loaded at run time)",
      organsim::cli::add_touch_command);
  add("view", "The trainee's view: the organ deforming under replayed or mouse-driven tools (VTK + OpenCV)",
      organsim::cli::add_view_command);
  add("phantom", "Make a synthetic abdominal CT with a liver-like organ", organsim::cli::add_phantom_command);

  CLI11_PARSE(app, argc, argv);
  const CLI::App* chosen = app.get_subcommands().front();
  try {
    return commands.at(chosen)();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "organsim %s: error: %s\n", chosen->get_name().c_str(), e.what());
    return 1;
  }
}
