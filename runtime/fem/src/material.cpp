#include "organsim/fem/material.h"

namespace organsim::fem {

const char* material_name(MaterialModel model) noexcept {
  switch (model) {
    case MaterialModel::linear: return "linear";
    case MaterialModel::corotational: return "corotational";
    case MaterialModel::stvk: return "stvk";
    case MaterialModel::mooney_rivlin: return "mooney-rivlin";
  }
  return "?";
}

bool parse_material_model(const std::string& name, MaterialModel& model) noexcept {
  for (MaterialModel candidate :
       {MaterialModel::linear, MaterialModel::corotational, MaterialModel::stvk, MaterialModel::mooney_rivlin})
    if (name == material_name(candidate)) {
      model = candidate;
      return true;
    }
  return false;
}

double Material::lame_mu() const noexcept { return young_modulus / (2 * (1 + poisson_ratio)); }

double Material::lame_lambda() const noexcept {
  return young_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio));
}

Material Material::mooney_rivlin_from_young(double young_modulus, double poisson_ratio, double stabilization) {
  Material m;
  m.model = MaterialModel::mooney_rivlin;
  m.young_modulus = young_modulus;
  m.poisson_ratio = poisson_ratio;
  m.c1 = m.c2 = young_modulus / (8 * (1 + poisson_ratio));
  m.bulk_modulus = young_modulus / (3 * (1 - 2 * poisson_ratio));
  m.stabilization = stabilization;
  return m;
}

Material Material::from_young(MaterialModel model, double young_modulus, double poisson_ratio) {
  Material m;
  m.model = model;
  m.young_modulus = young_modulus;
  m.poisson_ratio = poisson_ratio;
  return m;
}

}  // namespace organsim::fem
