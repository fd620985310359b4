// `organsim poke MODEL --tool X,Y,Z/DX,DY,DZ [--tool …] [--model M] [--compare M]`:
// a static press: the force each tool feels for a prescribed displacement, and
// how the organ deforms, with any deformation model (and the difference from a
// second one).
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line.h"
#include "model_tuning.h"
#include "organsim/geometry/model_measures.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/model/model_file.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/fem/organ_fem.h"
#include "organsim/realtime/deformation_model.h"

namespace organsim::cli {
namespace {

struct ToolSpec {
  std::string text;
  Eigen::Vector3d point_mm;
  Eigen::Vector3d displacement_mm;
};

struct PokeOptions {
  std::string model_path;
  std::vector<std::string> tools;
  std::string merge = "influence";
  std::string theory = "euler-bernoulli";
  double snap_distance_mm = 10.0;
  bool json = false;
  std::string out_path;
  std::string deformation = "beam";
  std::string compare;          ///< a second model to press the same way, or empty
  double settle_seconds = 2.0;  ///< mass-spring model: how long the press is held before the force is read
  ModelTuning tuning;
};

Eigen::Vector3d parse_triple(const std::string& text, const std::string& whole) {
  Eigen::Vector3d v;
  std::size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t end = k < 2 ? text.find(',', start) : text.size();
    if (end == std::string::npos)
      throw std::runtime_error("--tool " + whole + ": expected X,Y,Z/DX,DY,DZ in millimetres");
    const std::string field = text.substr(start, end - start);
    char* stop = nullptr;
    v[k] = std::strtod(field.c_str(), &stop);
    if (field.empty() || stop != field.c_str() + field.size())
      throw std::runtime_error("--tool " + whole + ": '" + field + "' is not a number; expected X,Y,Z/DX,DY,DZ in mm");
    start = end + 1;
  }
  return v;
}

ToolSpec parse_tool(const std::string& text) {
  const std::size_t slash = text.find('/');
  if (slash == std::string::npos)
    throw std::runtime_error("--tool " + text + ": expected X,Y,Z/DX,DY,DZ (point / displacement, mm)");
  return {text, parse_triple(text.substr(0, slash), text), parse_triple(text.substr(slash + 1), text)};
}

nlohmann::json triple(const Eigen::Vector3d& v) { return {v[0], v[1], v[2]}; }

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// What one press gave, whatever the model.
struct ToolResult {
  Eigen::Vector3d action_point = Eigen::Vector3d::Zero();  ///< m, rest surface
  double snap_distance = 0.0;                              ///< m, from the tool point to the action point
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double beam_length = 0.0;                                ///< m (multi-beam model only)
  Eigen::Vector3d force = Eigen::Vector3d::Zero();         ///< N on the tool
};

struct PokeResult {
  std::string model;            ///< the deformation model's name
  std::string summary;          ///< one line on how the model was set up and solved
  std::vector<ToolResult> tools;
  std::vector<model::Point3> positions, normals;
  double attach_seconds = 0.0;  ///< per tool
  double force_seconds = 0.0;   ///< per tool and force evaluation
  double deform_seconds = 0.0;  ///< per deformation frame (FEM: per Newton iteration)
  double setup_seconds = 0.0;   ///< FEM: building the system and factorizing the rest tangent
  int frames = 1;               ///< deformation frames (FEM: Newton iterations) to equilibrium
};

/// The multi-beam model: static, so one deformation gives the pressed organ.
PokeResult press_beams(const multibeam::BeamOrgan& organ, const std::vector<ToolSpec>& tools, const PokeOptions& o) {
  using namespace organsim::multibeam;
  MultiBeamOptions options;
  options.max_tools = static_cast<std::uint32_t>(tools.size());
  options.merge = o.merge == "sum" ? MergeRule::sum : MergeRule::influence;
  options.beam.theory = o.theory == "timoshenko" ? BeamTheory::timoshenko : BeamTheory::euler_bernoulli;
  options.snap_distance = o.snap_distance_mm * 1e-3;
  MultiBeam beams(organ, options);

  PokeResult r;
  r.tools.resize(tools.size());
  std::vector<Eigen::Vector3d> displacements(tools.size());
  const auto attach_start = std::chrono::steady_clock::now();
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    displacements[i] = tools[i].displacement_mm * 1e-3;
    const Status status = beams.attach(i, tools[i].point_mm * 1e-3);
    if (status != Status::ok) throw std::runtime_error(fmt::format("tool {} ({}): {}", i + 1, tools[i].text, describe(status)));
    if (!displacements[i].allFinite())
      throw std::runtime_error(fmt::format("tool {} ({}): {}", i + 1, tools[i].text, describe(Status::not_finite)));
  }
  r.attach_seconds = seconds_since(attach_start) / tools.size();

  constexpr int kForceRepeats = 1000;  // one call is too short to time alone
  const auto force_start = std::chrono::steady_clock::now();
  for (int repeat = 0; repeat < kForceRepeats; ++repeat)
    for (std::uint32_t i = 0; i < tools.size(); ++i) beams.force(i, displacements[i], r.tools[i].force);
  r.force_seconds = seconds_since(force_start) / (kForceRepeats * tools.size());

  r.positions.resize(organ.vertex_count());
  r.normals.resize(organ.vertex_count());
  const auto deform_start = std::chrono::steady_clock::now();
  const Status deformed = beams.deform(displacements.data(), r.positions.data(), r.normals.data(), r.positions.size());
  r.deform_seconds = seconds_since(deform_start);
  if (deformed != Status::ok) throw std::runtime_error(describe(deformed));
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    const ToolBeam& b = beams.beam(i);
    r.tools[i].action_point = b.action.position;
    r.tools[i].snap_distance = b.action.distance;
    r.tools[i].normal = geometry::triangle_normal(organ.model(), b.action.triangle);
    r.tools[i].beam_length = b.length;
  }
  return r;
}

/// The rest-surface point a tool presses: the nearest one, within the snap distance.
Eigen::Vector3d snap_to_surface(const multibeam::BeamOrgan& organ, const ToolSpec& tool, std::size_t index,
                                const PokeOptions& o) {
  const Eigen::Vector3d point = tool.point_mm * 1e-3;
  if (!point.allFinite() || !tool.displacement_mm.allFinite())
    throw std::runtime_error(fmt::format("tool {} ({}): a coordinate is not a finite number", index + 1, tool.text));
  const geometry::SurfacePoint nearest = organ.surface_tree().closest_point(point);
  if ((nearest.position - point).norm() > o.snap_distance_mm * 1e-3)
    throw std::runtime_error(fmt::format("tool {} ({}): the point is farther than {} mm from the organ's surface",
                                         index + 1, tool.text, o.snap_distance_mm));
  return nearest.position;
}

/// A FEM model: the static equilibrium of the press by Newton's method (the
/// tangent refactored at every iteration), from rest.
PokeResult press_fem(const multibeam::BeamOrgan& organ, const std::vector<ToolSpec>& tools, const PokeOptions& o,
                     fem::MaterialModel material) {
  constexpr int kMaxIterations = 40;
  fem::OrganFemOptions options;
  realtime::SpringModelOptions unused;
  apply_model_tuning(o.tuning, options, unused);
  options.refresh_frames = 0;
  options.relaxation = 1.0;  // Newton: full steps
  options.realtime_solves = false;
  const auto setup_start = std::chrono::steady_clock::now();
  fem::OrganFem fem(organ.model(), material, options, tools.size());
  PokeResult r;
  r.setup_seconds = seconds_since(setup_start);
  r.tools.resize(tools.size());
  std::vector<Eigen::Vector3d> displacements(tools.size());
  const auto attach_start = std::chrono::steady_clock::now();
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    displacements[i] = tools[i].displacement_mm * 1e-3;
    if (!fem.attach(i, snap_to_surface(organ, tools[i], i, o)))
      throw std::runtime_error(fmt::format("tool {} ({}): the nearest boundary face of the tetrahedra is clamped or "
                                           "touches another tool's",
                                           i + 1, tools[i].text));
  }
  r.attach_seconds = seconds_since(attach_start) / tools.size();
  const auto newton_start = std::chrono::steady_clock::now();
  double force_scale = 0.0;
  for (r.frames = 1;; ++r.frames) {
    if (r.frames > 1 && !fem.refresh_tangent())
      throw std::runtime_error(fmt::format("the {} tangent became singular or indefinite at Newton iteration {}: the "
                                           "press is deeper than the mesh can follow",
                                           fem::material_name(material), r.frames));
    if (fem.step(displacements.data()) != fem::FrameStatus::ok)
      throw std::runtime_error("the press inverts a tetrahedron even in small steps: press less deep");
    for (std::uint32_t i = 0; i < tools.size(); ++i) force_scale = std::max(force_scale, fem.contact_force(i).norm());
    if (fem.unbalanced_force() <= 1e-9 * force_scale) break;
    if (r.frames == kMaxIterations)
      throw std::runtime_error(fmt::format("Newton's method did not converge in {} iterations (out of balance {:.3g} N)",
                                           kMaxIterations, fem.unbalanced_force()));
  }
  r.deform_seconds = seconds_since(newton_start) / r.frames;
  r.positions.resize(organ.vertex_count());
  r.normals.resize(organ.vertex_count());
  fem.surface_positions(r.positions.data());
  multibeam::compute_vertex_normals(organ, r.positions.data(), r.normals.data(), 0, r.positions.size());
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    r.tools[i].force = fem.contact_force(i);
    r.tools[i].action_point = fem.contact_point(i);
    r.tools[i].snap_distance = (r.tools[i].action_point - tools[i].point_mm * 1e-3).norm();
    r.tools[i].normal = geometry::triangle_normal(organ.model(), organ.surface_tree().closest_point(r.tools[i].action_point).triangle);
  }
  const fem::Material& law = fem.system().material();
  const std::string constants =
      material == fem::MaterialModel::mooney_rivlin
          ? fmt::format("c1 = c2 {:g} Pa, kappa {:g} Pa, beta {:g}", law.c1, law.bulk_modulus, law.stabilization)
          : fmt::format("E {:g} Pa, nu {:g}", law.young_modulus, law.poisson_ratio);
  r.summary = fmt::format("{} tetrahedra, {} nodes ({} clamped within {:g} mm); {}; Newton, {} iteration(s), {}",
                          organ.model().tetrahedra.size(), organ.model().volume_vertices.size(),
                          fem.clamped_node_count(), o.tuning.fixed_radius_mm, constants, r.frames,
                          fem.linear_solver());
  return r;
}

/// The mass-spring model: dynamic, so the press is held while the organ
/// settles (deformation frames of 1/60 s, as in the engine) and the force is
/// read from the settled state.
PokeResult press_springs(const multibeam::BeamOrgan& organ, const std::vector<ToolSpec>& tools, const PokeOptions& o) {
  using namespace organsim::realtime;
  ModelOptions options;
  apply_model_tuning(o.tuning, options.fem, options.springs);
  const std::unique_ptr<DeformationModel> springs =
      make_deformation_model(ModelKind::springs, organ, options, tools.size());
  PokeResult r;
  r.tools.resize(tools.size());
  std::vector<ContactLinearization> contacts(tools.size());
  std::vector<Eigen::Vector3d> displacements(tools.size());
  const auto attach_start = std::chrono::steady_clock::now();
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    displacements[i] = tools[i].displacement_mm * 1e-3;
    if (!springs->attach(i, snap_to_surface(organ, tools[i], i, o), contacts[i]))
      throw std::runtime_error(fmt::format("tool {} ({}): the nearest node is clamped or held by another tool", i + 1,
                                           tools[i].text));
  }
  r.attach_seconds = seconds_since(attach_start) / tools.size();
  r.positions.resize(organ.vertex_count());
  r.normals.resize(organ.vertex_count());
  const auto deform_start = std::chrono::steady_clock::now();
  r.frames = 0;
  for (int frame = 0; frame < static_cast<int>(o.settle_seconds * 60.0 + 0.5); ++frame, ++r.frames)
    if (!springs->step(1.0 / 60.0, displacements.data(), r.positions.data(), r.normals.data(), contacts.data()))
      throw std::runtime_error("the mass-spring model could not move the organ (a displacement is not finite)");
  r.deform_seconds = seconds_since(deform_start) / std::max(r.frames, 1);
  r.summary = fmt::format("mass-spring, settled over {} frames of 1/60 s", r.frames);
  if (springs->instabilities() > 0)
    warn("poke", fmt::format("the mass-spring model diverged {} time(s) and was reset to rest", springs->instabilities()));
  constexpr int kForceRepeats = 1000;
  const auto force_start = std::chrono::steady_clock::now();
  for (int repeat = 0; repeat < kForceRepeats; ++repeat)
    for (std::uint32_t i = 0; i < tools.size(); ++i)
      r.tools[i].force = contacts[i].force - contacts[i].stiffness * (displacements[i] - contacts[i].displacement);
  r.force_seconds = seconds_since(force_start) / (kForceRepeats * tools.size());
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    r.tools[i].action_point = contacts[i].action_point;
    r.tools[i].snap_distance = (contacts[i].action_point - tools[i].point_mm * 1e-3).norm();
    r.tools[i].normal = contacts[i].normal;
  }
  return r;
}

PokeResult press(const std::string& name, const multibeam::BeamOrgan& organ, const std::vector<ToolSpec>& tools,
                 const PokeOptions& o) {
  realtime::ModelKind kind = realtime::ModelKind::beam;
  realtime::parse_model_kind(name, kind);
  fem::MaterialModel material = fem::MaterialModel::linear;
  PokeResult r = kind == realtime::ModelKind::beam      ? press_beams(organ, tools, o)
                 : kind == realtime::ModelKind::springs ? press_springs(organ, tools, o)
                 : realtime::fem_material(kind, material)
                     ? press_fem(organ, tools, o, material)
                     : throw std::logic_error("unknown deformation model " + name);
  r.model = name;
  if (kind == realtime::ModelKind::beam)
    r.summary = fmt::format("{} stations per beam; E {:g} Pa, nu {:g}; {}, {} merge", organ.stations(),
                            organ.model().material.young_modulus, organ.model().material.poisson_ratio, o.theory,
                            o.merge);
  return r;
}

/// How the deformed organ of a press looks, in numbers.
struct Deformation {
  double max_displacement = 0.0;  ///< m
  std::size_t max_vertex = 0;     ///< runtime numbering
  double rest_volume = 0.0, deformed_volume = 0.0;  ///< m³
};

Deformation measure(const multibeam::BeamOrgan& organ, const std::vector<model::Point3>& positions) {
  const model::OrganModel& model = organ.model();
  Deformation d;
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const model::Point3& rest = model.surface_vertices[v];
    const double distance =
        std::hypot(positions[v][0] - rest[0], positions[v][1] - rest[1], positions[v][2] - rest[2]);
    if (distance > d.max_displacement) {
      d.max_displacement = distance;
      d.max_vertex = v;
    }
  }
  d.rest_volume = geometry::enclosed_volume(model.surface_vertices, model.surface_triangles);
  d.deformed_volume = geometry::enclosed_volume(positions, model.surface_triangles);
  return d;
}

/// Where two presses of the same organ differ: the surfaces vertex by vertex
/// (m) and the tools' forces (N).
struct Difference {
  double rms = 0.0, max = 0.0;  ///< vertex distance between the two deformed surfaces, m
  std::vector<double> force;    ///< per tool |F_a − F_b|, N
};

Difference difference(const PokeResult& a, const PokeResult& b) {
  Difference d;
  for (std::size_t v = 0; v < a.positions.size(); ++v) {
    const double distance = std::hypot(a.positions[v][0] - b.positions[v][0], a.positions[v][1] - b.positions[v][1],
                                       a.positions[v][2] - b.positions[v][2]);
    d.rms += distance * distance;
    d.max = std::max(d.max, distance);
  }
  d.rms = std::sqrt(d.rms / static_cast<double>(std::max<std::size_t>(a.positions.size(), 1)));
  for (std::size_t i = 0; i < a.tools.size(); ++i) d.force.push_back((a.tools[i].force - b.tools[i].force).norm());
  return d;
}

int run_poke(const PokeOptions& o) {
  std::vector<ToolSpec> tools;
  for (const std::string& t : o.tools) tools.push_back(parse_tool(t));
  if (tools.size() > multibeam::kMaxTools) throw std::runtime_error(fmt::format("at most {} tools", multibeam::kMaxTools));
  if (!o.out_path.empty() && (o.out_path.size() < 4 || o.out_path.substr(o.out_path.size() - 4) != ".vtp"))
    throw std::runtime_error("--out " + o.out_path + ": the deformed surface is written as VTK PolyData; name it .vtp");
  if (!o.compare.empty() && o.compare == o.deformation)
    throw CLI::ValidationError("--compare", "compare with another model than --model " + o.deformation);

  model::OrganModel loaded = load_simulation_model("poke", o.model_path);
  const std::vector<model::Triangle> file_triangles = loaded.surface_triangles;
  const multibeam::BeamOrgan organ(std::move(loaded));
  const bool beam = o.deformation == "beam";
  const PokeResult r = press(o.deformation, organ, tools, o);
  const std::vector<model::Point3>& positions = r.positions;
  const Deformation shape = measure(organ, positions);
  const double volume_change = (shape.deformed_volume - shape.rest_volume) / shape.rest_volume;
  std::optional<PokeResult> other;
  Difference versus;
  if (!o.compare.empty()) {
    other = press(o.compare, organ, tools, o);
    versus = difference(r, *other);
  }

  if (!o.out_path.empty()) {
    // Back to the file's vertex numbering, so the output matches the model file.
    std::vector<model::Point3> in_file_order(positions.size());
    for (std::size_t v = 0; v < positions.size(); ++v) in_file_order[organ.file_vertex_index()[v]] = positions[v];
    mesh_io::write_surface_vtp({in_file_order, file_triangles}, o.out_path);
  }

  if (o.json) {
    nlohmann::json j;
    j["model"] = o.model_path;
    j["deformation_model"] = o.deformation;
    j["setup"] = r.summary;
    j["merge"] = o.merge;
    j["theory"] = o.theory;
    nlohmann::json list = nlohmann::json::array();
    for (std::uint32_t i = 0; i < tools.size(); ++i) {
      const ToolResult& t = r.tools[i];
      list.push_back({{"point_mm", triple(tools[i].point_mm)},
                      {"action_point_mm", triple(t.action_point * 1e3)},
                      {"snap_distance_mm", t.snap_distance * 1e3},
                      {"beam_length_mm", beam ? nlohmann::json(t.beam_length * 1e3) : nlohmann::json(nullptr)},
                      {"normal", triple(t.normal)},
                      {"displacement_mm", triple(tools[i].displacement_mm)},
                      {"force_n", triple(t.force)},
                      {"force_magnitude_n", t.force.norm()}});
    }
    j["tools"] = list;
    j["organ"] = {{"vertices", positions.size()},
                  {"max_displacement_mm", shape.max_displacement * 1e3},
                  {"max_displacement_vertex", organ.file_vertex_index()[shape.max_vertex]},
                  {"rest_volume_ml", shape.rest_volume * 1e6},
                  {"deformed_volume_ml", shape.deformed_volume * 1e6},
                  {"volume_change_percent", volume_change * 100.0}};
    j["seconds"] = {{"beam_per_tool", beam ? nlohmann::json(r.attach_seconds) : nlohmann::json(nullptr)},
                    {"attach_per_tool", r.attach_seconds},
                    {"force_per_tool", r.force_seconds},
                    {"deformation", r.deform_seconds},
                    {"setup", r.setup_seconds},
                    {"frames", r.frames}};
    if (other) {
      nlohmann::json forces = nlohmann::json::array();
      for (std::size_t i = 0; i < tools.size(); ++i)
        forces.push_back({{"force_n", triple(other->tools[i].force)}, {"force_difference_n", versus.force[i]}});
      j["compare"] = {{"deformation_model", o.compare},
                      {"setup", other->summary},
                      {"tools", forces},
                      {"surface_difference_rms_mm", versus.rms * 1e3},
                      {"surface_difference_max_mm", versus.max * 1e3},
                      {"max_displacement_mm", measure(organ, other->positions).max_displacement * 1e3}};
    }
    if (!o.out_path.empty()) j["deformed_surface"] = o.out_path;
    std::cout << j.dump() << '\n';
    return 0;
  }
  auto mm = [](const Eigen::Vector3d& v) { return fmt::format("({:.2f}, {:.2f}, {:.2f}) mm", v[0], v[1], v[2]); };
  std::cout << fmt::format("{:<14}{} ({} vertices; {}: {})\n", "model", o.model_path, positions.size(), o.deformation,
                           r.summary);
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    const ToolResult& t = r.tools[i];
    std::cout << fmt::format("{:<14}at {} -> action point {} (snapped {:.2f} mm){}\n", fmt::format("tool {}", i + 1),
                             mm(tools[i].point_mm), mm(t.action_point * 1e3), t.snap_distance * 1e3,
                             beam ? fmt::format(", beam {:.1f} mm", t.beam_length * 1e3)
                             : o.deformation == "springs" ? std::string(", held node")
                                                          : std::string(", held boundary point"));
    std::cout << fmt::format("{:<14}press {} -> force on the tool ({:.4f}, {:.4f}, {:.4f}) N, |F| {:.4f} N\n", "",
                             mm(tools[i].displacement_mm), t.force[0], t.force[1], t.force[2], t.force.norm());
  }
  std::cout << fmt::format("{:<14}max vertex displacement {:.2f} mm (vertex {}); volume {:.1f} -> {:.1f} mL ({:+.2f} %)\n",
                           "organ", shape.max_displacement * 1e3, organ.file_vertex_index()[shape.max_vertex],
                           shape.rest_volume * 1e6, shape.deformed_volume * 1e6, volume_change * 100.0);
  if (beam)
    std::cout << fmt::format("{:<14}beam {:.1f} us per tool, force {:.3f} us per tool, deformation {:.3f} ms "
                             "(first frame of a contact, normals included)\n",
                             "time", r.attach_seconds * 1e6, r.force_seconds * 1e6, r.deform_seconds * 1e3);
  else if (o.deformation == "springs")
    std::cout << fmt::format("{:<14}attach {:.1f} us per tool, force {:.3f} us per tool, deformation {:.3f} ms per frame "
                             "(normals included)\n",
                             "time", r.attach_seconds * 1e6, r.force_seconds * 1e6, r.deform_seconds * 1e3);
  else
    std::cout << fmt::format("{:<14}setup {:.3f} s (assembly and factorization at rest), attach {:.1f} ms per tool, "
                             "Newton iteration {:.1f} ms (assembly, factorization, solve)\n",
                             "time", r.setup_seconds, r.attach_seconds * 1e3, r.deform_seconds * 1e3);
  if (other) {
    std::cout << fmt::format("{:<14}{}: {}; max vertex displacement {:.2f} mm\n", "compare", o.compare, other->summary,
                             measure(organ, other->positions).max_displacement * 1e3);
    for (std::uint32_t i = 0; i < tools.size(); ++i) {
      const Eigen::Vector3d& f = other->tools[i].force;
      std::cout << fmt::format("{:<14}tool {}: force ({:.4f}, {:.4f}, {:.4f}) N, |F| {:.4f} N; |F_{} - F_{}| {:.4f} N "
                               "({:.0f} % of |F_{}|)\n",
                               "", i + 1, f[0], f[1], f[2], f.norm(), o.deformation, o.compare, versus.force[i],
                               100.0 * versus.force[i] / std::max(f.norm(), 1e-300), o.compare);
    }
    std::cout << fmt::format("{:<14}surfaces {} vs {}: vertex distance RMS {:.2f} mm, max {:.2f} mm\n", "", o.deformation,
                             o.compare, versus.rms * 1e3, versus.max * 1e3);
  }
  if (!o.out_path.empty()) std::cout << fmt::format("{:<14}{} (LPS, mm)\n", "deformed", o.out_path);
  return 0;
}

}  // namespace

Command add_poke_command(CLI::App& app) {
  auto o = std::make_shared<PokeOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  app.add_option("--tool", o->tools,
                 "A tool: X,Y,Z/DX,DY,DZ, a point on or near the surface and its prescribed displacement "
                 "(model frame, mm); repeat for more tools")
      ->required()
      ->allow_extra_args(false);
  app.add_option("--merge", o->merge, "How beams combine: influence (eq. 7) or sum (eq. 5)")
      ->check(CLI::IsMember({"influence", "sum"}))
      ->capture_default_str();
  app.add_option("--theory", o->theory, "Beam theory: euler-bernoulli or timoshenko")
      ->check(CLI::IsMember({"euler-bernoulli", "timoshenko"}))
      ->capture_default_str();
  app.add_option("--snap-distance", o->snap_distance_mm, "Farthest a tool point may be from the surface, mm")
      ->check(kNonNegative)
      ->capture_default_str();
  add_deformation_model_option(app, o->deformation);
  app.add_option("--compare", o->compare, "Press with this model too and print how its forces and surface differ")
      ->check(CLI::IsMember(deformation_model_names()));
  add_model_tuning_options(app, o->tuning);
  app.add_option("--settle", o->settle_seconds, "Mass-spring model: seconds the press is held before the force is read")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--out", o->out_path, "Write the deformed surface (.vtp, LPS, mm)");
  app.add_flag("--json", o->json, "Print the result as one JSON object on stdout");
  return [o] { return run_poke(*o); };
}

}  // namespace organsim::cli
