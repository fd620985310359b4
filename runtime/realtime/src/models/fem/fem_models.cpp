// The FEM models on the model's tetrahedra (organsim/organ_fem/organ_fem.h) in the
// engine: linear, co-rotational, St. Venant–Kirchhoff and pressure-stabilized
// Mooney–Rivlin (Ogata et al.), one class with the material as a parameter.
#include <cmath>
#include <iterator>
#include <string>

#include "organsim/organ_fem/organ_fem.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/realtime/model_registry.h"

namespace organsim::realtime {
namespace {

/// A FEM model (fem/organ_fem.h): one warm-started iteration per frame; the
/// contact's force and condensed stiffness are the linearization.
class FemModel final : public DeformationModel {
 public:
  FemModel(const char* name, fem::MaterialModel material, const organ::Organ& organ,
           const fem::OrganFemOptions& options, std::size_t tools)
      : name_(name), organ_(organ), fem_(organ.model(), material, options, tools) {}

  const char* name() const noexcept override { return name_; }

  bool attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip,
              ContactLinearization& contact) noexcept override {
    if (!fem_.attach(tool, rest_point, tip)) return false;
    contact.action_point = rest_point;
    contact.normal = organ_.rest_normal_at(organ_.surface_tree().closest_point(rest_point));
    linearize(tool, contact);
    // The organ may already be deformed there: the tool begins with no force
    // where the material point is now.
    contact.force.setZero();
    return true;
  }

  void detach(std::uint32_t tool) noexcept override { fem_.detach(tool); }
  void set_grasp(std::uint32_t tool, bool grasped) noexcept override { fem_.grasp(tool, grasped); }

  bool step(double, const Eigen::Vector3d* displacements, model::Point3* positions, model::Point3* normals,
            ContactLinearization* contacts) noexcept override {
    const fem::FrameStatus status = fem_.step(displacements);
    if (status == fem::FrameStatus::not_finite) return false;
    // The organ keeps its shape this frame: even a sixteenth of the step
    // would have inverted a tetrahedron, or the step would have thrown the
    // organ out of balance.
    if (status == fem::FrameStatus::kept_shape) ++instabilities_;
    fem_.surface_positions(positions);
    organ::compute_vertex_normals(organ_, positions, normals, 0, organ_.vertex_count());
    for (std::uint32_t tool = 0; tool < multibeam::kMaxTools; ++tool)
      if (fem_.attached(tool)) linearize(tool, contacts[tool]);
    return true;
  }

  std::uint64_t instabilities() const noexcept override { return instabilities_; }
  void set_reproducible(bool reproducible) noexcept override { fem_.set_reproducible(reproducible); }
  double estimated_frame_seconds() const noexcept override { return fem_.estimated_frame_seconds(); }

  bool volume_node_positions(model::Point3* positions, std::size_t capacity) const noexcept override {
    if (capacity < organ_.model().volume_vertices.size()) return false;
    fem_.node_positions(positions);
    return true;
  }

 private:
  void linearize(std::uint32_t tool, ContactLinearization& contact) const noexcept {
    contact.displacement = fem_.contact_displacement(tool);
    contact.force = fem_.contact_force(tool);
    contact.stiffness = fem_.contact_stiffness(tool);
  }

  const char* name_;
  const organ::Organ& organ_;
  fem::OrganFem fem_;
  std::uint64_t instabilities_ = 0;
};

std::unique_ptr<DeformationModel> make_fem(const char* name, fem::MaterialModel material, const organ::Organ& organ,
                                           const ModelOptions& options, std::size_t tools) {
  return std::make_unique<FemModel>(name, material, organ, options.of<fem::OrganFemOptions>(), tools);
}

const ModelParameter kFemParameters[] = {
    {"fixed-radius", ModelParameter::Kind::length,
     "FEM models (and springs with --volume-springs): clamp the tetrahedral nodes within this distance of the fixed "
     "point (docs/fem.md)",
     nullptr,
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       if (!(v.number > 0.0) || !std::isfinite(v.number)) return "the clamp's radius must be a positive length";
       o.edit<fem::OrganFemOptions>().fixed_radius = v.number;
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{o.of<fem::OrganFemOptions>().fixed_radius, {}};
     }},
    {"supports", ModelParameter::Kind::choice, kSupportsHelp, kSupportsChoices,
     [](ModelOptions& o, const ParameterValue& v) { return read_supports(v, o.edit<fem::OrganFemOptions>().supports); },
     [](const ModelOptions& o) { return supports_value(o.of<fem::OrganFemOptions>().supports); }},
};

}  // namespace

extern const RegisteredModel linear_model{
    "linear",
    "linear FEM on the tetrahedra (small strains)",
    false,
    true,
    fem::MaterialModel::linear,
    StaticPress::equilibrium,
    /*matches_reference=*/nullptr,
    /*calibration=*/{},
    kFemParameters,
    std::size(kFemParameters),
    [](const organ::Organ& organ, const ModelOptions& options, std::size_t tools) {
      return make_fem("linear", fem::MaterialModel::linear, organ, options, tools);
    }};
extern const RegisteredModel corotational_model{
    "corotational",
    "co-rotational linear FEM (large rotations, small strains)",
    false,
    true,
    fem::MaterialModel::corotational,
    StaticPress::equilibrium,
    /*matches_reference=*/nullptr,
    /*calibration=*/{},
    kFemParameters,
    std::size(kFemParameters),
    [](const organ::Organ& organ, const ModelOptions& options, std::size_t tools) {
      return make_fem("corotational", fem::MaterialModel::corotational, organ, options, tools);
    }};
extern const RegisteredModel stvk_model{"stvk",
                                        "St. Venant-Kirchhoff FEM (large strains)",
                                        false,
                                        true,
                                        fem::MaterialModel::stvk,
                                        StaticPress::equilibrium,
                                        /*matches_reference=*/nullptr,
                                        /*calibration=*/{},
                                        kFemParameters,
                                        std::size(kFemParameters),
                                        [](const organ::Organ& organ, const ModelOptions& options, std::size_t tools) {
                                          return make_fem("stvk", fem::MaterialModel::stvk, organ, options, tools);
                                        }};
extern const RegisteredModel psh_model{
    "psh",
    "pressure-stabilized hyperelastic FEM (Ogata et al.: Mooney-Rivlin, nearly incompressible)",
    false,
    true,
    fem::MaterialModel::mooney_rivlin,
    StaticPress::equilibrium,
    /*matches_reference=*/nullptr,
    /*calibration=*/{},
    kFemParameters,
    std::size(kFemParameters),
    [](const organ::Organ& organ, const ModelOptions& options, std::size_t tools) {
      return make_fem("psh", fem::MaterialModel::mooney_rivlin, organ, options, tools);
    }};

}  // namespace organsim::realtime
