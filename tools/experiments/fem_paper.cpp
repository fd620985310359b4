// Ogata et al.'s FEM experiments on our curved tube, and the same
// comparison on a baked liver (docs/fem.md):
//   1. PSH with β = 0 against CalculiX (the paper checked against ADINA) at
//      ρ = 510 and 5.1 kg/m³: mean and largest nodal difference;
//   2. Table 5: linear, co-rotational and St. VK against PSH (ρ = 500, β = 100);
//   3. Table 6: assembly and solve time of one Newton iteration, relative to
//      the co-rotational assembly;
//   4. Figs. 3–4: the pressure field for β = 0, 1, 10, 100, 1000 (its
//      face-to-face oscillation, a CSV of pressure per element, and the
//      deformed tubes coloured by pressure, tube_pressure_3d.png);
//   5. Fig. 5: the sag at ρ = 5000 (tube_sag_3d.png);
//   6. with a model file: Table 5 on the liver's tetrahedra, and the PSH press
//      solved with every tangent factorized against GMRES with a kept
//      factorization (tangent_solver.h), with the direct solvers when built.
// Tube: top ring fixed; the middle ring moved +50 % of the tube's x extent in x
// (y, z free); the bottom ring moved −30 % of its z extent in z (x, y free);
// self-weight along −z. Material: E = 1 MPa, ν = 0.49 (PSH: c1 = c2 = E/(8(1+ν)),
// κ = E/(3(1−2ν)) = 1.667e7 Pa).
//
// Usage: fem_paper OUT_DIR [LIVER.organ]   (Markdown on stdout, CSVs in OUT_DIR)
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/SparseCholesky>

#include "organsim/calculix/calculix.h"
#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/static_solver.h"
#include "organsim/model/model_file.h"
#include "plot/field_view.h"
#ifdef ORGANSIM_HAVE_FEM_DIRECT
#include "organsim/fem/direct_factorizations.h"
#endif

namespace {

using namespace organsim;
using namespace organsim::fem;

constexpr double kYoung = 1e6, kPoisson = 0.49;

Material material_named(const std::string& name, double beta) {
  if (name == "psh") return Material::mooney_rivlin_from_young(kYoung, kPoisson, beta);
  MaterialModel model;
  parse_material_model(name, model);
  return Material::from_young(model, kYoung, kPoisson);
}

StaticProblem tube_problem(const Material& material, double density) {
  StaticProblem p;
  const TubeOptions tube;
  p.mesh = curved_tube(tube);
  p.material = material;
  p.density = density;
  p.gravity = {0, 0, -9.81};
  p.load_steps = material.model == MaterialModel::linear ? 1 : 10;
  const Eigen::Vector3d extent = bounding_box_size(p.mesh.nodes);
  const int per_ring = tube.around, rings = tube.rings;
  for (std::size_t n = 0; n < p.mesh.nodes.size(); ++n) {
    const int ring = static_cast<int>(n) / per_ring % rings;
    const auto node = static_cast<std::int32_t>(n);
    if (ring == 0) p.fixed.push_back(node);
    if (ring == rings / 2) p.prescribed.push_back({node, 0, 0.5 * extent.x()});
    if (ring == rings - 1) p.prescribed.push_back({node, 2, -0.3 * extent.z()});
  }
  return p;
}

StaticSolution solve_or_die(const StaticProblem& p, const std::string& what) {
  StaticSolution s = solve_static(p);
  if (!s.converged) throw std::runtime_error(what + ": " + s.error);
  return s;
}

struct Difference {
  double mean = 0, max = 0;
  Eigen::Vector3d per_axis = Eigen::Vector3d::Zero();
};

/// Nodal displacement differences normalized by the bounding box: |Δu| by its
/// diagonal (mean, max), |Δu_axis| by its extent along that axis (mean).
Difference difference(const Points& nodes, const Eigen::VectorXd& u, const Eigen::VectorXd& reference) {
  const Eigen::Vector3d extent = bounding_box_size(nodes);
  Difference d;
  const Eigen::Index n = u.size() / 3;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d delta = u.segment<3>(3 * i) - reference.segment<3>(3 * i);
    d.mean += delta.norm() / extent.norm();
    d.max = std::max(d.max, delta.norm() / extent.norm());
    d.per_axis += delta.cwiseAbs().cwiseQuotient(extent);
  }
  d.mean /= static_cast<double>(n);
  d.per_axis /= static_cast<double>(n);
  return d;
}

std::string percent(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f %%", 100 * x);
  return text;
}

/// Seconds of one tangent assembly and of one factorization + solve at the solution.
std::pair<double, double> time_iteration(const StaticProblem& p, const StaticSolution& s) {
  std::vector<bool> constrained(3 * p.mesh.nodes.size(), false);
  for (std::int32_t n : p.fixed)
    for (int c = 0; c < 3; ++c) constrained[static_cast<std::size_t>(3 * n + c)] = true;
  for (const auto& pr : p.prescribed) constrained[static_cast<std::size_t>(3 * pr.node + pr.component)] = true;
  ElasticitySystem system(p.mesh, p.material, constrained);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system.dof_count()), gradient(system.dof_count());
  x.head(s.displacements.size()) = s.displacements;
  if (s.pressures.size()) x.tail(s.pressures.size()) = s.pressures;
  const int repeats = 20;
  auto start = std::chrono::steady_clock::now();
  for (int r = 0; r < repeats; ++r) system.assemble(x, gradient, true);
  const double assembly = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / repeats;
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  ldlt.analyzePattern(system.tangent_free());
  Eigen::VectorXd rhs = Eigen::VectorXd::Ones(system.free_count()), solution;
  start = std::chrono::steady_clock::now();
  for (int r = 0; r < repeats; ++r) {
    ldlt.factorize(system.tangent_free());
    solution = ldlt.solve(rhs);
  }
  const double solve = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / repeats;
  return {assembly, solve};
}

void compare_models(const std::string& title, const std::function<StaticProblem(const Material&)>& make,
                    const char* paper[3][2]) {
  const StaticProblem reference_problem = make(material_named("psh", 100));
  const StaticSolution reference = solve_or_die(reference_problem, "psh");
  const auto [psh_assembly, psh_solve] = time_iteration(reference_problem, reference);
  std::cout << "\n### " << title << "\n\n"
            << "| model | mean | max | mean x | mean y | mean z | paper mean | paper max | assembly | solve |\n"
            << "|---|---|---|---|---|---|---|---|---|---|\n";
  double corotational_assembly = 1;
  std::vector<std::string> rows;
  int row = 0;
  std::vector<std::pair<double, double>> times;
  for (const std::string name : {"linear", "corotational", "stvk"}) {
    const StaticProblem p = make(material_named(name, 0));
    const StaticSolution s = solve_or_die(p, name);
    const Difference d = difference(p.mesh.nodes, s.displacements, reference.displacements);
    times.push_back(time_iteration(p, s));
    if (name == "corotational") corotational_assembly = times.back().first;
    char line[512];
    std::snprintf(line, sizeof line, "| %s | %s | %s | %s | %s | %s | %s | %s |", name.c_str(), percent(d.mean).c_str(),
                  percent(d.max).c_str(), percent(d.per_axis.x()).c_str(), percent(d.per_axis.y()).c_str(),
                  percent(d.per_axis.z()).c_str(), paper ? paper[row][0] : "–", paper ? paper[row][1] : "–");
    rows.push_back(line);
    ++row;
  }
  times.push_back({psh_assembly, psh_solve});
  rows.push_back("| psh (β = 100) | 0 | 0 | 0 | 0 | 0 | 0 | 0 |");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    char timing[128];
    std::snprintf(timing, sizeof timing, " %.2f (%.2f ms) | %.2f (%.2f ms) |", times[i].first / corotational_assembly,
                  times[i].first * 1e3, times[i].second / corotational_assembly, times[i].second * 1e3);
    std::cout << rows[i] << timing << "\n";
  }
}

/// RMS of the pressure jump over the interior faces, relative to the RMS pressure.
double pressure_oscillation(const StaticProblem& p, const StaticSolution& s) {
  ElasticitySystem system(p.mesh, Material::mooney_rivlin_from_young(kYoung, kPoisson, 1.0),
                          std::vector<bool>(3 * p.mesh.nodes.size(), false));
  double jump = 0;
  for (const auto& f : system.jump_faces()) jump += std::pow(s.pressures[f.first] - s.pressures[f.second], 2);
  jump = std::sqrt(jump / static_cast<double>(system.jump_faces().size()));
  return jump / std::sqrt(s.pressures.squaredNorm() / static_cast<double>(s.pressures.size()));
}

StaticProblem liver_problem(const model::OrganModel& organ, const Material& material) {
  TetMesh mesh;
  for (const auto& v : organ.volume_vertices) mesh.nodes.emplace_back(v[0], v[1], v[2]);
  for (const auto& t : organ.tetrahedra)
    mesh.tetrahedra.push_back({static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                               static_cast<std::int32_t>(t[2]), static_cast<std::int32_t>(t[3])});
  const Eigen::Vector3d fixed_point(organ.fixed_points[0][0], organ.fixed_points[0][1], organ.fixed_points[0][2]);
  return top_press_problem(std::move(mesh), fixed_point, material);
}

/// The deformed mesh (mm) as a panel of a field view, coloured by `values`
/// (one per tetrahedron or one per node).
plot::FieldPanel deformed_panel(const StaticProblem& p, const StaticSolution& s, const std::string& title,
                                const Eigen::VectorXd& values) {
  plot::FieldPanel panel;
  panel.title = title;
  for (std::size_t n = 0; n < p.mesh.nodes.size(); ++n) {
    const Eigen::Vector3d x = 1e3 * (p.mesh.nodes[n] + s.displacements.segment<3>(3 * static_cast<Eigen::Index>(n)));
    panel.points.push_back({x.x(), x.y(), x.z()});
  }
  for (const Tetrahedron& t : p.mesh.tetrahedra) panel.tetrahedra.push_back(t);
  (static_cast<std::size_t>(values.size()) == p.mesh.tetrahedra.size() ? panel.cell_values : panel.point_values)
      .assign(values.data(), values.data() + values.size());
  return panel;
}

// (Panel titles in ASCII: VTK's embedded fonts lack Greek letters.)

/// Writes a field view, or says why it could not (no X display: run under xvfb-run -a).
void write_view(const std::vector<plot::FieldPanel>& panels, const plot::FieldView& view,
                const std::filesystem::path& path) {
  try {
    plot::write_field_view_png(panels, view, path.string());
    std::cout << "\n![" << path.filename().string() << "](" << path.string() << ")\n";
  } catch (const std::runtime_error& e) {
    std::cout << "\n(" << path.filename().string() << " not drawn: " << e.what() << ")\n";
  }
}

/// The liver's PSH press solved with every tangent factorized and with GMRES
/// reusing the last factorization: Newton iterations, linear solves, times.
void newton_linear_solves(const StaticProblem& p) {
  std::cout << "\n### PSH (β = 100) press on the liver: Newton's linear solves\n\n"
               "| tangents | Newton iterations | factorizations | GMRES solves (iterations) | analysis (s) | assembly (s) "
               "| factorizations + solves (s) | per Newton iteration (ms, without the analysis) |\n"
               "|---|---|---|---|---|---|---|---|\n";
  std::string linear_solver;
  for (const int krylov : {0, TangentSolverOptions{}.max_krylov_iterations}) {
    SolverOptions options;
#ifdef ORGANSIM_HAVE_FEM_DIRECT
    options.factorization = direct_factorization;
#endif
    options.tangent.max_krylov_iterations = krylov;
    const StaticSolution s = solve_static(p, options);
    if (!s.converged) throw std::runtime_error("liver psh: " + s.error);
    linear_solver = s.linear_solver;
    int iterations = 0;
    for (int i : s.newton_iterations) iterations += i;
    const double work = s.solve_seconds - s.analysis_seconds;
    std::printf("| %s | %d | %d | %d (%d) | %.2f | %.2f | %.2f | %.0f |\n",
                krylov ? "GMRES with the kept factorization" : "each factorized", iterations, s.factorizations,
                s.krylov_solves, s.krylov_iterations, s.analysis_seconds, s.assembly_seconds, work,
                1e3 * (s.assembly_seconds + work) / iterations);
  }
  std::cout << "\nFactorization: " << linear_solver << ".\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: fem_paper OUT_DIR [LIVER.organ]\n";
    return 2;
  }
  try {
    const std::filesystem::path out_dir = argv[1];
    std::filesystem::create_directories(out_dir);
    const StaticProblem base = tube_problem(material_named("psh", 0), 510);
    const Eigen::Vector3d extent = bounding_box_size(base.mesh.nodes);
    std::printf("Tube: %zu nodes, %zu tetrahedra, %.1f × %.1f × %.1f mm; middle ring +%.1f mm in x, bottom ring "
                "−%.1f mm in z.\n",
                base.mesh.nodes.size(), base.mesh.tetrahedra.size(), extent.x() * 1e3, extent.y() * 1e3,
                extent.z() * 1e3, 0.5 * extent.x() * 1e3, 0.3 * extent.z() * 1e3);

    std::cout << "\n### PSH (β = 0) against CalculiX (fractions of the bounding-box diagonal)\n\n| ρ (kg/m³) | mean | max | paper (vs ADINA, mean) |\n|---|---|---|---|\n";
    for (const auto& [density, paper] : {std::pair{510.0, "0.89 %"}, std::pair{5.1, "1.72 %"}}) {
      const StaticProblem p = tube_problem(material_named("psh", 0), density);
      const StaticSolution ours = solve_or_die(p, "psh β = 0");
      const Difference d = difference(p.mesh.nodes, ours.displacements, calculix::solve(p, "tube"));
      std::printf("| %g | %.2e | %.2e | %s |\n", density, d.mean, d.max, paper);
    }

    const char* paper_table5[3][2] = {{"22.0 %", "96.2 %"}, {"3.33 %", "13.6 %"}, {"3.36 %", "13.4 %"}};
    compare_models("Table 5 and 6 on the tube (ρ = 500 kg/m³, PSH β = 100)",
                   [](const Material& m) { return tube_problem(m, 500); }, paper_table5);
    std::cout << "\nPaper's Table 6 (relative to co-rotational assembly): assembly linear 0.09, co-rotational 1, "
                 "St.VK 1.3, PSH 10.1; solve 4.2, 4.2, 4.2, 19.8.\n";

    std::cout << "\n### Pressure stabilization (ρ = 500 kg/m³)\n\n"
                 "| β | pressure jump RMS / pressure RMS | min p (kPa) | max p (kPa) | Newton iterations | mean shift vs β = 0 |\n"
                 "|---|---|---|---|---|---|\n";
    std::ofstream csv(out_dir / "tube_pressure.csv");
    csv << "element";
    std::vector<StaticSolution> sweep;
    const std::vector<double> betas = {0, 1, 10, 100, 1000};
    for (double beta : betas) {
      csv << ",beta_" << beta;
      const StaticProblem p = tube_problem(material_named("psh", beta), 500);
      sweep.push_back(solve_or_die(p, "psh"));
      const StaticSolution& s = sweep.back();
      int iterations = 0;
      for (int i : s.newton_iterations) iterations += i;
      std::printf("| %g | %.3f | %.1f | %.1f | %d | %s |\n", beta, pressure_oscillation(p, s),
                  s.pressures.minCoeff() / 1e3, s.pressures.maxCoeff() / 1e3, iterations,
                  percent(difference(p.mesh.nodes, s.displacements, sweep.front().displacements).mean).c_str());
    }
    csv << "\n";
    for (Eigen::Index e = 0; e < sweep.front().pressures.size(); ++e) {
      csv << e;
      for (const StaticSolution& s : sweep) csv << "," << s.pressures[e];
      csv << "\n";
    }
    // Figs. 3–4: one colour scale for all, the stabilized (β = 100) field's
    // range widened by half its span; the unstabilized field's checkerboard
    // runs off both ends of it.
    std::vector<plot::FieldPanel> panels;
    for (std::size_t i = 0; i < betas.size(); ++i)
      panels.push_back(deformed_panel(base, sweep[i], "beta = " + std::to_string(static_cast<int>(betas[i])),
                                      sweep[i].pressures / 1e3));
    const Eigen::VectorXd& stabilized = sweep[3].pressures;  // β = 100
    plot::FieldView pressure_view;
    pressure_view.scalar_title = "pressure (kPa)";
    const double span = (stabilized.maxCoeff() - stabilized.minCoeff()) / 1e3;
    pressure_view.low = stabilized.minCoeff() / 1e3 - 0.5 * span;
    pressure_view.high = stabilized.maxCoeff() / 1e3 + 0.5 * span;
    write_view(panels, pressure_view, out_dir / "tube_pressure_3d.png");

    std::cout << "\n### Sag under ten times the density (PSH β = 100)\n\n";
    const StaticProblem light = tube_problem(material_named("psh", 100), 500);
    const StaticProblem heavy = tube_problem(material_named("psh", 100), 5000);
    const StaticSolution a = solve_or_die(light, "ρ 500"), b = solve_or_die(heavy, "ρ 5000");
    double largest = 0, mean = 0;
    for (Eigen::Index n = 0; n < a.displacements.size() / 3; ++n) {
      const double sag = a.displacements[3 * n + 2] - b.displacements[3 * n + 2];
      largest = std::max(largest, sag);
      mean += sag;
    }
    std::printf("ρ = 5000 against ρ = 500: the nodes sag %.2f mm more on average, %.2f mm at most.\n",
                mean / static_cast<double>(a.displacements.size() / 3) * 1e3, largest * 1e3);
    Eigen::VectorXd sag(a.displacements.size() / 3);
    for (Eigen::Index n = 0; n < sag.size(); ++n) sag[n] = 1e3 * (a.displacements[3 * n + 2] - b.displacements[3 * n + 2]);
    plot::FieldView sag_view;
    sag_view.scalar_title = "extra sag (mm)";
    sag_view.low = 0;
    sag_view.high = std::max(sag.maxCoeff(), 1e-6);
    write_view({deformed_panel(light, a, "rho = 500", Eigen::VectorXd::Zero(sag.size())),
                deformed_panel(heavy, b, "rho = 5000", sag)},
               sag_view, out_dir / "tube_sag_3d.png");

    if (argc > 2) {
      const model::ModelReadResult read = model::read_organ_model_file(argv[2]);
      if (!read) throw std::runtime_error(read.error);
      const model::OrganModel organ = *read.model;
      std::printf("\nLiver: %zu nodes, %zu tetrahedra (%s).\n", organ.volume_vertices.size(), organ.tetrahedra.size(),
                  argv[2]);
      compare_models("Table 5 and 6 on the liver (no gravity; a 10 mm patch at the top pressed down 10 % of the height)",
                     [&organ](const Material& m) { return liver_problem(organ, m); }, nullptr);
      newton_linear_solves(liver_problem(organ, material_named("psh", 100)));
    }
  } catch (const std::exception& e) {
    std::cerr << "fem_paper: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
