#include "organsim/calculix/calculix.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <stdexcept>
#include <utility>
#include <vector>

namespace organsim::calculix {

namespace fs = std::filesystem;

namespace {

/// The equations that tie each point's node of its own (numbered after the
/// mesh's) to the point: per component, Σ wᵢ uᵢ − u = 0, its first term a
/// DOF no other equation and no boundary condition takes (ccx eliminates it).
/// ccx reads at most four terms (12 entries) per line.
void write_point_equations(const fem::StaticProblem& problem, const std::vector<PointDisplacement>& points,
                           std::ostream& out) {
  std::vector<std::array<bool, 3>> taken(problem.mesh.nodes.size(), {false, false, false});
  for (std::int32_t n : problem.fixed) taken[static_cast<std::size_t>(n)] = {true, true, true};
  for (const fem::PrescribedDisplacement& p : problem.prescribed)
    taken[static_cast<std::size_t>(p.node)][static_cast<std::size_t>(p.component)] = true;
  out << "*EQUATION\n";
  for (std::size_t k = 0; k < points.size(); ++k) {
    const PointDisplacement& point = points[k];
    if (point.nodes.size() != point.weights.size())
      throw std::invalid_argument("a held point has " + std::to_string(point.nodes.size()) + " nodes and " +
                                  std::to_string(point.weights.size()) + " weights");
    const std::size_t own = problem.mesh.nodes.size() + k + 1;
    for (int c = 0; c < 3; ++c) {
      std::ptrdiff_t first = -1;
      for (std::size_t i = 0; i < point.nodes.size(); ++i)
        if (point.weights[i] > 1e-12 && !taken[static_cast<std::size_t>(point.nodes[i])][static_cast<std::size_t>(c)] &&
            (first < 0 || point.weights[i] > point.weights[static_cast<std::size_t>(first)]))
          first = static_cast<std::ptrdiff_t>(i);
      if (first < 0)
        throw std::invalid_argument("a held point's nodes are all clamped or tied to other points already");
      const auto lead = static_cast<std::size_t>(first);
      taken[static_cast<std::size_t>(point.nodes[lead])][static_cast<std::size_t>(c)] = true;
      std::vector<std::pair<std::size_t, double>> terms{
          {static_cast<std::size_t>(point.nodes[lead]) + 1, point.weights[lead]}};
      for (std::size_t i = 0; i < point.nodes.size(); ++i)
        if (i != lead && point.weights[i] > 1e-12)
          terms.emplace_back(static_cast<std::size_t>(point.nodes[i]) + 1, point.weights[i]);
      terms.emplace_back(own, -1.0);
      out << terms.size() << "\n";
      for (std::size_t t = 0; t < terms.size(); ++t)
        out << terms[t].first << ", " << c + 1 << ", " << terms[t].second
            << (t + 1 == terms.size() ? "\n"
                : t % 4 == 3          ? ",\n"
                                      : ", ");
    }
  }
}

}  // namespace

void write_deck(const fem::StaticProblem& problem, const std::filesystem::path& path,
                const std::vector<PointDisplacement>& points) {
  if (problem.material.model == fem::MaterialModel::corotational || problem.material.stabilization > 0)
    throw std::invalid_argument("CalculiX has no co-rotational or pressure-stabilized element");
  std::ofstream out(path);
  out.precision(13);  // ccx reads at most 20 characters per number
  out << "*HEADING\norgansim comparison\n*NODE, NSET=NALL\n";
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const Eigen::Vector3d& p = problem.mesh.nodes[n];
    out << n + 1 << ", " << p.x() << ", " << p.y() << ", " << p.z() << "\n";
  }
  if (!points.empty()) {
    out << "*NODE, NSET=NHELD\n";
    for (std::size_t k = 0; k < points.size(); ++k) {
      Eigen::Vector3d at = Eigen::Vector3d::Zero();
      for (std::size_t i = 0; i < points[k].nodes.size(); ++i)
        if (points[k].weights[i] > 1e-12)
          at += points[k].weights[i] * problem.mesh.nodes[static_cast<std::size_t>(points[k].nodes[i])];
      out << problem.mesh.nodes.size() + k + 1 << ", " << at.x() << ", " << at.y() << ", " << at.z() << "\n";
    }
  }
  out << "*ELEMENT, TYPE=C3D4, ELSET=EALL\n";
  for (std::size_t e = 0; e < problem.mesh.tetrahedra.size(); ++e) {
    const fem::Tetrahedron& t = problem.mesh.tetrahedra[e];
    out << e + 1 << ", " << t[0] + 1 << ", " << t[1] + 1 << ", " << t[2] + 1 << ", " << t[3] + 1 << "\n";
  }
  const fem::Material& m = problem.material;
  out << "*MATERIAL, NAME=TISSUE\n";
  if (m.model == fem::MaterialModel::mooney_rivlin)
    out << "*HYPERELASTIC, MOONEY-RIVLIN\n" << m.c1 << ", " << m.c2 << ", " << 2 / m.bulk_modulus << "\n";
  else
    out << "*ELASTIC\n" << m.young_modulus << ", " << m.poisson_ratio << "\n";
  out << "*DENSITY\n" << std::max(problem.density, 1e-30) << "\n";
  out << "*SOLID SECTION, ELSET=EALL, MATERIAL=TISSUE\n";
  if (!points.empty()) write_point_equations(problem, points, out);
  out << (m.model == fem::MaterialModel::linear ? "*STEP\n" : "*STEP, NLGEOM, INC=1000\n");
  out << "*STATIC\n" << (m.model == fem::MaterialModel::linear ? "1., 1.\n" : "0.1, 1., 1e-5, 0.25\n");
  out << "*BOUNDARY\n";
  for (std::int32_t n : problem.fixed) out << n + 1 << ", 1, 3\n";
  for (const fem::PrescribedDisplacement& p : problem.prescribed)
    out << p.node + 1 << ", " << p.component + 1 << ", " << p.component + 1 << ", " << p.value << "\n";
  for (std::size_t k = 0; k < points.size(); ++k)
    for (int c = 0; c < 3; ++c)
      out << problem.mesh.nodes.size() + k + 1 << ", " << c + 1 << ", " << c + 1 << ", " << points[k].displacement[c]
          << "\n";
  if (!problem.loads.empty()) {
    out << "*CLOAD\n";
    for (const fem::NodalLoad& l : problem.loads)
      out << l.node + 1 << ", " << l.component + 1 << ", " << l.value << "\n";
  }
  if (problem.density > 0 && problem.gravity.norm() > 0) {
    const Eigen::Vector3d direction = problem.gravity.normalized();
    out << "*DLOAD\nEALL, GRAV, " << problem.gravity.norm() << ", " << direction.x() << ", " << direction.y() << ", "
        << direction.z() << "\n";
  }
  out << "*NODE PRINT, NSET=NALL\nU\n";
  // The force the points take is what their faces' nodes take from the
  // equations (ccx reports no force on the points' own nodes, which no
  // element holds): their internal forces, RF.
  if (!points.empty()) out << "*NODE PRINT, NSET=NALL\nRF\n";
  out << "*END STEP\n";
}

Eigen::VectorXd solve(const fem::StaticProblem& problem, const std::string& job_name) {
  return solve(problem, job_name, {}).displacements;
}

Solution solve(const fem::StaticProblem& problem, const std::string& job_name,
               const std::vector<PointDisplacement>& points) {
  const fs::path dir = fs::temp_directory_path() / ("organsim_ccx_" + job_name + "_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_deck(problem, dir / (job_name + ".inp"), points);
  const std::string command = "cd '" + dir.string() + "' && OMP_NUM_THREADS=1 ccx -i " + job_name + " > ccx.log 2>&1";
  if (std::system(command.c_str()) != 0)
    throw std::runtime_error(
        "ccx failed (is Debian's calculix-ccx installed? tools/scripts/setup.sh installs it); see " +
        (dir / "ccx.log").string());
  std::ifstream dat(dir / (job_name + ".dat"));
  std::string line;
  // The last "displacements" and "forces" blocks: the end of the step.
  std::vector<std::string> block, forces, *into = &block;
  while (std::getline(dat, line)) {
    if (line.find("displacements") != std::string::npos) {
      block.clear();
      into = &block;
    } else if (line.find("forces") != std::string::npos) {
      forces.clear();
      into = &forces;
    } else {
      into->push_back(line);
    }
  }
  Eigen::VectorXd u = Eigen::VectorXd::Constant(3 * static_cast<Eigen::Index>(problem.mesh.nodes.size()), std::nan(""));
  for (const std::string& row : block) {
    std::istringstream in(row);
    long node;
    double x, y, z;
    if (in >> node >> x >> y >> z && node >= 1 && node <= static_cast<long>(problem.mesh.nodes.size()))
      u.segment<3>(3 * (node - 1)) = Eigen::Vector3d(x, y, z);
  }
  if (!u.allFinite())
    throw std::runtime_error("ccx wrote no displacements for some nodes; see " + (dir / "ccx.log").string());
  Solution solution{u, Eigen::Vector3d::Zero()};
  std::vector<bool> tied(problem.mesh.nodes.size(), false);
  for (const PointDisplacement& point : points)
    for (std::size_t i = 0; i < point.nodes.size(); ++i)
      if (point.weights[i] > 1e-12) tied[static_cast<std::size_t>(point.nodes[i])] = true;
  for (std::int32_t n : problem.fixed) tied[static_cast<std::size_t>(n)] = false;
  for (const std::string& row : forces) {
    std::istringstream in(row);
    long node;
    double x, y, z;
    if (in >> node >> x >> y >> z && node >= 1 && node <= static_cast<long>(problem.mesh.nodes.size()) &&
        tied[static_cast<std::size_t>(node - 1)])
      solution.point_force += Eigen::Vector3d(x, y, z);
  }
  fs::remove_all(dir);
  return solution;
}

}  // namespace organsim::calculix
