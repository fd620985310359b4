// Every deformation model the engine can run, in one table: its name (what
// --model, the Python module and session tools take), a line of help, what it
// needs in the model file, and how to make it on an organ.
//
// Adding a model: a folder runtime/core/src/models/<name>/ whose source defines
//   extern const organsim::realtime::RegisteredModel <name>_model;
// (a class implementing DeformationModel, and the entry that makes it), plus
// the one line X(<name>) in ORGANSIM_REGISTERED_MODELS
// (runtime/core/src/realtime/model_registry.cpp). CMake compiles every source under
// runtime/core/src/models/; the command line, the Python module, the help texts and
// the engine tests read this table (docs/architecture.md#adding-a-model).
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

namespace organsim::realtime {

struct RegisteredModel {
  const char* name;         ///< "beam", "springs", "linear", "corotational", "stvk", "psh"
  const char* description;  ///< one line for --help: "multi-beam (Ushiki et al.)"
  bool needs_beam_tables;   ///< refused on a model baked with --no-beam-tables
  bool needs_tetrahedra;    ///< refused on a model without tetrahedra
  /// The FEM material when the model is one of the FEM models: `poke`,
  /// `compare` and `calibrate` then solve its static problem with it.
  std::optional<fem::MaterialModel> fem_material;
  /// The model on `organ`, sized for `tools` tools. Throws
  /// std::invalid_argument when the organ or the options do not suit it.
  std::unique_ptr<DeformationModel> (*make)(const organ::Organ& organ, const ModelOptions& options, std::size_t tools);
};

/// Every registered model, in the order help texts list them.
const std::vector<const RegisteredModel*>& registered_models();

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
