// The multi-beam model (Ushiki et al.; organsim/multibeam/multibeam.h) in the engine.
#include <cmath>
#include <iterator>
#include <string>
#include <vector>

#include "organsim/multibeam/multibeam.h"
#include "organsim/realtime/model_registry.h"

namespace organsim::realtime {
namespace {

/// The multi-beam model: its beam's contact force is linear in the
/// displacement, so the linearization at zero displacement (force 0,
/// stiffness K) is exact and never changes during a contact; a matched
/// contact's site law (docs/matching.md) is linearized again at every frame.
/// The beam has no contact surface: a tip of finite size holds the organ at
/// its action point as a point tool does, and the surface it would cut into
/// is laid onto it (docs/realtime.md#contact-rule).
class BeamModel final : public DeformationModel {
 public:
  BeamModel(const organ::Organ& organ, const multibeam::MultiBeamOptions& options)
      : organ_(organ),
        beams_(organ, options),
        tips_(options.max_tools),
        grasps_(options.max_tools),
        last_displacements_(options.max_tools, Eigen::Vector3d::Zero()) {}

  const char* name() const noexcept override { return "beam"; }

  bool attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip,
              ContactLinearization& contact) noexcept override {
    if (tool >= tips_.size() || !std::isfinite(tip.radius) || tip.radius < 0.0) return false;
    if (!tip.is_point() && !(std::abs(tip.axis.norm() - 1.0) < 1e-6)) return false;
    if (beams_.attach(tool, rest_point, tip.radius) != multibeam::Status::ok) return false;
    tips_[tool] = tip;
    grasps_[tool].open();
    last_displacements_[tool].setZero();
    const multibeam::ToolBeam& beam = beams_.beam(tool);
    contact.action_point = beam.action.position;
    contact.normal = organ_.rest_normal_at(beam.action);
    contact.stiffness = beam.stiffness;
    contact.displacement.setZero();
    contact.force.setZero();
    return true;
  }

  void detach(std::uint32_t tool) noexcept override {
    beams_.detach(tool);
    if (tool < grasps_.size()) grasps_[tool].open();
  }

  /// The beam's own force, −K d, holds both ways already; a matched contact
  /// goes on past the rest surface with the held patch's law (organ::SiteGrasp).
  void set_grasp(std::uint32_t tool, bool grasped) noexcept override {
    if (tool >= grasps_.size() || !beams_.beam(tool).attached) return;
    if (!grasped)
      grasps_[tool].open();
    else if (!grasps_[tool].held)
      grasps_[tool].close(beams_.beam(tool).law, last_displacements_[tool]);
  }

  bool step(double, const Eigen::Vector3d* displacements, model::Point3* positions, model::Point3* normals,
            ContactLinearization* contacts) noexcept override {
    const std::size_t n = organ_.vertex_count();
    if (beams_.deform(displacements, positions, normals, n) != multibeam::Status::ok) return false;
    for (std::uint32_t tool = 0; tool < tips_.size(); ++tool) {
      const multibeam::ToolBeam& beam = beams_.beam(tool);
      if (!beam.attached) continue;
      last_displacements_[tool] = displacements[tool];
      if (!beam.matched) continue;
      const organ::SiteGrasp& grasp = grasps_[tool];
      const Eigen::Vector3d& d = displacements[tool];
      contacts[tool].displacement = d;
      contacts[tool].force = grasp.held ? grasp.force(beam.law, d) : beam.law.force(d);
      contacts[tool].stiffness = grasp.held ? grasp.tangent(beam.law, d) : beam.law.tangent(d);
    }
    bool laid = false;
    for (std::uint32_t tool = 0; tool < tips_.size(); ++tool)
      if (beams_.beam(tool).attached && !tips_[tool].is_point())
        laid |= tips_[tool].push_out(beams_.beam(tool).action.position + tips_[tool].seat + displacements[tool],
                                     positions, n);
    if (laid) organ::compute_vertex_normals(organ_, positions, normals, 0, n);
    return true;
  }

 private:
  const organ::Organ& organ_;
  multibeam::MultiBeam beams_;
  std::vector<geometry::ToolTip> tips_;              // per tool
  std::vector<organ::SiteGrasp> grasps_;             // per tool: a matched contact in the jaws
  std::vector<Eigen::Vector3d> last_displacements_;  // per tool, m: the last step's
};

const char* merge_name(multibeam::MergeRule rule) { return rule == multibeam::MergeRule::sum ? "sum" : "influence"; }

const ModelParameter kBeamParameters[] = {
    {"merge", ModelParameter::Kind::choice, "beam: how the tools' beams combine, influence (eq. 7) or sum (eq. 5)",
     "influence|sum",
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       return multibeam::parse_merge_rule(v.text, o.edit<multibeam::MultiBeamOptions>().merge) ? "" : "unknown rule";
     },
     [](const ModelOptions& o) {
       return ParameterValue{0.0, merge_name(o.of<multibeam::MultiBeamOptions>().merge)};
     }},
    {"theory", ModelParameter::Kind::choice, "beam: the beams' theory", "euler-bernoulli|timoshenko",
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       return multibeam::parse_beam_theory(v.text, o.edit<multibeam::MultiBeamOptions>().beam.theory)
                  ? ""
                  : "unknown theory";
     },
     [](const ModelOptions& o) {
       const bool timoshenko = o.of<multibeam::MultiBeamOptions>().beam.theory == multibeam::BeamTheory::timoshenko;
       return ParameterValue{0.0, timoshenko ? "timoshenko" : "euler-bernoulli"};
     }},
    {"sections", ModelParameter::Kind::choice,
     "beam: eccentric (elements through the section centroids) or centred (on the fixed point-action point line)",
     "eccentric|centred",
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       if (v.text != "eccentric" && v.text != "centred") return "unknown sections";
       o.edit<multibeam::MultiBeamOptions>().beam.centroid_offsets = v.text == "eccentric";
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{0.0, o.of<multibeam::MultiBeamOptions>().beam.centroid_offsets ? "eccentric" : "centred"};
     }},
    {"unmatched", ModelParameter::Kind::flag,
     "beam, springs: the model's own contact force, not the FEM reference's site law that a model with site "
     "compliances gives a tool of finite size (docs/matching.md)",
     nullptr,
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       o.edit<multibeam::MultiBeamOptions>().match_sites = v.number == 0.0;
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{o.of<multibeam::MultiBeamOptions>().match_sites ? 0.0 : 1.0, {}};
     }},
    {"supports", ModelParameter::Kind::choice, kSupportsHelp, kSupportsChoices,
     [](ModelOptions& o, const ParameterValue& v) {
       return read_supports(v, o.edit<multibeam::MultiBeamOptions>().supports);
     },
     [](const ModelOptions& o) { return supports_value(o.of<multibeam::MultiBeamOptions>().supports); }},
};

}  // namespace

extern const RegisteredModel beam_model{
    "beam",
    "multi-beam (Ushiki et al.): a clamped beam per tool, the organ moved by their space distortion",
    /*needs_beam_tables=*/true,
    /*needs_tetrahedra=*/false,
    /*fem_material=*/std::nullopt,
    StaticPress::beam_tables,
    [](const ModelOptions& options) { return options.of<multibeam::MultiBeamOptions>().match_sites; },
    /*calibration=*/{&model::Material::beam_stiffness_scale, /*attenuated=*/true},
    kBeamParameters,
    std::size(kBeamParameters),
    [](const organ::Organ& organ, const ModelOptions& options, std::size_t tools) -> std::unique_ptr<DeformationModel> {
      multibeam::MultiBeamOptions beams = options.of<multibeam::MultiBeamOptions>();
      beams.max_tools = static_cast<std::uint32_t>(tools);
      return std::make_unique<BeamModel>(organ, beams);
    }};

}  // namespace organsim::realtime
