// `organsim springs`: the mass-spring experiment tool (He et al.'s experiment
// and its variations; docs/springs.md): a flat grid or a baked organ, one
// integrator, a fixed number of steps, a point force; prints the final
// positions, the time per step, the active region and the energy per step,
// and with --trace the force point's displacement and the energy per step as CSV.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "organsim/io/atomic_file.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/model/model_file.h"
#include "organsim/springs/mass_spring.h"

namespace organsim::cli {
namespace {

using namespace organsim::springs;

struct SpringsOptions {
  std::string model_path;
  std::string grid;  // "NxM"
  double spacing_mm = 10.0;
  std::string integrator = "midpoint";
  double dt = 0.01;
  long steps = 100;
  double mass = 0.01;
  bool mass_given = false;
  double gravity = 9.8;
  std::vector<double> stiffness{2.0, 2.0, 1.2};
  bool stiffness_given = false;
  bool volume_springs = false;
  std::vector<double> damping{0.4, 0.4, 0.24};
  bool damping_given = false;
  double point_damping = 0.0;
  double body_factor = 2.0;
  std::vector<double> force{0.0, 0.0, -5.0};
  long at = -1;  // -1: the centre vertex
  std::string fixed = "border";
  std::string region = "all";
  std::uint32_t region_rings = 3;
  double threshold = 0.001;
  bool json = false;
  std::string out_path;
  std::string trace_path;
};

/// With --fixed border on an organ: surface nodes this close (m) to its fixed point are clamped.
constexpr double kOrganClampRadius = 0.015;

Integrator parse_integrator(const std::string& name) {
  if (name == "euler") return Integrator::explicit_euler;
  if (name == "midpoint") return Integrator::midpoint;
  if (name == "rk4") return Integrator::rk4;
  if (name == "symplectic") return Integrator::symplectic_euler;
  return Integrator::implicit_euler;
}

/// The grid "NxM" as (columns, rows); throws a one-line error otherwise.
std::pair<std::uint32_t, std::uint32_t> parse_grid(const std::string& text) {
  unsigned columns = 0, rows = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%u%c%u%c", &columns, &x, &rows, &extra) != 3 || (x != 'x' && x != 'X'))
    throw CLI::ValidationError("--grid", "expected NxM (columns x rows), e.g. 15x15; got '" + text + "'");
  if (columns < 3 || rows < 3 || columns > 2000 || rows > 2000)
    throw CLI::ValidationError("--grid", fmt::format("the grid must be 3x3 to 2000x2000 (got {}x{})", columns, rows));
  return {columns, rows};
}

SpringNetwork make_network(const SpringsOptions& o) {
  if (!o.grid.empty()) {
    const auto [columns, rows] = parse_grid(o.grid);
    GridOptions g;
    g.columns = columns;
    g.rows = rows;
    g.spacing = o.spacing_mm * 1e-3;
    g.mass = o.mass;
    g.structural_stiffness = o.stiffness[0];
    g.shear_stiffness = o.stiffness[1];
    g.bending_stiffness = o.stiffness[2];
    g.structural_damping = o.damping[0];
    g.shear_damping = o.damping[1];
    g.bending_damping = o.damping[2];
    g.body_factor = o.body_factor;
    g.fix_border = o.fixed == "border";
    return make_grid_network(g);
  }
  model::ModelReadResult read = model::read_organ_model_file(o.model_path);
  if (!read) throw std::runtime_error(read.error);
  OrganNetworkOptions n;
  // The paper's 2 N/m holds 0.01 kg points; an organ's springs take their
  // constant from its Young's modulus (k = E x mean edge, as in the engine)
  // unless --stiffness is given.
  if (o.stiffness_given) {
    n.stiffness = o.stiffness[0];
    n.bending_factor = o.stiffness[2] / o.stiffness[0];
  }
  n.volume_springs = o.volume_springs;
  // The paper's damping (0.4 N s/m for 0.01 kg points) would overdamp an
  // organ's light nodes far beyond explicit stability: unless --damping is
  // given, a fraction of critical damping (docs/springs.md).
  if (o.damping_given) n.damping = o.damping[0];
  n.body_factor = o.body_factor;
  n.uniform_mass = o.mass_given ? o.mass : 0.0;
  // An organ has no border: `--fixed border` clamps the surface around its
  // fixed point (e.g. the portal vein entry), as the multi-beam model does.
  n.clamp_radius = o.fixed == "border" ? kOrganClampRadius : 0.0;
  return make_organ_network(*read.model, n);
}

std::uint32_t centre_vertex(const SpringsOptions& o, const SpringNetwork& network) {
  if (!o.grid.empty()) {
    const auto [columns, rows] = parse_grid(o.grid);
    return columns / 2 + columns * (rows / 2);
  }
  // An organ: the free surface node nearest the surface's centroid.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (std::size_t v = 0; v < network.surface_nodes; ++v)
    centre += network.rest[v] / static_cast<double>(network.surface_nodes);
  std::uint32_t best = 0;
  double nearest = std::numeric_limits<double>::infinity();
  for (std::uint32_t v = 0; v < network.surface_nodes; ++v)
    if (!network.fixed[v] && (network.rest[v] - centre).norm() < nearest)
      nearest = (network.rest[v] - centre).norm(), best = v;
  return best;
}

std::string number(double value) { return fmt::format("{:.17g}", value); }

int run_springs(const SpringsOptions& o) {
  if (o.model_path.empty() == o.grid.empty())
    throw CLI::ValidationError("springs", "give a model file or --grid NxM, not both and not neither");
  const Eigen::Vector3d force(o.force[0], o.force[1], o.force[2]);
  if (!force.allFinite()) throw CLI::ValidationError("--force", "the force must be finite");
  SpringNetwork network = make_network(o);
  const std::size_t surface = network.surface_nodes;
  const std::uint32_t at = o.at < 0 ? centre_vertex(o, network) : static_cast<std::uint32_t>(o.at);
  if (o.at >= static_cast<long>(surface))
    throw std::runtime_error(fmt::format("--at {}: the surface has vertices 0 to {}", o.at, surface - 1));
  if (network.fixed[at])
    throw std::runtime_error(
        fmt::format("--at {}: the vertex is fixed (--fixed {}), a force there does nothing; "
                    "choose a free vertex",
                    at, o.fixed));
  const std::vector<model::Triangle> triangles = network.triangles;

  SimulationOptions s;
  s.integrator = parse_integrator(o.integrator);
  s.dt = o.dt;
  s.gravity = Eigen::Vector3d(0.0, 0.0, -o.gravity);
  s.point_damping = o.point_damping;
  s.region = parse_region(o.region);
  s.region_rings = o.region_rings;
  s.threshold = o.threshold;
  MassSpring simulation(std::move(network), s);
  simulation.set_external_force(at, force);

  std::vector<std::size_t> active;
  std::vector<Energy> energy;
  std::vector<Eigen::Vector3d> trace;  // the force vertex's displacement after each step (--trace)
  active.reserve(static_cast<std::size_t>(o.steps));
  energy.reserve(static_cast<std::size_t>(o.steps));
  if (!o.trace_path.empty()) trace.reserve(static_cast<std::size_t>(o.steps));
  long taken = 0;
  double seconds = 0.0;
  for (; taken < o.steps; ++taken) {
    const auto start = std::chrono::steady_clock::now();
    const StepStatus status = simulation.step();
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (status != StepStatus::ok) break;
    active.push_back(simulation.active_count());
    energy.push_back(simulation.energy());
    if (!o.trace_path.empty()) trace.push_back(simulation.position(at) - simulation.network().rest[at]);
  }
  if (!simulation.stable())
    warn("springs", fmt::format("the simulation blew up at step {} (state restored to step {}); use a smaller --dt "
                                "or the implicit integrator",
                                taken + 1, taken));

  std::vector<model::Point3> positions(surface);
  for (std::size_t v = 0; v < surface; ++v) {
    const Eigen::Vector3d& x = simulation.position(static_cast<std::uint32_t>(v));
    positions[v] = {x[0], x[1], x[2]};
  }
  if (!o.out_path.empty()) {
    if (triangles.empty()) throw std::runtime_error("--out: this network has no surface triangles to write");
    mesh_io::write_surface_vtp({positions, triangles}, o.out_path);
  }
  if (!o.trace_path.empty()) {
    // Shortest round-trip numbers ({} in fmt): exact and compact.
    std::string csv =
        "step,time_s,force_vertex_dx_m,force_vertex_dy_m,force_vertex_dz_m,active_vertices,kinetic_j,"
        "spring_j,gravity_j\n";
    for (std::size_t i = 0; i < trace.size(); ++i)
      csv += fmt::format("{},{},{},{},{},{},{},{},{}\n", i + 1, static_cast<double>(i + 1) * o.dt, trace[i][0],
                         trace[i][1], trace[i][2], active[i], energy[i].kinetic, energy[i].spring, energy[i].gravity);
    io::write_file_atomically(o.trace_path, csv);
  }
  const double per_step_us = taken > 0 ? seconds / static_cast<double>(taken) * 1e6 : 0.0;
  const Eigen::Vector3d moved = simulation.position(at) - simulation.network().rest[at];

  if (o.json) {
    // Numbers at round-trip precision (17 significant digits), written by hand
    // so that the document stays exact and compact.
    std::ostringstream j;
    j << "{\"integrator\":\"" << o.integrator << "\",\"dt\":" << number(o.dt) << ",\"steps\":" << taken
      << ",\"stable\":" << (simulation.stable() ? "true" : "false") << ",\"vertices\":" << surface
      << ",\"springs\":" << simulation.network().springs.size() << ",\"force_vertex\":" << at
      << ",\"force_vertex_displacement\":[" << number(moved[0]) << ',' << number(moved[1]) << ',' << number(moved[2])
      << "],\"time_per_step_us\":" << number(per_step_us) << ",\"active_vertices\":[";
    for (std::size_t i = 0; i < active.size(); ++i) j << (i ? "," : "") << active[i];
    j << "],\"energy\":[";
    for (std::size_t i = 0; i < energy.size(); ++i)
      j << (i ? "," : "") << "{\"kinetic\":" << number(energy[i].kinetic) << ",\"spring\":" << number(energy[i].spring)
        << ",\"gravity\":" << number(energy[i].gravity) << '}';
    j << "],\"positions\":[";
    for (std::size_t v = 0; v < surface; ++v)
      j << (v ? "," : "") << '[' << number(positions[v][0]) << ',' << number(positions[v][1]) << ','
        << number(positions[v][2]) << ']';
    j << "]";
    if (!o.out_path.empty()) j << ",\"out\":" << nlohmann::json(o.out_path).dump();
    if (!o.trace_path.empty()) j << ",\"trace\":" << nlohmann::json(o.trace_path).dump();
    j << "}\n";
    std::cout << j.str();
    return 0;
  }
  std::cout << fmt::format("{:<14}{} ({} vertices, {} springs)\n", "network",
                           o.grid.empty() ? o.model_path : "grid " + o.grid, surface,
                           simulation.network().springs.size());
  std::cout << fmt::format("{:<14}{}, dt {:g} s, {} of {} steps{}\n", "integration", o.integrator, o.dt, taken, o.steps,
                           simulation.stable() ? "" : " (blew up)");
  std::cout << fmt::format("{:<14}({:g}, {:g}, {:g}) N at vertex {}: moved ({:.4f}, {:.4f}, {:.4f}) mm\n", "force",
                           force[0], force[1], force[2], at, moved[0] * 1e3, moved[1] * 1e3, moved[2] * 1e3);
  if (!energy.empty())
    std::cout << fmt::format("{:<14}kinetic {:.6g} J, spring {:.6g} J, gravity {:.6g} J (last step)\n", "energy",
                             energy.back().kinetic, energy.back().spring, energy.back().gravity);
  if (!active.empty())
    std::cout << fmt::format("{:<14}{} active vertices at the last step ({} region)\n", "region", active.back(),
                             o.region);
  std::cout << fmt::format("{:<14}{:.2f} us per step\n", "time", per_step_us);
  if (!o.out_path.empty()) std::cout << fmt::format("{:<14}{} (LPS, mm)\n", "final", o.out_path);
  if (!o.trace_path.empty()) std::cout << fmt::format("{:<14}{} ({} steps)\n", "trace", o.trace_path, trace.size());
  return 0;
}

}  // namespace

Command add_springs_command(CLI::App& app) {
  auto o = std::make_shared<SpringsOptions>();
  app.add_option("MODEL", o->model_path, "Model file (.organ); or --grid for the paper's flat grid");
  app.add_option("--grid", o->grid, "Flat grid of N columns (x) by M rows (y), vertex (i, j) at index i + N·j");
  app.add_option("--spacing", o->spacing_mm, "Grid spacing, mm")->check(kPositive)->capture_default_str();
  app.add_option("--integrator", o->integrator, "euler, midpoint, rk4, symplectic or implicit")
      ->check(CLI::IsMember({"euler", "midpoint", "rk4", "symplectic", "implicit"}))
      ->capture_default_str();
  app.add_option("--dt", o->dt, "Time step, s")->check(kPositive)->capture_default_str();
  app.add_option("--steps", o->steps, "Number of steps")->check(CLI::Range(1L, 100000000L))->capture_default_str();
  app.add_option_function<double>(
         "--mass", [o](double m) { o->mass = m, o->mass_given = true; },
         "Mass per vertex, kg (default: 0.01 on a grid; density x volume on a model)")
      ->check(kPositive);
  app.add_option("--gravity", o->gravity, "Gravity along -z, m/s^2")->capture_default_str();
  app.add_option("--stiffness", o->stiffness,
                 "Spring constants KS,KSH,KB (structural, shear, bending), N/m (a model: default E x mean edge)")
      ->delimiter(',')
      ->expected(3)
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--damping", o->damping, "Spring damping CS,CSH,CB, N s/m (a model: default 0.1 x critical)")
      ->delimiter(',')
      ->expected(3)
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--point-damping", o->point_damping, "Damping of every point's velocity, N s/m")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_flag("--volume-springs", o->volume_springs,
               "A model: also a spring on every tetrahedron edge, the surface tied to the tetrahedra");
  app.add_option("--body-factor", o->body_factor, "Body springs: this x the surface springs (0: none)")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--force", o->force, "External force FX,FY,FZ, N (default 0,0,-5)")->delimiter(',')->expected(3);
  app.add_option("--at", o->at, "Vertex the force acts on (default: the centre vertex)")->check(kNonNegative);
  app.add_option("--fixed", o->fixed, "border: fix the grid's border (a model: the surface near its fixed point); none")
      ->check(CLI::IsMember({"border", "none"}))
      ->capture_default_str();
  app.add_option("--region", o->region,
                 "all; dynamic (integrate only the active region, grown past --threshold); fixed (only the vertices "
                 "within --region-rings springs of the force)")
      ->check(CLI::IsMember({"all", "dynamic", "fixed"}))
      ->capture_default_str();
  app.add_option("--region-rings", o->region_rings, "Fixed region: its size, in springs from the force's vertex")
      ->check(CLI::Range(1u, 1000000u))
      ->capture_default_str();
  app.add_option("--threshold", o->threshold, "Dynamic region: displacement (m) that activates the neighbours")
      ->check(kPositive)
      ->capture_default_str();
  app.add_flag("--json", o->json,
               "Print one JSON object (positions, steps, time_per_step_us, active_vertices, energy, stable)");
  app.add_option("--out", o->out_path, "Write the final surface as VTK PolyData (.vtp)");
  app.add_option("--trace", o->trace_path,
                 "Write one CSV row per step: the force vertex's displacement (m), active vertices, energies (J)");
  return [o, &app] {
    o->damping_given = app.count("--damping") > 0;
    o->stiffness_given = app.count("--stiffness") > 0;
    if (o->volume_springs && !o->grid.empty())
      throw CLI::ValidationError("--volume-springs", "a grid has no tetrahedra; give a model file");
    return run_springs(*o);
  };
}

}  // namespace organsim::cli
