// `organsim fem`: a problem file solved (text and JSON reports), the JSON
// document's shape and its agreement with the library, the ParaView output,
// and malformed problems (exit 1, one line naming the field or element).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include "cli_fixture.h"
#include "organsim/fem/static_solver.h"

namespace organsim {
namespace {

using namespace cli::testing;
using nlohmann::json;

/// A 3 × 1 × 1 cm bar of 6 × 2 × 2 cells, fixed at x = 0, its end pushed
/// along x (and sagging under its own weight), as a problem document.
json bar_document(const std::string& model) {
  const fem::TetMesh mesh = fem::box_mesh({6, 2, 2}, {0.03, 0.01, 0.01});
  json doc;
  doc["nodes"] = json::array();
  for (const auto& p : mesh.nodes) doc["nodes"].push_back({p.x(), p.y(), p.z()});
  doc["tetrahedra"] = mesh.tetrahedra;
  if (model == "mooney-rivlin")
    doc["material"] = {
        {"model", model}, {"c1", 8.39e3}, {"c2", 8.39e3}, {"bulk_modulus", 1.667e6}, {"stabilization", 10}};
  else
    doc["material"] = {{"model", model}, {"young_modulus", 5e4}, {"poisson_ratio", 0.4}};
  doc["density"] = 1000;
  doc["gravity"] = {0, 0, -9.81};
  doc["fixed"] = json::array();
  doc["prescribed"] = json::array();
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n) {
    if (mesh.nodes[n].x() == 0) doc["fixed"].push_back(n);
    if (std::abs(mesh.nodes[n].x() - 0.03) < 1e-12) doc["prescribed"].push_back({n, 0, 0.003});
  }
  doc["loads"] = json::array({{7, 1, 1e-3}});
  doc["load_steps"] = 2;
  return doc;
}

void write(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

TEST_F(Cli, FemSolvesAProblemFileForEveryMaterial) {
  for (const std::string model : {"linear", "corotational", "stvk", "mooney-rivlin"}) {
    const json doc = bar_document(model);
    write(dir_ / "bar.json", doc.dump());
    const CommandRun run =
        run_organsim("fem " + (dir_ / "bar.json").string() + " --json --linear-solver simplicial", dir_);
    ASSERT_EQ(run.exit_code, 0) << model << ": " << run.err;
    const json out = json::parse(run.out);
    EXPECT_EQ(out["linear_solver"], fem::make_simplicial_factorization()->name());
    EXPECT_TRUE(out["converged"].get<bool>());
    ASSERT_EQ(out["displacements"].size(), doc["nodes"].size());
    EXPECT_EQ(out["newton_iterations"].size(), 2u);
    EXPECT_EQ(out["pressures"].size(), model == "mooney-rivlin" ? doc["tetrahedra"].size() : 0u);
    EXPECT_EQ(out["reactions"].size(), 3u);
    EXPECT_GE(out["time_s"]["assembly"].get<double>(), 0);
    EXPECT_GE(out["time_s"]["solve"].get<double>(), 0);
    // The prescribed end moved exactly as asked; the fixed end did not move.
    const std::size_t end = doc["prescribed"][0][0];
    EXPECT_DOUBLE_EQ(out["displacements"][end][0].get<double>(), 0.003);
    EXPECT_EQ(out["displacements"][0], json({0, 0, 0}));
    // The supports carry the weight and the load (N).
    const double weight = 1000 * 0.03 * 0.01 * 0.01 * 9.81;
    EXPECT_NEAR(out["reactions"][2].get<double>(), weight, 1e-7);
    EXPECT_NEAR(out["reactions"][1].get<double>(), -1e-3, 1e-7);
    // The same numbers as the library's own solve, to the last digit.
    fem::StaticProblem problem;
    for (const auto& p : doc["nodes"])
      problem.mesh.nodes.emplace_back(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
    problem.mesh.tetrahedra = doc["tetrahedra"].get<std::vector<fem::Tetrahedron>>();
    fem::parse_material_model(model, problem.material.model);
    if (model == "mooney-rivlin") {
      problem.material.c1 = problem.material.c2 = 8.39e3;
      problem.material.bulk_modulus = 1.667e6;
      problem.material.stabilization = 10;
    } else {
      problem.material.young_modulus = 5e4;
      problem.material.poisson_ratio = 0.4;
    }
    problem.density = 1000;
    problem.gravity = {0, 0, -9.81};
    problem.fixed = doc["fixed"].get<std::vector<std::int32_t>>();
    for (const auto& p : doc["prescribed"]) problem.prescribed.push_back({p[0], p[1], p[2]});
    problem.loads.push_back({7, 1, 1e-3});
    problem.load_steps = 2;
    const fem::StaticSolution library = fem::solve_static(problem);
    for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(out["displacements"][n][static_cast<std::size_t>(c)].get<double>(),
                  library.displacements[3 * static_cast<Eigen::Index>(n) + c])
            << model << " node " << n;
    // The default factorization (CHOLMOD and MUMPS where built with them)
    // gives the same solution to round-off.
    const CommandRun by_default = run_organsim("fem " + (dir_ / "bar.json").string() + " --json", dir_);
    ASSERT_EQ(by_default.exit_code, 0) << model << ": " << by_default.err;
    const json other = json::parse(by_default.out);
    double largest = 0, difference = 0;
    for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
      for (std::size_t c = 0; c < 3; ++c) {
        largest = std::max(largest, std::abs(out["displacements"][n][c].get<double>()));
        difference = std::max(difference, std::abs(other["displacements"][n][c].get<double>() -
                                                   out["displacements"][n][c].get<double>()));
      }
    EXPECT_LT(difference, 1e-9 * largest) << model << " with " << other["linear_solver"];
  }
}

TEST_F(Cli, FemReportsItsLinearSolvesAndCanFactorizeEveryTangent) {
  write(dir_ / "bar.json", bar_document("mooney-rivlin").dump());
  const auto solve = [&](const std::string& options) {
    const CommandRun run = run_organsim("fem " + (dir_ / "bar.json").string() + " --json " + options, dir_);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return json::parse(run.out);
  };
  const json kept = solve(""), every = solve("--krylov-iterations 0");
  int iterations = 0;
  for (const auto& n : kept["newton_iterations"]) iterations += n.get<int>();
  EXPECT_EQ(kept["newton_iterations"], every["newton_iterations"]);
  EXPECT_EQ(every["factorizations"].get<int>(), iterations);
  EXPECT_EQ(every["krylov_solves"].get<int>(), 0);
  EXPECT_EQ(kept["factorizations"].get<int>() + kept["krylov_solves"].get<int>(), iterations);
  EXPECT_LT(kept["factorizations"].get<int>(), iterations);
  EXPECT_GE(kept["krylov_iterations"].get<int>(), kept["krylov_solves"].get<int>());
  const CommandRun bad = run_organsim("fem " + (dir_ / "bar.json").string() + " --krylov-iterations -1", dir_);
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("--krylov-iterations"), std::string::npos) << bad.err;
}

TEST_F(Cli, FemTextReportAndParaViewOutput) {
  write(dir_ / "bar.json", bar_document("mooney-rivlin").dump());
  const CommandRun run =
      run_organsim("fem " + (dir_ / "bar.json").string() + " --out " + (dir_ / "r.vtu").string(), dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* line :
       {"problem ", "solve ", "converged", "displacement ", "pressure ", "reactions ", "linear solves ", "time "})
    EXPECT_NE(run.out.find(line), std::string::npos) << line << "\n" << run.out;
  const std::string vtu = read_bytes(dir_ / "r.vtu");
  for (const char* array : {"\"displacement\"", "\"stress\"", "\"von_mises\"", "\"pressure\"", "UNITS"})
    EXPECT_NE(vtu.find(array), std::string::npos) << array;
}

TEST_F(Cli, FemRejectsMalformedProblemsWithOneLine) {
  const json good = bar_document("stvk");
  struct Case {
    const char* what;
    json document;
    const char* message;
  };
  std::vector<Case> cases;
  json missing = good;
  missing.erase("tetrahedra");
  cases.push_back({"missing field", missing, "tetrahedra: missing"});
  json out_of_range = good;
  out_of_range["tetrahedra"][4][2] = 9999;
  cases.push_back({"index out of range", out_of_range, "tetrahedra[4]: node 9999 is out of range"});
  json inverted = good;
  std::swap(inverted["tetrahedra"][5][0], inverted["tetrahedra"][5][1]);
  cases.push_back({"negative volume", inverted, "tetrahedra[5]: negative volume"});
  json flat = good;
  flat["nodes"][1] = flat["nodes"][0];
  cases.push_back({"zero volume", flat, "zero volume"});
  json unknown = good;
  unknown["material"]["model"] = "rubber";
  cases.push_back({"unknown model", unknown, "material.model: unknown model 'rubber'"});
  json no_modulus = good;
  no_modulus["material"].erase("young_modulus");
  cases.push_back({"missing constant", no_modulus, "material.young_modulus: missing"});
  json string_number = good;
  string_number["density"] = "heavy";
  cases.push_back({"not a number", string_number, "density: expected a number"});
  json bad_component = good;
  bad_component["prescribed"][0][1] = 3;
  cases.push_back({"bad component", bad_component, "prescribed[0]: component must be 0, 1 or 2"});
  for (const Case& c : cases) {
    write(dir_ / "bad.json", c.document.dump());
    const CommandRun run = run_organsim("fem " + (dir_ / "bad.json").string(), dir_);
    EXPECT_EQ(run.exit_code, 1) << c.what;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << c.what << ": " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << c.what << ": " << run.err;
  }
  write(dir_ / "bad.json", "{\"nodes\": [[0, 0, 1e999]]}");
  CommandRun run = run_organsim("fem " + (dir_ / "bad.json").string(), dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("not valid JSON"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("number overflow"), std::string::npos) << run.err;
  write(dir_ / "bad.json", "{ not json");
  run = run_organsim("fem " + (dir_ / "bad.json").string(), dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("not valid JSON"), std::string::npos) << run.err;
  run = run_organsim("fem " + (dir_ / "absent.json").string(), dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("cannot read"), std::string::npos) << run.err;
}

TEST_F(Cli, FemReportsAFailedSolveWithoutNaN) {
  json doc = bar_document("stvk");
  for (auto& p : doc["prescribed"]) p[2] = -0.06;  // push the end through the fixed end
  doc["load_steps"] = 1;
  write(dir_ / "crush.json", doc.dump());
  const CommandRun run = run_organsim("fem " + (dir_ / "crush.json").string() + " --json", dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("failed after"), std::string::npos) << run.err;
  const json out = json::parse(run.out);
  EXPECT_FALSE(out["converged"].get<bool>());
  EXPECT_NE(out["error"].get<std::string>().find("load step 1 of 1"), std::string::npos);
}

}  // namespace
}  // namespace organsim
