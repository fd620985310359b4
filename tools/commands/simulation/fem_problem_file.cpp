#include "fem_problem_file.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace organsim::cli {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw std::runtime_error(where + ": " + what);
}

double number(const json& value, const std::string& where) {
  if (!value.is_number()) fail(where, "expected a number");
  const double x = value.get<double>();
  if (!std::isfinite(x)) fail(where, "not a finite number");
  return x;
}

std::int32_t index(const json& value, const std::string& where) {
  if (!value.is_number_integer()) fail(where, "expected a non-negative integer index");
  const auto i = value.get<std::int64_t>();
  if (i < 0 || i > 2147483647) fail(where, "index out of range");
  return static_cast<std::int32_t>(i);
}

const json& array_of(const json& document, const char* key, bool required) {
  static const json empty = json::array();
  const auto it = document.find(key);
  if (it == document.end()) {
    if (required) fail(key, "missing (see docs/fem.md for the problem format)");
    return empty;
  }
  if (!it->is_array()) fail(key, "expected an array");
  return *it;
}

template <std::size_t N>
const json& tuple(const json& value, const std::string& where, const char* shape) {
  if (!value.is_array() || value.size() != N) fail(where, std::string("expected ") + shape);
  return value;
}

double optional_number(const json& object, const char* key, double fallback, const std::string& prefix) {
  const auto it = object.find(key);
  return it == object.end() ? fallback : number(*it, prefix + key);
}

fem::Material parse_material(const json& document) {
  const auto it = document.find("material");
  if (it == document.end()) fail("material", "missing (see docs/fem.md for the problem format)");
  if (!it->is_object()) fail("material", "expected an object");
  const json& m = *it;
  const auto model = m.find("model");
  if (model == m.end() || !model->is_string()) fail("material.model", "missing or not a string");
  fem::Material material;
  if (!fem::parse_material_model(model->get<std::string>(), material.model))
    fail("material.model",
         "unknown model '" + model->get<std::string>() + "' (linear, corotational, stvk or mooney-rivlin)");
  const auto required = [&](const char* key) {
    const auto field = m.find(key);
    if (field == m.end())
      fail(std::string("material.") + key,
           std::string("missing for the ") + fem::material_name(material.model) + " model");
    return number(*field, std::string("material.") + key);
  };
  if (material.model == fem::MaterialModel::mooney_rivlin) {
    material.c1 = required("c1");
    material.c2 = required("c2");
    material.bulk_modulus = required("bulk_modulus");
    material.stabilization = optional_number(m, "stabilization", 0.0, "material.");
  } else {
    material.young_modulus = required("young_modulus");
    material.poisson_ratio = required("poisson_ratio");
  }
  return material;
}

}  // namespace

fem::StaticProblem parse_fem_problem(const std::string& text) {
  json document;
  try {
    document = json::parse(text, nullptr, true, /*ignore_comments=*/true);
  } catch (const json::exception& e) {  // a syntax error, or a number beyond double's range
    throw std::runtime_error(std::string("not valid JSON: ") + e.what());
  }
  if (!document.is_object()) fail("problem", "expected one JSON object");
  fem::StaticProblem problem;
  const json& nodes = array_of(document, "nodes", true);
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const std::string where = "nodes[" + std::to_string(i) + "]";
    const json& p = tuple<3>(nodes[i], where, "[x, y, z] in metres");
    problem.mesh.nodes.emplace_back(number(p[0], where), number(p[1], where), number(p[2], where));
  }
  const json& tets = array_of(document, "tetrahedra", true);
  for (std::size_t i = 0; i < tets.size(); ++i) {
    const std::string where = "tetrahedra[" + std::to_string(i) + "]";
    const json& t = tuple<4>(tets[i], where, "[a, b, c, d] node indices");
    problem.mesh.tetrahedra.push_back({index(t[0], where), index(t[1], where), index(t[2], where), index(t[3], where)});
  }
  problem.material = parse_material(document);
  problem.density = optional_number(document, "density", 0.0, "");
  if (const auto g = document.find("gravity"); g != document.end()) {
    const json& v = tuple<3>(*g, "gravity", "[gx, gy, gz] in m/s²");
    problem.gravity = {number(v[0], "gravity"), number(v[1], "gravity"), number(v[2], "gravity")};
  }
  const json& fixed = array_of(document, "fixed", false);
  for (std::size_t i = 0; i < fixed.size(); ++i)
    problem.fixed.push_back(index(fixed[i], "fixed[" + std::to_string(i) + "]"));
  const json& prescribed = array_of(document, "prescribed", false);
  for (std::size_t i = 0; i < prescribed.size(); ++i) {
    const std::string where = "prescribed[" + std::to_string(i) + "]";
    const json& p = tuple<3>(prescribed[i], where, "[node, component 0|1|2, value in m]");
    problem.prescribed.push_back({index(p[0], where), index(p[1], where), number(p[2], where)});
  }
  const json& loads = array_of(document, "loads", false);
  for (std::size_t i = 0; i < loads.size(); ++i) {
    const std::string where = "loads[" + std::to_string(i) + "]";
    const json& l = tuple<3>(loads[i], where, "[node, component 0|1|2, value in N]");
    problem.loads.push_back({index(l[0], where), index(l[1], where), number(l[2], where)});
  }
  if (const auto steps = document.find("load_steps"); steps != document.end()) {
    if (!steps->is_number_integer()) fail("load_steps", "expected an integer");
    const auto n = steps->get<std::int64_t>();
    if (n < 1 || n > 100000) fail("load_steps", "must be between 1 and 100000");
    problem.load_steps = static_cast<int>(n);
  }
  problem.tolerance = optional_number(document, "tolerance", 1e-8, "");
  problem.initial_pressure = optional_number(document, "initial_pressure", 0.0, "");
  try {
    fem::validate(problem);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  return problem;
}

fem::StaticProblem read_fem_problem(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return parse_fem_problem(text.str());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("'" + path + "': " + e.what());
  }
}

}  // namespace organsim::cli
