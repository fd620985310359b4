#include "command_line.h"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "model_tuning.h"
#include "organsim/devices/session_file.h"
#include "organsim/model/model_file.h"
#include "organsim/realtime/engine.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/realtime/session_playback.h"
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
              "Press the organ with tools: the force each tool feels and the deformed organ (multi-beam model)",
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

void warn_if_depth_curve_rescaled(const std::string& command, const model::OrganModel& model,
                                  const std::vector<std::string>& models, const ModelTuning& tuning,
                                  const devices::Session* session) {
  const model::SiteCompliance& sites = model.sites;
  const bool matched = std::any_of(models.begin(), models.end(), [&](const std::string& m) {
    const realtime::RegisteredModel* entry = realtime::find_model(m);
    return entry && entry->matches_reference && entry->matches_reference(tuning.models);
  });
  if (sites.depth_curve.empty() || !matched) return;
  realtime::EngineOptions options;
  options.tip_radius = tuning.tip_radius;
  if (session) options = realtime::with_session_tips(options, *session);
  std::vector<double> radii;  // m, each tool's as the engine will take it
  for (std::size_t k = 0; k < (session ? session->tools.size() : 1); ++k) radii.push_back(options.tip_radius_of(k));
  std::vector<double> warned;
  for (const double radius : radii) {
    if (!(radius > 0.0) || std::abs(radius - sites.curve_tip_radius) <= 1e-9 ||
        std::find(warned.begin(), warned.end(), radius) != warned.end())
      continue;
    warned.push_back(radius);
    warn(command, fmt::format("the model's depth curve was fitted for a {:g} mm tip, and a tool's is {:g} mm: the "
                              "curve is read at the same depth relative to the radius, which follows the tip's own "
                              "contact but not the organ's bending (that depends on the depth alone); for a curve of "
                              "this tip run organsim calibrate with --tip-radius {:g} "
                              "(docs/matching.md#the-depth-curve-organsim-calibrate)",
                              sites.curve_tip_radius * 1e3, radius * 1e3, radius * 1e3));
  }
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
