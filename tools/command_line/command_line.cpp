#include "command_line/command_line.h"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "organsim/model/model_file.h"
#include "organsim/realtime/engine.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/version.h"

namespace organsim::cli {
namespace {

constexpr int kInputError = 1;
constexpr int kUsageError = 2;

Verbosity g_verbosity = Verbosity::normal;

std::string one_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  for (std::size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at)) text.replace(at, 1, "; ");
  return text;
}

/// The subcommand named on the command line, for the error prefix; "" if none.
std::string named_subcommand(const CLI::App& app, int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    for (const CLI::App* sub : app.get_subcommands({}))
      if (sub->get_name() == argv[i]) return sub->get_name();
  return "";
}

}  // namespace

void add_command(CLI::App& app, CommandTable& table, const char* name, const char* description,
                 Command (*add_subcommand)(CLI::App&)) {
  CLI::App* sub = app.add_subcommand(name, description);
  sub->set_version_flag("--version", std::string("organsim ") + kProgramVersion);
  auto* quiet = sub->add_flag_callback(
      "--quiet", [] { g_verbosity = Verbosity::quiet; },
      "No progress or notes on stderr (warnings and errors are still shown)");
  auto* verbose = sub->add_flag_callback(
      "--verbose", [] { g_verbosity = Verbosity::verbose; }, "More detail on stderr (what was loaded, each stage)");
  quiet->excludes(verbose);
  table[sub] = add_subcommand(*sub);
}

int run_program(CLI::App& app, const CommandTable& table, int argc, char** argv) {
  // Past a file-size limit (ulimit -f) write() then fails with EFBIG, which the
  // writers report in one line and clean up after, instead of SIGXFSZ killing
  // the program with a temporary file left half written.
  std::signal(SIGXFSZ, SIG_IGN);
  app.set_version_flag("--version", std::string("organsim ") + kProgramVersion);
  app.require_subcommand(1);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end the parse with exit code 0: CLI11 prints them.
    if (e.get_exit_code() == 0) return app.exit(e);
    const std::string command = named_subcommand(app, argc, argv);
    std::fprintf(stderr, "organsim%s%s: error: %s (see organsim%s%s --help)\n", command.empty() ? "" : " ",
                 command.c_str(), one_line(e.what()).c_str(), command.empty() ? "" : " ", command.c_str());
    return kUsageError;
  }
  const CLI::App* chosen = app.get_subcommands().front();
  try {
    return table.at(chosen)();
  } catch (const CLI::ParseError& e) {
    // A command's own check of how its options fit together (CLI11's error type).
    std::fprintf(stderr, "organsim %s: error: %s (see organsim %s --help)\n", chosen->get_name().c_str(),
                 one_line(e.what()).c_str(), chosen->get_name().c_str());
    return kUsageError;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "organsim %s: error: %s\n", chosen->get_name().c_str(), one_line(e.what()).c_str());
    return kInputError;
  }
}

namespace {

CLI::Validator number_check(const char* description, bool (*accept)(double), bool infinity_allowed = false) {
  return CLI::Validator(
      [description, accept, infinity_allowed](std::string& text) -> std::string {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        const bool number = std::isfinite(value) || (infinity_allowed && value > 0.0 && std::isinf(value));
        if (text.empty() || end != text.c_str() + text.size() || !number || !accept(value))
          return "'" + text + "' is not " + description;
        return {};
      },
      description);
}

}  // namespace

const CLI::Validator kPositive = number_check("a positive number", [](double v) { return v > 0.0; });
const CLI::Validator kNonNegative = number_check("a number >= 0", [](double v) { return v >= 0.0; });
const CLI::Validator kNonNegativeOrInfinity = number_check(
    "a number >= 0 or inf", [](double v) { return v >= 0.0; }, true);

std::array<double, 3> parse_xyz(const std::string& text, const std::string& context) {
  std::array<double, 3> v{};
  std::size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t end = k < 2 ? text.find(',', start) : text.size();
    if (end == std::string::npos) throw std::runtime_error(context + ": expected X,Y,Z in millimetres");
    const std::string field = text.substr(start, end - start);
    char* stop = nullptr;
    v[static_cast<std::size_t>(k)] = std::strtod(field.c_str(), &stop);
    if (field.empty() || stop != field.c_str() + field.size())
      throw std::runtime_error(context + ": '" + field + "' is not a number; expected X,Y,Z in millimetres");
    start = end + 1;
  }
  return v;
}

const std::vector<std::string>& deformation_model_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> registered;
    for (const realtime::RegisteredModel* model : realtime::registered_models()) registered.emplace_back(model->name);
    return registered;
  }();
  return names;
}

std::string deformation_model_help() {
  std::string help = "Deformation model:";
  for (const realtime::RegisteredModel* model : realtime::registered_models())
    help += fmt::format("{} {} ({})", help.back() == ':' ? "" : ";", model->name, model->description);
  return help + "; docs/architecture.md";
}

std::vector<std::string> reference_model_names() {
  std::vector<std::string> names;
  for (const realtime::RegisteredModel* model : realtime::registered_models())
    if (model->static_press == realtime::StaticPress::equilibrium) names.emplace_back(model->name);
  return names;
}

void add_deformation_model_option(CLI::App& app, std::string& kind) {
  app.add_option("--model", kind, deformation_model_help())
      ->check(CLI::IsMember(deformation_model_names()))
      ->capture_default_str();
}

Verbosity verbosity() { return g_verbosity; }

void note(const std::string& command, const std::string& message) {
  if (g_verbosity != Verbosity::quiet) std::fprintf(stderr, "organsim %s: %s\n", command.c_str(), message.c_str());
}

void detail(const std::string& command, const std::string& message) {
  if (g_verbosity == Verbosity::verbose) std::fprintf(stderr, "organsim %s: %s\n", command.c_str(), message.c_str());
}

model::OrganModel load_simulation_model(const std::string& command, const std::string& path,
                                        const std::vector<std::string>& models) {
  model::ModelReadResult read = model::read_organ_model_file(path);
  if (!read) throw std::runtime_error(read.error);
  const model::OrganModel& model = *read.model;
  detail(command, fmt::format("{}: {} surface vertices, {} triangles, {} tetrahedra, {} beam stations, E = {:g} Pa",
                              path, model.surface_vertices.size(), model.surface_triangles.size(),
                              model.tetrahedra.size(), model.beams.stations_per_beam, model.material.young_modulus));
  for (const std::string& name : models) {
    const realtime::RegisteredModel* entry = realtime::find_model(name);
    if (!entry) throw std::runtime_error("unknown deformation model '" + name + "': " + realtime::model_names(", "));
    if (const std::string why = realtime::unsuitable_model(*entry, model); !why.empty())
      throw std::runtime_error(path + ": " + why);
  }
  return std::move(*read.model);
}

void warn(const std::string& command, const std::string& message) {
  std::fprintf(stderr, "organsim %s: warning: %s\n", command.c_str(), message.c_str());
}

void warn_if_frames_overrun(const std::string& command, const realtime::Engine& engine) {
  const double frame = engine.model().estimated_frame_seconds(), period = engine.options().deformation_period;
  if (!(frame > period)) return;
  warn(command,
       fmt::format("the {} model's frames are estimated at {:.1f} ms on this machine (one assembly and one "
                   "solve on {} tetrahedra, timed at set-up), longer than the {:.1f} ms deformation period: "
                   "frames will be dropped and the organ will lag the tools. Bake the model with a coarser "
                   "--tet-size, or choose a faster --model (docs/fem.md#finer-meshes)",
                   engine.model().name(), frame * 1e3, engine.organ().model().tetrahedra.size(), period * 1e3));
}

}  // namespace organsim::cli
