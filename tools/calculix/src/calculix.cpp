#include "organsim/calculix/calculix.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace organsim::calculix {

namespace fs = std::filesystem;

void write_deck(const fem::StaticProblem& problem, const std::filesystem::path& path) {
  if (problem.material.model == fem::MaterialModel::corotational || problem.material.stabilization > 0)
    throw std::invalid_argument("CalculiX has no co-rotational or pressure-stabilized element");
  std::ofstream out(path);
  out.precision(13);  // ccx reads at most 20 characters per number
  out << "*HEADING\norgansim comparison\n*NODE, NSET=NALL\n";
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const Eigen::Vector3d& p = problem.mesh.nodes[n];
    out << n + 1 << ", " << p.x() << ", " << p.y() << ", " << p.z() << "\n";
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
  out << (m.model == fem::MaterialModel::linear ? "*STEP\n" : "*STEP, NLGEOM, INC=1000\n");
  out << "*STATIC\n" << (m.model == fem::MaterialModel::linear ? "1., 1.\n" : "0.1, 1., 1e-5, 0.25\n");
  out << "*BOUNDARY\n";
  for (std::int32_t n : problem.fixed) out << n + 1 << ", 1, 3\n";
  for (const fem::PrescribedDisplacement& p : problem.prescribed)
    out << p.node + 1 << ", " << p.component + 1 << ", " << p.component + 1 << ", " << p.value << "\n";
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
  out << "*NODE PRINT, NSET=NALL\nU\n*END STEP\n";
}

Eigen::VectorXd solve(const fem::StaticProblem& problem, const std::string& job_name) {
  const fs::path dir = fs::temp_directory_path() / ("organsim_ccx_" + job_name + "_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_deck(problem, dir / (job_name + ".inp"));
  const std::string command = "cd '" + dir.string() + "' && OMP_NUM_THREADS=1 ccx -i " + job_name + " > ccx.log 2>&1";
  if (std::system(command.c_str()) != 0)
    throw std::runtime_error("ccx failed (is Debian's calculix-ccx installed? tools/setup.sh installs it); see " +
                             (dir / "ccx.log").string());
  std::ifstream dat(dir / (job_name + ".dat"));
  std::string line;
  std::vector<std::string> block;  // the last "displacements" block: the end of the step
  while (std::getline(dat, line)) {
    if (line.find("displacements") != std::string::npos)
      block.clear();
    else
      block.push_back(line);
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
  fs::remove_all(dir);
  return u;
}

}  // namespace organsim::calculix
