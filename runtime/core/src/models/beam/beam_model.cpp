// The multi-beam model (Ushiki et al.; organsim/multibeam/multibeam.h) in the engine.
#include "organsim/geometry/model_measures.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/realtime/model_registry.h"

namespace organsim::realtime {
namespace {

/// The multi-beam model: its contact force is linear in the displacement, so
/// the linearization at zero displacement (force 0, stiffness K) is exact and
/// never changes during a contact.
class BeamModel final : public DeformationModel {
 public:
  BeamModel(const organ::Organ& organ, const multibeam::MultiBeamOptions& options)
      : organ_(organ), beams_(organ, options) {}

  const char* name() const noexcept override { return "beam"; }

  bool attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, ContactLinearization& contact) noexcept override {
    if (beams_.attach(tool, rest_point) != multibeam::Status::ok) return false;
    const multibeam::ToolBeam& beam = beams_.beam(tool);
    contact.action_point = beam.action.position;
    contact.normal = geometry::triangle_normal(organ_.model(), beam.action.triangle);
    contact.stiffness = beam.stiffness;
    contact.displacement.setZero();
    contact.force.setZero();
    return true;
  }

  void detach(std::uint32_t tool) noexcept override { beams_.detach(tool); }

  bool step(double, const Eigen::Vector3d* displacements, model::Point3* positions, model::Point3* normals,
            ContactLinearization*) noexcept override {
    return beams_.deform(displacements, positions, normals, organ_.vertex_count()) == multibeam::Status::ok;
  }

 private:
  const organ::Organ& organ_;
  multibeam::MultiBeam beams_;
};

}  // namespace

extern const RegisteredModel beam_model{
    "beam", "multi-beam (Ushiki et al.): a clamped beam per tool, the organ moved by their space distortion",
    /*needs_beam_tables=*/true, /*needs_tetrahedra=*/false, std::nullopt,
    [](const organ::Organ& organ, const ModelOptions& options, std::size_t) -> std::unique_ptr<DeformationModel> {
      return std::make_unique<BeamModel>(organ, options.beams);
    }};

}  // namespace organsim::realtime
