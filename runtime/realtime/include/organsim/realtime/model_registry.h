// Every deformation model the engine can run, in one table: its name (what
// --model, the Python module and session tools take), a line of help, what it
// needs in the model file, its settings, how a static press solves it, and how
// to make it on an organ.
//
// Adding a model: a folder runtime/realtime/src/models/<name>/ whose source defines
//   extern const organsim::realtime::RegisteredModel <name>_model;
// (a class implementing DeformationModel, its options and parameters
// (model_options.h), and the entry that makes it), plus the one line X(<name>)
// in ORGANSIM_REGISTERED_MODELS (runtime/realtime/src/model_registry.cpp).
// CMake compiles every source under runtime/realtime/src/models/; the command line,
// the Python module, the help texts, the static presses and the engine tests
// read this table (docs/architecture.md#adding-a-model). A model outside the
// runtime (a test's) registers itself with ORGANSIM_REGISTER_MODEL.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "organsim/fem/material.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/deformation_model.h"
#include "organsim/realtime/model_options.h"

namespace organsim::realtime {

/// How `poke`, `compare` and `calibrate` solve a static press of the model.
enum class StaticPress {
  beam_tables,  ///< one deformation of the beams the model file's tables give (the multi-beam closed form)
  settled,      ///< stepped at 60 Hz with the press held until the organ settles (any model)
  equilibrium,  ///< the FEM static equilibrium of `fem_material`, by Newton's method
};

/// What `organsim calibrate` fits of a model matched to the FEM reference
/// (docs/cli.md#organsim-calibrate); empty for a model it fits nothing of.
struct ModelCalibration {
  /// The material's stiffness scale that the model's beams or springs take
  /// (E × scale): the model's force is linear in it, and calibrate fits it to
  /// the reference's forces.
  double model::Material::*stiffness_scale = nullptr;
  /// Whether the model's displacement falls off with the material's
  /// attenuation, exp(−β ln α d) (the multi-beam model's space distortion):
  /// calibrate then fits β to the reference's displacements.
  bool attenuated = false;
};

struct RegisteredModel {
  const char* name;         ///< "beam", "springs", "linear", "corotational", "stvk", "psh"
  const char* description;  ///< one line for --help: "multi-beam (Ushiki et al.)"
  bool needs_beam_tables;   ///< refused on a model baked with --no-beam-tables
  bool needs_tetrahedra;    ///< refused on a model without tetrahedra
  /// The FEM material when the model is one of the FEM models: `poke`,
  /// `compare` and `calibrate` then solve its static problem with it.
  std::optional<fem::MaterialModel> fem_material;
  StaticPress static_press;
  /// For a model matched to the FEM reference (its contacts give a tool of
  /// finite size the site law of the model file's site compliances,
  /// docs/matching.md; `calibrate` fits it): whether `options` keep it
  /// matched. nullptr for a model that is never matched.
  bool (*matches_reference)(const ModelOptions& options);
  ModelCalibration calibration;
  /// The settings it takes by name (model_options.h), `parameter_count` of them.
  const ModelParameter* parameters;
  std::size_t parameter_count;
  /// The model on `organ`, sized for `tools` tools. Throws
  /// std::invalid_argument when the organ or the options do not suit it.
  std::unique_ptr<DeformationModel> (*make)(const organ::Organ& organ, const ModelOptions& options, std::size_t tools);
};

/// Every registered model, in the order help texts list them (the runtime's,
/// then those registered with ORGANSIM_REGISTER_MODEL).
const std::vector<const RegisteredModel*>& registered_models();

/// Adds a model defined outside the runtime (a test's) to the table; at start-up only,
/// through ORGANSIM_REGISTER_MODEL(entry) at namespace scope in its source.
bool register_model(const RegisteredModel& entry);
#define ORGANSIM_REGISTER_MODEL(entry) \
  [[maybe_unused]] static const bool organsim_registered_##entry = ::organsim::realtime::register_model(entry)

/// The model the commands run when none is named (the first registered: beam).
const RegisteredModel& default_model();

/// The model static presses are measured against when none is named: the
/// pressure-stabilized hyperelastic FEM (psh), the converged reference of docs/matching.md.
const RegisteredModel& reference_model();

/// The model called `name`, or nullptr.
const RegisteredModel* find_model(std::string_view name) noexcept;

/// The registered names joined by `separator`: "beam, springs, linear, …".
std::string model_names(std::string_view separator = ", ");

/// Why `entry` cannot run on `model` (one line that says how to bake a model
/// that it can run on), or "" when it can.
std::string unsuitable_model(const RegisteredModel& entry, const model::OrganModel& model);

/// The model called `name` on `organ`, sized for `tools` tools. Throws
/// std::invalid_argument with one line when the name is unknown (listing the
/// names), the organ lacks what the model needs, or the options do not suit it.
std::unique_ptr<DeformationModel> make_deformation_model(std::string_view name, const organ::Organ& organ,
                                                         const ModelOptions& options, std::size_t tools);

}  // namespace organsim::realtime
