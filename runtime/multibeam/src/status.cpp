#include "organsim/multibeam/status.h"

namespace organsim::multibeam {

const char* describe(Status status) noexcept {
  switch (status) {
    case Status::ok: return "ok";
    case Status::not_finite: return "a tool point or displacement is NaN or infinite; pass finite values in metres";
    case Status::far_from_organ:
      return "the tool point is farther from the organ surface than the snap distance; touch the organ";
    case Status::at_fixed_point:
      return "the action point is at the fixed point where the organ is clamped; press elsewhere";
    case Status::no_beam_tables:
      return "the model has no beam tables (baked with --no-beam-tables); bake it again without that option";
    case Status::singular_beam:
      return "the beam's stiffness is singular (empty sections); check the model's beam tables";
    case Status::too_many_tools: return "more tools than the state was made for; raise max_tools (at most 16)";
    case Status::no_contact: return "the tool has no beam; attach it to the organ first";
    case Status::buffer_too_small: return "an output buffer is smaller than the organ's vertex count";
  }
  return "unknown status";
}

}  // namespace organsim::multibeam
