// A test-only deformation model: a rigid organ that never moves, each contact
// a spring of the stiffness its one setting gives, tying the tool to the point
// it touched. Added as a model is added (model_registry.h): this folder, and
// the one registration line at its end; the commands and the engine tests then
// run it like any other.
#include <cmath>
#include <cstdint>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "organsim/organ/organ.h"
#include "organsim/realtime/model_registry.h"

namespace organsim::testing {
namespace {

using realtime::ContactLinearization;
using realtime::ModelOptions;
using realtime::ModelParameter;
using realtime::ParameterValue;

struct RigidOptions {
  double stiffness = 200.0;  ///< N/m: each contact's spring, the same in every direction
};

class RigidModel final : public realtime::DeformationModel {
 public:
  RigidModel(const organ::Organ& organ, const RigidOptions& options, std::size_t tools)
      : organ_(organ), options_(options), attached_(tools, false) {}

  const char* name() const noexcept override { return "rigid"; }

  bool attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip,
              ContactLinearization& contact) noexcept override {
    if (tool >= attached_.size() || !rest_point.allFinite() || !std::isfinite(tip.radius)) return false;
    const geometry::SurfacePoint at = organ_.surface_tree().closest_point(rest_point);
    contact.action_point = at.position;
    contact.normal = organ_.rest_normal_at(at);
    contact.stiffness = options_.stiffness * Eigen::Matrix3d::Identity();
    contact.displacement.setZero();
    contact.force.setZero();
    attached_[tool] = true;
    return true;
  }
  void detach(std::uint32_t tool) noexcept override {
    if (tool < attached_.size()) attached_[tool] = false;
  }
  void set_grasp(std::uint32_t, bool) noexcept override {}  // the spring holds both ways already

  bool step(double, const Eigen::Vector3d* displacements, model::Point3* positions, model::Point3* normals,
            ContactLinearization* contacts) noexcept override {
    for (std::size_t tool = 0; tool < attached_.size(); ++tool)
      if (attached_[tool] && !displacements[tool].allFinite()) return false;
    const std::size_t n = organ_.vertex_count();
    for (std::size_t v = 0; v < n; ++v) positions[v] = organ_.model().surface_vertices[v];
    organ::compute_vertex_normals(organ_, positions, normals, 0, n);
    for (std::size_t tool = 0; tool < attached_.size(); ++tool)
      if (attached_[tool]) {
        contacts[tool].displacement = displacements[tool];
        contacts[tool].force = -options_.stiffness * displacements[tool];
      }
    return true;
  }

 private:
  const organ::Organ& organ_;
  RigidOptions options_;
  std::vector<bool> attached_;
};

const ModelParameter kRigidParameters[] = {
    {"rigid-stiffness", ModelParameter::Kind::number, "rigid: each contact's spring, N/m", nullptr,
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       if (!(v.number > 0.0) || !std::isfinite(v.number)) return "the stiffness must be a positive number of N/m";
       o.edit<RigidOptions>().stiffness = v.number;
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{o.of<RigidOptions>().stiffness, {}};
     }},
};

const realtime::RegisteredModel rigid_model{"rigid",
                                            "a rigid organ (a test model): each contact a spring to the point touched",
                                            /*needs_beam_tables=*/false,
                                            /*needs_tetrahedra=*/false,
                                            /*fem_material=*/std::nullopt,
                                            realtime::StaticPress::settled,
                                            /*matches_reference=*/nullptr,
                                            /*calibration=*/{},
                                            kRigidParameters,
                                            std::size(kRigidParameters),
                                            [](const organ::Organ& organ, const ModelOptions& options,
                                               std::size_t tools) -> std::unique_ptr<realtime::DeformationModel> {
                                              return std::make_unique<RigidModel>(organ, options.of<RigidOptions>(),
                                                                                  tools);
                                            }};

ORGANSIM_REGISTER_MODEL(rigid_model);

}  // namespace
}  // namespace organsim::testing
