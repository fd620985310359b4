#include "organsim/realtime/model_registry.h"

#include <stdexcept>

// The registered models, in the order help texts list them: X(name) for the
// entry `name_model` that runtime/realtime/src/models/<name>/ defines.
#define ORGANSIM_REGISTERED_MODELS(X) X(beam) X(springs) X(linear) X(corotational) X(stvk) X(psh)
// The converged reference the fast models are measured against and matched to (docs/matching.md).
#define ORGANSIM_REFERENCE_MODEL psh_model

namespace organsim::realtime {

#define ORGANSIM_DECLARE_MODEL(name) extern const RegisteredModel name##_model;
ORGANSIM_REGISTERED_MODELS(ORGANSIM_DECLARE_MODEL)
#undef ORGANSIM_DECLARE_MODEL

namespace {

std::vector<const RegisteredModel*>& table() {
#define ORGANSIM_LIST_MODEL(name) &name##_model,
  static std::vector<const RegisteredModel*> models{ORGANSIM_REGISTERED_MODELS(ORGANSIM_LIST_MODEL)};
#undef ORGANSIM_LIST_MODEL
  return models;
}

}  // namespace

const std::vector<const RegisteredModel*>& registered_models() { return table(); }

bool register_model(const RegisteredModel& entry) {
  if (find_model(entry.name)) throw std::logic_error(std::string("two deformation models are called ") + entry.name);
  table().push_back(&entry);
  return true;
}

const RegisteredModel& default_model() { return *table().front(); }

const RegisteredModel& reference_model() { return ORGANSIM_REFERENCE_MODEL; }

const RegisteredModel* find_model(std::string_view name) noexcept {
  for (const RegisteredModel* model : registered_models())
    if (name == model->name) return model;
  return nullptr;
}

std::string model_names(std::string_view separator) {
  std::string names;
  for (const RegisteredModel* model : registered_models()) {
    if (!names.empty()) names += separator;
    names += model->name;
  }
  return names;
}

std::string unsuitable_model(const RegisteredModel& entry, const model::OrganModel& model) {
  if (entry.needs_beam_tables && model.beams.empty())
    return std::string("--model ") + entry.name +
           " needs beam tables, and this model was baked with --no-beam-tables: bake it again without that option "
           "(every other model runs on it as it is)";
  if (entry.needs_tetrahedra && (model.tetrahedra.empty() || model.volume_vertices.empty()))
    return std::string("--model ") + entry.name +
           ": the model has no tetrahedra: re-bake it with organsim bake, which meshes the volume";
  return "";
}

std::unique_ptr<DeformationModel> make_deformation_model(std::string_view name, const organ::Organ& organ,
                                                         const ModelOptions& options, std::size_t tools) {
  const RegisteredModel* entry = find_model(name);
  if (!entry)
    throw std::invalid_argument("unknown deformation model '" + std::string(name) + "': " + model_names(", "));
  if (const std::string why = unsuitable_model(*entry, organ.model()); !why.empty()) throw std::invalid_argument(why);
  return entry->make(organ, options, tools);
}

}  // namespace organsim::realtime
