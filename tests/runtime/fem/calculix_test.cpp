// Our FEM against CalculiX (Debian calculix-ccx) on the same C3D4 mesh: the
// same discretization (linear tetrahedra, one integration point), so the
// displacements must agree to the two solvers' tolerances, not to a
// discretization error. linear: no NLGEOM; stvk: *ELASTIC with NLGEOM (ccx's
// elastic law in NLGEOM is S = C : E, St. Venant–Kirchhoff); mooney-rivlin
// with β = 0: *HYPERELASTIC, MOONEY-RIVLIN, D1 = 2/κ, NLGEOM (with one pressure
// per tetrahedron and no stabilization, our P1/P0 pressure is p = κ (J − 1)
// element by element, which is ccx's volumetric energy (J − 1)²/D1).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "organsim/fem/static_solver.h"

namespace organsim::fem {
namespace {

namespace fs = std::filesystem;

/// Writes `problem` as a CalculiX input deck (node and element numbers 1-based).
void write_calculix_deck(const StaticProblem& problem, const fs::path& path) {
  std::ofstream out(path);
  out.precision(13);  // ccx reads at most 20 characters per number
  out << "*HEADING\norgansim comparison\n*NODE, NSET=NALL\n";
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const Eigen::Vector3d& p = problem.mesh.nodes[n];
    out << n + 1 << ", " << p.x() << ", " << p.y() << ", " << p.z() << "\n";
  }
  out << "*ELEMENT, TYPE=C3D4, ELSET=EALL\n";
  for (std::size_t e = 0; e < problem.mesh.tetrahedra.size(); ++e) {
    const Tetrahedron& t = problem.mesh.tetrahedra[e];
    out << e + 1 << ", " << t[0] + 1 << ", " << t[1] + 1 << ", " << t[2] + 1 << ", " << t[3] + 1 << "\n";
  }
  const Material& m = problem.material;
  out << "*MATERIAL, NAME=TISSUE\n";
  if (m.model == MaterialModel::mooney_rivlin)
    out << "*HYPERELASTIC, MOONEY-RIVLIN\n" << m.c1 << ", " << m.c2 << ", " << 2 / m.bulk_modulus << "\n";
  else
    out << "*ELASTIC\n" << m.young_modulus << ", " << m.poisson_ratio << "\n";
  out << "*DENSITY\n" << std::max(problem.density, 1e-30) << "\n";
  out << "*SOLID SECTION, ELSET=EALL, MATERIAL=TISSUE\n";
  out << (m.model == MaterialModel::linear ? "*STEP\n" : "*STEP, NLGEOM, INC=1000\n");
  out << "*STATIC\n" << (m.model == MaterialModel::linear ? "1., 1.\n" : "0.1, 1., 1e-5, 0.25\n");
  out << "*BOUNDARY\n";
  for (std::int32_t n : problem.fixed) out << n + 1 << ", 1, 3\n";
  for (const PrescribedDisplacement& p : problem.prescribed)
    out << p.node + 1 << ", " << p.component + 1 << ", " << p.component + 1 << ", " << p.value << "\n";
  if (!problem.loads.empty()) {
    out << "*CLOAD\n";
    for (const NodalLoad& l : problem.loads) out << l.node + 1 << ", " << l.component + 1 << ", " << l.value << "\n";
  }
  if (problem.density > 0 && problem.gravity.norm() > 0) {
    const Eigen::Vector3d direction = problem.gravity.normalized();
    out << "*DLOAD\nEALL, GRAV, " << problem.gravity.norm() << ", " << direction.x() << ", " << direction.y() << ", "
        << direction.z() << "\n";
  }
  out << "*NODE PRINT, NSET=NALL\nU\n*END STEP\n";
}

/// Runs ccx on the deck and reads the last displacement block of its .dat file.
Eigen::VectorXd run_calculix(const StaticProblem& problem, const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("organsim_ccx_" + name + "_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_calculix_deck(problem, dir / (name + ".inp"));
  const std::string command = "cd '" + dir.string() + "' && OMP_NUM_THREADS=1 ccx -i " + name + " > ccx.log 2>&1";
  const int status = std::system(command.c_str());
  Eigen::VectorXd u = Eigen::VectorXd::Constant(3 * static_cast<Eigen::Index>(problem.mesh.nodes.size()), std::nan(""));
  if (status != 0) {
    ADD_FAILURE() << "ccx failed (is Debian's calculix-ccx installed? tools/setup.sh installs it); see " << dir / "ccx.log";
    return u;
  }
  std::ifstream dat(dir / (name + ".dat"));
  std::string line;
  std::vector<std::string> block;
  while (std::getline(dat, line)) {
    if (line.find("displacements") != std::string::npos) block.clear();
    else block.push_back(line);
  }
  for (const std::string& row : block) {
    std::istringstream in(row);
    long node;
    double x, y, z;
    if (in >> node >> x >> y >> z) u.segment<3>(3 * (node - 1)) = Eigen::Vector3d(x, y, z);
  }
  fs::remove_all(dir);
  return u;
}

/// A 5 × 1 × 1 cm bar, fixed at x = 0, under self-weight, with its end either
/// loaded or moved.
StaticProblem bar_problem(const Material& material) {
  StaticProblem problem;
  problem.mesh = box_mesh({10, 2, 2}, {0.05, 0.01, 0.01});
  problem.material = material;
  problem.density = 1000;
  problem.gravity = {0, 0, -9.81};
  problem.load_steps = 4;
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const auto node = static_cast<std::int32_t>(n);
    if (problem.mesh.nodes[n].x() == 0) problem.fixed.push_back(node);
    if (std::abs(problem.mesh.nodes[n].x() - 0.05) < 1e-12) {
      if (material.model == MaterialModel::linear)
        problem.loads.push_back({node, 2, -2e-3});
      else
        problem.prescribed.push_back({node, 2, -0.012});  // a large bend: 24 % of the length
    }
  }
  return problem;
}

double relative_difference(const Eigen::VectorXd& ours, const Eigen::VectorXd& reference) {
  double largest = 0, worst = 0;
  for (Eigen::Index n = 0; n < ours.size() / 3; ++n) {
    largest = std::max(largest, reference.segment<3>(3 * n).norm());
    worst = std::max(worst, (ours.segment<3>(3 * n) - reference.segment<3>(3 * n)).norm());
  }
  return worst / largest;
}

TEST(CalculiX, LinearAgrees) {
  const StaticProblem problem = bar_problem(Material::from_young(MaterialModel::linear, 1e6, 0.3));
  const StaticSolution ours = solve_static(problem);
  ASSERT_TRUE(ours.converged) << ours.error;
  const double difference = relative_difference(ours.displacements, run_calculix(problem, "linear"));
  std::printf("largest difference / largest displacement: %.3g\n", difference);
  EXPECT_LT(difference, 1e-4);
}

TEST(CalculiX, StVenantKirchhoffAgrees) {
  const StaticProblem problem = bar_problem(Material::from_young(MaterialModel::stvk, 1e5, 0.3));
  const StaticSolution ours = solve_static(problem);
  ASSERT_TRUE(ours.converged) << ours.error;
  const double difference = relative_difference(ours.displacements, run_calculix(problem, "stvk"));
  std::printf("largest difference / largest displacement: %.3g\n", difference);
  EXPECT_LT(difference, 1e-4);
}

TEST(CalculiX, MooneyRivlinWithoutStabilizationAgrees) {
  for (double poisson_ratio : {0.45, 0.49}) {  // κ / μ = 9.7 and 50 (the paper's)
    const StaticProblem problem = bar_problem(Material::mooney_rivlin_from_young(1e5, poisson_ratio, 0));
    const StaticSolution ours = solve_static(problem);
    ASSERT_TRUE(ours.converged) << ours.error;
    const double difference = relative_difference(ours.displacements, run_calculix(problem, "mooney"));
    std::printf("ν = %.2f: largest difference / largest displacement: %.3g\n", poisson_ratio, difference);
    EXPECT_LT(difference, 1e-4) << "ν = " << poisson_ratio;
  }
}

}  // namespace
}  // namespace organsim::fem
