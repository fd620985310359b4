// The conventions every `organsim` subcommand shares (docs/cli.md):
//   - exit 0 on success, 1 when the input is wrong (a file, a value in it),
//     2 when the command line is wrong; each error is one line on stderr,
//     `organsim CMD: error: WHAT`;
//   - `--help` and `--version` on the program and on every subcommand;
//   - `--quiet` (no progress or notes on stderr; warnings and errors still
//     shown) and `--verbose` (extra detail on stderr) on every subcommand.
#pragma once

#include <array>
#include <map>
#include <string>

#include <CLI/CLI.hpp>

#include "command_line/commands.h"
#include "organsim/model/organ_model.h"

namespace organsim::realtime {
class Engine;
}

namespace organsim::cli {

/// The subcommands registered on an app and the function that runs each.
using CommandTable = std::map<const CLI::App*, Command>;

/// Registers subcommand `name` with the shared options (--version, --quiet,
/// --verbose) and the options `add_subcommand` adds.
void add_command(CLI::App& app, CommandTable& table, const char* name, const char* description,
                 Command (*add_subcommand)(CLI::App&));

/// Parses the command line, runs the chosen command and applies the
/// conventions above. Returns the process exit code.
int run_program(CLI::App& app, const CommandTable& table, int argc, char** argv);

enum class Verbosity { quiet, normal, verbose };
/// What the user asked for with --quiet or --verbose.
Verbosity verbosity();

/// "organsim COMMAND: MESSAGE" on stderr, unless --quiet: progress and notes.
void note(const std::string& command, const std::string& message);
/// The same, only with --verbose: detail a user asks for when checking a run.
void detail(const std::string& command, const std::string& message);
/// Option checks whose messages say what is wrong in plain words (CLI11's own
/// print the whole double range).
extern const CLI::Validator kPositive;               ///< a finite number > 0
extern const CLI::Validator kNonNegative;            ///< a finite number ≥ 0
extern const CLI::Validator kNonNegativeOrInfinity;  ///< a number ≥ 0, or inf

/// Parses "X,Y,Z", three numbers (NaN and infinity pass: the caller says
/// what a point that is not finite means); throws std::runtime_error starting
/// with `context` (the option and its whole value) and saying what is wrong.
std::array<double, 3> parse_xyz(const std::string& text, const std::string& context);

/// The names --model accepts: the registered models (realtime/model_registry.h).
const std::vector<std::string>& deformation_model_names();
/// "Deformation model: beam (multi-beam …), springs (…), …": the registered
/// models with their descriptions, for --model's help.
std::string deformation_model_help();
/// The models a fast model may be measured against: those with a static
/// equilibrium (the FEM models).
std::vector<std::string> reference_model_names();
/// --model NAME: which deformation model the engine runs (default beam).
/// `kind` receives a registered name (realtime::find_model).
void add_deformation_model_option(CLI::App& app, std::string& kind);

/// Loads the model file at `path` for a command that simulates it with the
/// deformation models `models` (registered names): throws std::runtime_error
/// (an input error) when the file is unreadable or invalid or lacks what one
/// of them needs (beam tables, tetrahedra; one line saying how to bake it);
/// with --verbose, says what it holds.
model::OrganModel load_simulation_model(const std::string& command, const std::string& path,
                                        const std::vector<std::string>& models);
/// "organsim COMMAND: warning: MESSAGE" on stderr, always.
void warn(const std::string& command, const std::string& message);
/// Warns, before a session starts, when the engine's deformation model is
/// estimated from its set-up (DeformationModel::estimated_frame_seconds) to
/// need more than one deformation period per frame, and says what to do.
void warn_if_frames_overrun(const std::string& command, const realtime::Engine& engine);

}  // namespace organsim::cli
