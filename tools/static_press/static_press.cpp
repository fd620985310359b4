#include "static_press/static_press.h"

#include <array>
#include <chrono>
#include <cmath>
#include <algorithm>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "command_line/command_line.h"
#include "organsim/organ_fem/organ_fem.h"
#include "organsim/geometry/model_measures.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/realtime/friction.h"
#include "organsim/realtime/model_registry.h"

namespace organsim::cli {
namespace {

Eigen::Vector3d parse_triple(const std::string& text, const std::string& whole) {
  const std::array<double, 3> v = parse_xyz(text, "--tool " + whole + " (X,Y,Z/DX,DY,DZ)");
  return {v[0], v[1], v[2]};
}

/// The force law the engine's 1 kHz loop evaluates for a model that is not a
/// beam: the contact's linearization F = F₀ − K (d − d₀).
struct ContactLaw {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();         ///< F₀, N
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();     ///< K, N/m
  Eigen::Vector3d displacement = Eigen::Vector3d::Zero();  ///< d₀, m
  Eigen::Vector3d at(const Eigen::Vector3d& d) const { return force - stiffness * (d - displacement); }
};

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Seconds per tool of one evaluation of the force law, at tool positions
/// that move a little every repeat (so that nothing is computed once for all).
double time_force_law(const std::vector<ContactLaw>& laws, const std::vector<Eigen::Vector3d>& displacements) {
  constexpr int kRepeats = 10000;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const auto start = std::chrono::steady_clock::now();
  for (int repeat = 0; repeat < kRepeats; ++repeat)
    for (std::size_t i = 0; i < laws.size(); ++i) sum += laws[i].at(displacements[i] * (1.0 + 1e-9 * repeat));
  const double seconds = seconds_since(start);
  volatile double sink = sum.sum();  // keeps the loop
  (void)sink;
  return seconds / (kRepeats * std::max<std::size_t>(laws.size(), 1));
}

constexpr double kSettledSlip = 1e-7;  // m: slips smaller than this are round-off
constexpr int kMaxSlipSteps = 40;      // per load step; the stiffness's nonlinearity makes them converge linearly

/// Coulomb's rule of the engine's force loop (docs/realtime.md#contact-rule)
/// in a static press: where a tool's force lies outside the friction cone
/// about its action point's outward normal, the organ slips under it, and
/// the tool holds the organ displaced by d − slip. One slip step per call
/// (realtime::slip_step, as the force loop takes at 1 kHz, from the force and
/// stiffness at the current state); the caller solves the press again and
/// calls again until no tool slips. True when some tool slipped by more than
/// kSettledSlip.
bool slip_once(const std::vector<Eigen::Vector3d>& forces, const std::vector<Eigen::Matrix3d>& stiffnesses,
               const std::vector<Eigen::Vector3d>& normals, double friction, std::vector<Eigen::Vector3d>& slips) {
  bool slipped = false;
  for (std::size_t i = 0; i < forces.size(); ++i) {
    Eigen::Vector3d force = forces[i];
    const Eigen::Vector3d shift = realtime::slip_step(stiffnesses[i], normals[i], friction, force);
    slips[i] -= shift;
    slipped |= shift.norm() > kSettledSlip;
  }
  return slipped;
}

/// The load steps of a press of a tip of finite size: it moves at most an
/// eighth of its radius per step. The tip holds each surface point where the
/// point enters it (docs/realtime.md#contact-rule), so the press follows the
/// tip's path: in coarse steps a point enters deep inside and is held where it
/// was pushed to, not where it first touched. R/8 is where the force stops
/// depending on the steps (a 5 mm press with R = 2.5 mm: 16 steps give the
/// force of 64 within 1 %, 4-5 steps 10-30 % off; docs/matching.md). One step
/// for a point tool.
int load_steps_for(const std::vector<Eigen::Vector3d>& displacements, const PressOptions& o) {
  constexpr double kStepPerRadius = 0.125;  // the tip's largest move per load step, in radii
  constexpr int kMaxFirstSteps = 64;        // a tip much smaller than the press is nearly a point
  int steps = 1;
  const double radius = o.tuning.tip_radius;
  if (radius > 0.0)
    for (const Eigen::Vector3d& d : displacements)
      steps =
          std::clamp(static_cast<int>(std::ceil(d.norm() / (kStepPerRadius * radius) - 1e-9)), steps, kMaxFirstSteps);
  return steps;
}

/// The outward normal of the rest surface at each tool's action point: the
/// friction cone's axis, as the engine's contact normal.
std::vector<Eigen::Vector3d> cone_normals(const organ::Organ& organ, const std::vector<ToolSpec>& tools,
                                          const PressOptions& o) {
  std::vector<Eigen::Vector3d> normals;
  for (std::size_t i = 0; i < tools.size(); ++i)
    normals.push_back(organ.rest_normal_at(organ.surface_tree().closest_point(snap_to_surface(organ, tools[i], i, o))));
  return normals;
}

/// m per tool: the grasp's bite, straight in along the inward normal (zero
/// vectors without a grasp).
std::vector<Eigen::Vector3d> grasp_bites(const std::vector<Eigen::Vector3d>& normals, const PressOptions& o) {
  std::vector<Eigen::Vector3d> bites(normals.size(), Eigen::Vector3d::Zero());
  if (o.grasp_bite_mm > 0.0)
    for (std::size_t i = 0; i < normals.size(); ++i) bites[i] = -o.grasp_bite_mm * 1e-3 * normals[i];
  return bites;
}

/// The multi-beam model: static, so one deformation gives the pressed organ.
PressResult press_beams(const organ::Organ& organ, const std::vector<ToolSpec>& tools, const PressOptions& o) {
  using namespace organsim::multibeam;
  MultiBeamOptions options = o.tuning.models.of<MultiBeamOptions>();
  options.max_tools = static_cast<std::uint32_t>(tools.size());
  options.snap_distance = o.snap_distance_mm * 1e-3;
  MultiBeam beams(organ, options);

  PressResult r;
  r.tools.resize(tools.size());
  std::vector<Eigen::Vector3d> displacements(tools.size());
  const auto attach_start = std::chrono::steady_clock::now();
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    displacements[i] = tools[i].displacement_mm * 1e-3;
    const Status status = beams.attach(i, tools[i].point_mm * 1e-3, o.tuning.tip_radius);
    if (status != Status::ok)
      throw std::runtime_error(fmt::format("tool {} ({}): {}", i + 1, tools[i].text, describe(status)));
    if (!displacements[i].allFinite())
      throw std::runtime_error(fmt::format("tool {} ({}): {}", i + 1, tools[i].text, describe(Status::not_finite)));
  }
  r.attach_seconds = seconds_since(attach_start) / tools.size();
  // The organ slips under a tool whose force leaves the friction cone, along
  // the path of the FEM press's load steps (the force is the beam's or the
  // site law's at each point of it; its stiffness by central differences).
  const std::vector<Eigen::Vector3d> normals = cone_normals(organ, tools, o);
  std::vector<Eigen::Vector3d> slips(tools.size(), Eigen::Vector3d::Zero()), forces(tools.size());
  std::vector<Eigen::Matrix3d> stiffnesses(tools.size());
  // A grasp bites straight in, where the cone holds, and then holds both ways:
  // no slip. Its force is the beam's −K d, or a matched site's grasp law.
  const std::vector<Eigen::Vector3d> bites = grasp_bites(normals, o);
  std::vector<organ::SiteGrasp> grasps(tools.size());
  for (std::uint32_t i = 0; i < tools.size(); ++i)
    if (o.grasp_bite_mm > 0.0 && beams.beam(i).matched) grasps[i].close(beams.beam(i).law, bites[i]);
  const auto force_at = [&](std::uint32_t i, const Eigen::Vector3d& d, Eigen::Vector3d& force) {
    if (grasps[i].held)
      force = grasps[i].force(beams.beam(i).law, d);
    else
      beams.force(i, d, force);
  };
  const int steps = o.grasp_bite_mm > 0.0 ? 0 : load_steps_for(displacements, o);
  for (int step = 1; step <= steps; ++step)
    for (int slip = 0; slip < kMaxSlipSteps; ++slip) {
      for (std::uint32_t i = 0; i < tools.size(); ++i) {
        const Eigen::Vector3d d = displacements[i] * (static_cast<double>(step) / steps) - slips[i];
        beams.force(i, d, forces[i]);
        constexpr double kDifference = 1e-7;  // m
        for (int axis = 0; axis < 3; ++axis) {
          Eigen::Vector3d ahead, behind;
          beams.force(i, d + kDifference * Eigen::Vector3d::Unit(axis), ahead);
          beams.force(i, d - kDifference * Eigen::Vector3d::Unit(axis), behind);
          stiffnesses[i].col(axis) = (behind - ahead) / (2.0 * kDifference);
        }
      }
      if (!slip_once(forces, stiffnesses, normals, o.tuning.friction, slips)) break;
    }
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    displacements[i] -= slips[i];
    r.tools[i].slip = slips[i];
  }

  constexpr int kForceRepeats = 1000;  // one call is too short to time alone
  const auto force_start = std::chrono::steady_clock::now();
  for (int repeat = 0; repeat < kForceRepeats; ++repeat)
    for (std::uint32_t i = 0; i < tools.size(); ++i) force_at(i, displacements[i], r.tools[i].force);
  r.force_seconds = seconds_since(force_start) / (kForceRepeats * tools.size());

  r.positions.resize(organ.vertex_count());
  r.normals.resize(organ.vertex_count());
  const auto deform_start = std::chrono::steady_clock::now();
  const Status deformed = beams.deform(displacements.data(), r.positions.data(), r.normals.data(), r.positions.size());
  r.deform_seconds = r.frame_seconds = seconds_since(deform_start);
  if (deformed != Status::ok) throw std::runtime_error(describe(deformed));
  // The surface the tips would cut into laid onto them, as the engine's beam model does.
  bool laid = false;
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    const Eigen::Vector3d action = beams.beam(i).action.position;
    const geometry::ToolTip tip = press_tip(organ, action, displacements[i], o);
    laid |= tip.push_out(action + tip.seat + displacements[i], r.positions.data(), r.positions.size());
  }
  if (laid) organ::compute_vertex_normals(organ, r.positions.data(), r.normals.data(), 0, r.positions.size());
  const std::vector<model::Point3>& nodes = organ.model().volume_vertices;
  r.node_positions.resize(nodes.size());
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    const Eigen::Vector3d rest(nodes[n][0], nodes[n][1], nodes[n][2]);
    const Eigen::Vector3d at = rest + beams.displacement_at(rest);
    r.node_positions[n] = {at[0], at[1], at[2]};
  }
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    const ToolBeam& b = beams.beam(i);
    r.tools[i].action_point = b.action.position;
    r.tools[i].snap_distance = b.action.distance;
    r.tools[i].normal = organ.rest_normal_at(b.action);
    r.tools[i].beam_length = b.length;
    r.tools[i].action_moved = beams.displacement_at(b.action.position);
  }
  r.summary = fmt::format(
      "{} stations per beam; E {:g} Pa x {:g}, nu {:g}, attenuation {:g} 1/m; {}, {} sections, {} merge",
      beams.stations(), organ.model().material.young_modulus, organ.model().material.beam_stiffness_scale,
      organ.model().material.poisson_ratio, beams.attenuation_rate(),
      options.beam.theory == BeamTheory::timoshenko ? "timoshenko" : "euler-bernoulli",
      options.beam.centroid_offsets ? "eccentric" : "centred", options.merge == MergeRule::sum ? "sum" : "influence");
  return r;
}

/// A FEM model: the static equilibrium of the press by Newton's method (the
/// tangent refactored at every iteration), from rest.
PressResult press_fem(const organ::Organ& organ, const std::vector<ToolSpec>& tools, const PressOptions& o,
                      fem::MaterialModel material) {
  // Newton's iterations per load step: at most kMaxIterations, or up to
  // kMaxSlowIterations while the out-of-balance force still falls by a factor
  // kSteadyContraction or better per iteration over the last kContractionWindow
  // (PSH's definite fallback, where the exact tangent is indefinite, converges
  // linearly: 0.84 per iteration at a compliant site of the DICOM liver, which
  // reached 1.3 times the tolerance at iteration 40). Such a run is steady,
  // and its iterations are solves with a kept factor, so the cap is high: a
  // steady run falls at least 0.95^8 per 8 iterations and reaches any tolerance
  // well within it (a press of `calibrate --evaluate` on the DICOM sample
  // stopped 18 times over the tolerance at a cap of 160).
  constexpr int kMaxIterations = 40, kMaxSlowIterations = 1000, kContractionWindow = 8;
  constexpr double kSteadyContraction = 0.95;
  constexpr int kKeptTangents = 8;
  constexpr double kKeptTangentContraction = 0.1, kMaxKeptContraction = 0.9;
  fem::OrganFemOptions options = o.tuning.models.of<fem::OrganFemOptions>();
  options.refresh_frames = 0;
  options.relaxation = 1.0;  // Newton: full steps
  options.realtime_solves = false;
  const auto setup_start = std::chrono::steady_clock::now();
  fem::OrganFem fem(organ.model(), material, options, tools.size());
  PressResult r;
  r.setup_seconds = seconds_since(setup_start);
  r.tools.resize(tools.size());
  std::vector<Eigen::Vector3d> displacements(tools.size());
  const std::vector<Eigen::Vector3d> normals = cone_normals(organ, tools, o);
  const std::vector<Eigen::Vector3d> bites = grasp_bites(normals, o);
  const bool grasp = o.grasp_bite_mm > 0.0;
  const auto attach_start = std::chrono::steady_clock::now();
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    displacements[i] = tools[i].displacement_mm * 1e-3;
    const Eigen::Vector3d at = snap_to_surface(organ, tools[i], i, o);
    if (!fem.attach(i, at, press_tip(organ, at, grasp ? bites[i] : displacements[i], o)))
      throw std::runtime_error(
          fmt::format("tool {} ({}): the nearest boundary face of the tetrahedra is clamped or "
                      "touches another tool's",
                      i + 1, tools[i].text));
  }
  r.attach_seconds = seconds_since(attach_start) / tools.size();
  const auto newton_start = std::chrono::steady_clock::now();
  // Newton's method to the equilibrium under `target`; an empty string, or why it failed.
  auto equilibrium = [&](const std::vector<Eigen::Vector3d>& target) -> std::string {
    double force_scale = 0.0;
    int kept_tangent = 0;
    double previous_unbalanced = 0.0, before_previous = 0.0;  // N, after the last two iterations
    double fresh_contraction = 0.0;                           // of the first iteration on the last fresh tangent
    bool refreshed = false;
    std::array<double, kContractionWindow> recent{};  // the out-of-balance forces of the last iterations
    for (int iteration = 1;; ++iteration, ++r.frames) {
      // The tangent is refactored only when the kept one stops paying: an
      // iteration with it costs a solve, a factorization a hundred of them,
      // and in a short load step the last step's tangent still shrinks the
      // out-of-balance force tenfold or more per iteration. Where a fresh one
      // did no better (PSH's definite fallback converges linearly), the kept
      // one goes on while it does about as well. Where the fresh tangent is
      // singular or indefinite (a state a Newton step overshot to), the last
      // good one carries on while the iterations draw closer; only a run of
      // such states fails.
      const double contraction = previous_unbalanced / before_previous;  // of the last iteration
      if (refreshed) fresh_contraction = contraction;
      refreshed = false;
      const double enough = std::min(kMaxKeptContraction, std::max(kKeptTangentContraction, 2.0 * fresh_contraction));
      if (iteration > 2 && !(contraction <= enough) && material != fem::MaterialModel::linear) {
        refreshed = fem.refresh_tangent();
        if (!refreshed && ++kept_tangent > kKeptTangents)
          return fmt::format(
              "the {} tangent became singular or indefinite at Newton iteration {}: the press is "
              "deeper than the mesh can follow",
              fem::material_name(material), iteration);
      }
      if (fem.step(target.data()) != fem::FrameStatus::ok)
        return "the press inverts a tetrahedron even in small steps: press less deep";
      before_previous = previous_unbalanced;
      previous_unbalanced = fem.unbalanced_force();
      for (std::uint32_t i = 0; i < tools.size(); ++i) force_scale = std::max(force_scale, fem.contact_force(i).norm());
      if (fem.unbalanced_force() <= 1e-9 * force_scale && fem.contact_settled()) return "";
      double& window_ago = recent[static_cast<std::size_t>(iteration % kContractionWindow)];
      const bool steady = fem.contact_settled() &&
                          fem.unbalanced_force() <= std::pow(kSteadyContraction, kContractionWindow) * window_ago;
      window_ago = fem.unbalanced_force();
      if (iteration >= kMaxSlowIterations || (iteration >= kMaxIterations && !steady))
        return fmt::format("Newton's method did not converge in {} iterations (out of balance {:.3g} N)", iteration,
                           fem.unbalanced_force());
    }
  };
  // In load_steps_for's steps (each equilibrium the next one's start);
  // failing that, from rest again in four times as many. Within each load
  // step the organ slips under a tool whose force left the friction cone
  // (slip_once), and the step is balanced again, as the engine's force loop
  // lets it slip along the same path. A grasp bites in over the first half of
  // the steps, closes the jaws, and moves to the displacement over the second
  // half, held both ways (no slip).
  std::string failure;
  std::vector<Eigen::Vector3d> from_bite(tools.size());
  for (std::size_t i = 0; i < tools.size(); ++i) from_bite[i] = displacements[i] - bites[i];
  const int first =
      grasp ? std::max(load_steps_for(bites, o), load_steps_for(from_bite, o)) : load_steps_for(displacements, o);
  std::vector<Eigen::Vector3d> slips(tools.size(), Eigen::Vector3d::Zero()), forces(tools.size());
  std::vector<Eigen::Matrix3d> stiffnesses(tools.size());
  double reached = 0.0;  // the largest fraction of the press any attempt balanced
  int solved_in = first;
  for (int load_steps : {first, 4 * first}) {
    solved_in = load_steps;
    fem.reset();
    for (std::uint32_t i = 0; i < tools.size(); ++i) fem.grasp(i, false);
    r.frames = 1;
    failure.clear();
    std::fill(slips.begin(), slips.end(), Eigen::Vector3d::Zero());
    const int total = grasp ? 2 * load_steps : load_steps;
    for (int step = 1; step <= total && failure.empty(); ++step) {
      if (grasp && step == load_steps + 1)
        for (std::uint32_t i = 0; i < tools.size(); ++i) fem.grasp(i, true);
      auto target = [&] {
        std::vector<Eigen::Vector3d> t(tools.size());
        for (std::size_t i = 0; i < tools.size(); ++i)
          t[i] = !grasp ? Eigen::Vector3d(displacements[i] * (static_cast<double>(step) / load_steps) - slips[i])
                 : step <= load_steps
                     ? Eigen::Vector3d(bites[i] * (static_cast<double>(step) / load_steps))
                     : Eigen::Vector3d(bites[i] + from_bite[i] * (static_cast<double>(step - load_steps) / load_steps));
        return t;
      };
      failure = equilibrium(target());
      for (int slip = 0; !grasp && failure.empty() && slip < kMaxSlipSteps; ++slip) {
        for (std::uint32_t i = 0; i < tools.size(); ++i) {
          forces[i] = fem.contact_force(i);
          stiffnesses[i] = fem.contact_stiffness(i);
        }
        if (!slip_once(forces, stiffnesses, normals, o.tuning.friction, slips)) break;
        failure = equilibrium(target());
      }
      if (failure.empty()) reached = std::max(reached, static_cast<double>(step) / total);
    }
    if (failure.empty()) break;
  }
  if (!failure.empty())
    throw std::runtime_error(failure + fmt::format(" (also in {} load steps; balanced up to {:.0f} % of the press)",
                                                   4 * first, 100 * reached));
  r.deform_seconds = seconds_since(newton_start) / r.frames;
  // What the engine does in a frame: one iteration with the kept factor (at
  // equilibrium already, so the state stays where it is).
  for (std::uint32_t i = 0; i < tools.size(); ++i) displacements[i] -= slips[i];  // where the organ is held
  const auto frame_start = std::chrono::steady_clock::now();
  if (fem.step(displacements.data()) != fem::FrameStatus::ok)
    throw std::runtime_error("the pressed state inverts a tetrahedron: press less deep");
  r.frame_seconds = seconds_since(frame_start);
  std::vector<ContactLaw> laws(tools.size());
  for (std::uint32_t i = 0; i < tools.size(); ++i)
    laws[i] = {fem.contact_force(i), fem.contact_stiffness(i), displacements[i]};
  r.force_seconds = time_force_law(laws, displacements);
  r.positions.resize(organ.vertex_count());
  r.normals.resize(organ.vertex_count());
  fem.surface_positions(r.positions.data());
  r.node_positions.resize(organ.model().volume_vertices.size());
  fem.node_positions(r.node_positions.data());
  organ::compute_vertex_normals(organ, r.positions.data(), r.normals.data(), 0, r.positions.size());
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    r.tools[i].force = fem.contact_force(i);
    r.tools[i].held_points = fem.held_points(i);
    r.tools[i].slip = slips[i];
    r.tools[i].action_moved = fem.contact_displacement(i);
    r.tools[i].action_point = fem.contact_point(i);
    r.tools[i].snap_distance = (r.tools[i].action_point - tools[i].point_mm * 1e-3).norm();
    r.tools[i].normal = normals[i];
  }
  r.contact_points_left_out = fem.hold_overflows();
  const fem::Material& law = fem.system().material();
  const std::string constants =
      material == fem::MaterialModel::mooney_rivlin
          ? fmt::format("c1 = c2 {:g} Pa, kappa {:g} Pa, beta {:g}", law.c1, law.bulk_modulus, law.stabilization)
          : fmt::format("E {:g} Pa, nu {:g}", law.young_modulus, law.poisson_ratio);
  r.summary = fmt::format(
      "{} tetrahedra, {} nodes ({} clamped within {:g} mm); {}; Newton, {} iteration(s) in {} load step(s), {}",
      organ.model().tetrahedra.size(), organ.model().volume_vertices.size(), fem.clamped_node_count(),
      options.fixed_radius * 1e3, constants, r.frames, solved_in, fem.linear_solver());
  return r;
}

/// Any model through the engine's interface (the mass-spring model, and any
/// model without a static solver of its own): the press is held while the
/// organ settles (deformation frames of 1/60 s, as in the engine) and the force
/// is read from the settled state.
PressResult press_settled(const realtime::RegisteredModel& entry, const organ::Organ& organ,
                          const std::vector<ToolSpec>& tools, const PressOptions& o) {
  using namespace organsim::realtime;
  const std::unique_ptr<DeformationModel> springs =
      make_deformation_model(entry.name, organ, o.tuning.models, tools.size());
  PressResult r;
  r.tools.resize(tools.size());
  std::vector<ContactLinearization> contacts(tools.size());
  std::vector<Eigen::Vector3d> displacements(tools.size());
  const std::vector<Eigen::Vector3d> normals = cone_normals(organ, tools, o);
  const std::vector<Eigen::Vector3d> bites = grasp_bites(normals, o);
  const bool grasp = o.grasp_bite_mm > 0.0;
  const auto attach_start = std::chrono::steady_clock::now();
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    displacements[i] = tools[i].displacement_mm * 1e-3;
    const Eigen::Vector3d at = snap_to_surface(organ, tools[i], i, o);
    if (!springs->attach(i, at, press_tip(organ, at, grasp ? bites[i] : displacements[i], o), contacts[i]))
      throw std::runtime_error(
          fmt::format("tool {} ({}): the nearest node is clamped or held by another tool", i + 1, tools[i].text));
  }
  r.attach_seconds = seconds_since(attach_start) / tools.size();
  r.positions.resize(organ.vertex_count());
  r.normals.resize(organ.vertex_count());
  // The organ slips under a tool whose force leaves the friction cone, as in
  // the engine: the force loop's 16 ticks per frame each take a slip step on
  // the frame's linearization. A grasp settles at its bite, closes the jaws,
  // and settles again at the displacement, held both ways (no slip).
  std::vector<Eigen::Vector3d> slips(tools.size(), Eigen::Vector3d::Zero()), forces(tools.size()),
      held(grasp ? bites : displacements);
  std::vector<Eigen::Matrix3d> stiffnesses(tools.size());
  constexpr int kTicksPerFrame = 16;
  const auto deform_start = std::chrono::steady_clock::now();
  r.frames = 0;
  const int settle_frames = static_cast<int>(o.settle_seconds * 60.0 + 0.5);
  for (int frame = 0; frame < (grasp ? 2 : 1) * settle_frames; ++frame, ++r.frames) {
    if (grasp && frame == settle_frames) {
      for (std::uint32_t i = 0; i < tools.size(); ++i) springs->set_grasp(i, true);
      held = displacements;
    }
    if (!springs->step(1.0 / 60.0, held.data(), r.positions.data(), r.normals.data(), contacts.data()))
      throw std::runtime_error(std::string("the ") + entry.name +
                               " model could not move the organ (a displacement is not finite)");
    for (int tick = 0; !grasp && tick < kTicksPerFrame; ++tick) {
      for (std::uint32_t i = 0; i < tools.size(); ++i) {
        forces[i] = ContactLaw{contacts[i].force, contacts[i].stiffness, contacts[i].displacement}.at(held[i]);
        stiffnesses[i] = contacts[i].stiffness;
      }
      if (!slip_once(forces, stiffnesses, normals, o.tuning.friction, slips)) break;
      for (std::uint32_t i = 0; i < tools.size(); ++i) held[i] = displacements[i] - slips[i];
    }
  }
  r.deform_seconds = r.frame_seconds = seconds_since(deform_start) / std::max(r.frames, 1);
  r.node_positions.resize(organ.model().volume_vertices.size());
  if (!springs->volume_node_positions(r.node_positions.data(), r.node_positions.size())) r.node_positions.clear();
  r.summary = fmt::format("{}, settled over {} frames of 1/60 s", entry.description, r.frames);
  if (springs->instabilities() > 0)
    warn(o.command,
         fmt::format("the {} model diverged {} time(s) and was reset to rest", entry.name, springs->instabilities()));
  std::vector<ContactLaw> laws(tools.size());
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    laws[i] = {contacts[i].force, contacts[i].stiffness, contacts[i].displacement};
    r.tools[i].force = laws[i].at(held[i]);
    r.tools[i].slip = slips[i];
  }
  r.force_seconds = time_force_law(laws, held);
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    r.tools[i].action_point = contacts[i].action_point;
    r.tools[i].snap_distance = (contacts[i].action_point - tools[i].point_mm * 1e-3).norm();
    r.tools[i].normal = contacts[i].normal;
    r.tools[i].action_moved = held[i];  // the held node follows its tool exactly, less the slip
  }
  return r;
}

}  // namespace

Eigen::Vector3d snap_to_surface(const organ::Organ& organ, const ToolSpec& tool, std::size_t index,
                                const PressOptions& o) {
  const Eigen::Vector3d point = tool.point_mm * 1e-3;
  if (!point.allFinite() || !tool.displacement_mm.allFinite())
    throw std::runtime_error(fmt::format("tool {} ({}): a coordinate is not a finite number", index + 1, tool.text));
  const geometry::SurfacePoint nearest = organ.surface_tree().closest_point(point);
  if ((nearest.position - point).norm() > o.snap_distance_mm * 1e-3)
    throw std::runtime_error(fmt::format("tool {} ({}): the point is farther than {} mm from the organ's surface",
                                         index + 1, tool.text, o.snap_distance_mm));
  return nearest.position;
}

geometry::ToolTip press_tip(const organ::Organ& organ, const Eigen::Vector3d& rest_point,
                            const Eigen::Vector3d& displacement, const PressOptions& o) {
  const Eigen::Vector3d normal = organ.rest_normal_at(organ.surface_tree().closest_point(rest_point));
  // The probe pushed along its shaft: the shaft trails a press into the organ.
  const Eigen::Vector3d shaft = displacement.dot(normal) < 0.0 ? Eigen::Vector3d(-displacement) : normal;
  return geometry::ToolTip::touching(o.tuning.tip_radius, shaft, normal);
}

double shaft_entry(const organ::Organ& organ, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip) {
  if (tip.is_point()) return std::numeric_limits<double>::infinity();
  // Along the axis only: a seated shaft laid along the surface (a drag across
  // it) keeps its axis R above the surface, while lines off the axis would
  // graze the surface's bumps.
  const Eigen::Vector3d centre = rest_point + tip.seat + tip.radius * tip.axis;
  geometry::SegmentHit hit;
  if (!organ.surface_tree().first_crossing(centre, centre + tip.shaft_length * tip.axis, true, hit))
    return std::numeric_limits<double>::infinity();
  return hit.along * tip.shaft_length;
}

double shaft_entry(const organ::Organ& organ, const ToolSpec& tool, const PressOptions& o) {
  const Eigen::Vector3d point = tool.point_mm * 1e-3, by = tool.displacement_mm * 1e-3;
  if (!point.allFinite() || !by.allFinite()) return std::numeric_limits<double>::infinity();
  const geometry::SurfacePoint at = organ.surface_tree().closest_point(point);
  if (at.distance > o.snap_distance_mm * 1e-3) return std::numeric_limits<double>::infinity();
  return shaft_entry(organ, at.position, press_tip(organ, at.position, by, o));
}

ToolSpec parse_tool(const std::string& text) {
  const std::size_t slash = text.find('/');
  if (slash == std::string::npos)
    throw std::runtime_error("--tool " + text + ": expected X,Y,Z/DX,DY,DZ (point / displacement, mm)");
  return {text, parse_triple(text.substr(0, slash), text), parse_triple(text.substr(slash + 1), text)};
}

PressResult press(const std::string& name, const organ::Organ& organ, const std::vector<ToolSpec>& tools,
                  const PressOptions& o) {
  const realtime::RegisteredModel* entry = realtime::find_model(name);
  if (!entry) throw std::logic_error("unknown deformation model " + name);
  for (std::size_t i = 0; i < tools.size(); ++i) {
    // A tool the model would refuse (not finite, too far) is left to it: it says why in its words.
    if (const double through = shaft_entry(organ, tools[i], o); std::isfinite(through)) {
      const geometry::SurfacePoint at = organ.surface_tree().closest_point(tools[i].point_mm * 1e-3);
      const geometry::ToolTip tip = press_tip(organ, at.position, tools[i].displacement_mm * 1e-3, o);
      const double tilt = std::acos(std::clamp(tip.axis.dot(organ.rest_normal_at(at)), -1.0, 1.0));
      throw std::runtime_error(
          fmt::format("tool {} ({}): its shaft, {:.0f} degrees from the surface normal, would pass "
                      "through the organ {:.1f} mm behind the tip: press closer to the normal or "
                      "from another side",
                      i + 1, tools[i].text, tilt * 180.0 / M_PI, through * 1e3));
    }
  }
  PressResult r;
  switch (entry->static_press) {
    case realtime::StaticPress::beam_tables: r = press_beams(organ, tools, o); break;
    case realtime::StaticPress::equilibrium: r = press_fem(organ, tools, o, *entry->fem_material); break;
    case realtime::StaticPress::settled: r = press_settled(*entry, organ, tools, o); break;
  }
  r.model = name;
  return r;
}

Deformation measure(const organ::Organ& organ, const PressResult& press) {
  const std::vector<model::Point3>& positions = press.positions;
  const model::OrganModel& model = organ.model();
  Deformation d;
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const model::Point3& rest = model.surface_vertices[v];
    const double distance = std::hypot(positions[v][0] - rest[0], positions[v][1] - rest[1], positions[v][2] - rest[2]);
    if (distance > d.max_displacement) {
      d.max_displacement = distance;
      d.max_vertex = v;
    }
  }
  d.volume_of_tetrahedra = !press.node_positions.empty();
  if (!d.volume_of_tetrahedra) {
    d.rest_volume = geometry::enclosed_volume(model.surface_vertices, model.surface_triangles);
    d.deformed_volume = geometry::enclosed_volume(positions, model.surface_triangles);
    return d;
  }
  auto at = [](const model::Point3& p) { return Eigen::Vector3d(p[0], p[1], p[2]); };
  for (const model::Tetrahedron& t : model.tetrahedra) {
    const auto& rest = model.volume_vertices;
    const auto& moved = press.node_positions;
    d.rest_volume +=
        geometry::signed_tetrahedron_volume(at(rest[t[0]]), at(rest[t[1]]), at(rest[t[2]]), at(rest[t[3]]));
    d.deformed_volume +=
        geometry::signed_tetrahedron_volume(at(moved[t[0]]), at(moved[t[1]]), at(moved[t[2]]), at(moved[t[3]]));
  }
  return d;
}

Difference difference(const PressResult& a, const PressResult& b) {
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

namespace {

fem::DisplacementDifference versus(const std::vector<model::Point3>& positions,
                                   const std::vector<model::Point3>& reference, const Eigen::Vector3d& extent) {
  static_assert(sizeof(model::Point3) == 3 * sizeof(double), "points are read as one 3 x n matrix");
  if (positions.empty()) return {};
  const auto columns = static_cast<Eigen::Index>(positions.size());
  return fem::displacement_difference(Eigen::Map<const Eigen::Matrix3Xd>(positions.data()->data(), 3, columns),
                                      Eigen::Map<const Eigen::Matrix3Xd>(reference.data()->data(), 3, columns), extent);
}

}  // namespace

Eigen::Vector3d bounding_box_extent(const std::vector<model::Point3>& points) {
  Eigen::Vector3d low = Eigen::Vector3d::Constant(1e300), high = -low;
  for (const model::Point3& p : points) {
    const Eigen::Vector3d x(p[0], p[1], p[2]);
    low = low.cwiseMin(x);
    high = high.cwiseMax(x);
  }
  return high - low;
}

double force_factor(const PressResult& press, const PressResult& reference) {
  double sum = 0.0;
  for (std::size_t i = 0; i < press.tools.size() && i < reference.tools.size(); ++i) {
    const double ratio = press.tools[i].force.norm() / reference.tools[i].force.norm();
    if (!(ratio > 0.0) || !std::isfinite(ratio)) return std::numeric_limits<double>::quiet_NaN();
    sum += std::log(ratio) * std::log(ratio);
  }
  return press.tools.empty() ? std::numeric_limits<double>::quiet_NaN()
                             : std::exp(std::sqrt(sum / static_cast<double>(press.tools.size())));
}

Comparison compare_presses(const PressResult& press, const PressResult& reference, const Eigen::Vector3d& extent) {
  Comparison c;
  c.surface = versus(press.positions, reference.positions, extent);
  c.on_nodes = !press.node_positions.empty() && !reference.node_positions.empty();
  c.measure = c.on_nodes ? versus(press.node_positions, reference.node_positions, extent) : c.surface;
  return c;
}

void add_press_options(CLI::App& app, std::vector<std::string>& tools, PressOptions& o) {
  app.add_option("--tool", tools,
                 "A tool: X,Y,Z/DX,DY,DZ, a point on or near the surface and its prescribed displacement "
                 "(model frame, mm); repeat for more tools")
      ->required()
      ->allow_extra_args(false);
  app.add_option("--snap-distance", o.snap_distance_mm, "Farthest a tool point may be from the surface, mm")
      ->check(kNonNegative)
      ->capture_default_str();
  add_model_tuning_options(app, o.tuning);
  app.add_option("--grasp", o.grasp_bite_mm,
                 "Grasp: each tool presses this far in along the inward normal, mm, closes its jaws on what it holds "
                 "and then moves to its displacement (outward: a pull), the organ held both ways "
                 "(docs/realtime.md#grasping)")
      ->check(kPositive);
  app.add_option(
         "--settle", o.settle_seconds,
         "Models without a static solver (the mass-spring model): seconds the press is held before the force is "
         "read")
      ->check(kPositive)
      ->capture_default_str();
}

}  // namespace organsim::cli
