#include "refined_reference.h"

#include <stdexcept>
#include <string>

#include "organsim/pipeline/tetrahedra.h"

namespace organsim::cli {

model::OrganModel refined_at(const model::OrganModel& model, const Eigen::Vector3d& site, double size_mm,
                             double radius_mm) {
  pipeline::TetrahedraOptions options;
  const auto given = model.provenance.parameters.find("tet_size_mm");
  if (given != model.provenance.parameters.end()) options.tet_size_mm = std::stod(given->second);
  options.refinements.push_back({{site.x(), site.y(), site.z()}, radius_mm, size_mm});
  // The clamp resolved as the bake resolved it (a model baked before the
  // clamp was refined keeps its coarse clamp: the same organ, re-meshed).
  const auto clamp_cells = model.provenance.parameters.find("clamp_cells_mm");
  const auto clamp_radius = model.provenance.parameters.find("clamp_radius_mm");
  if (clamp_cells != model.provenance.parameters.end() && clamp_radius != model.provenance.parameters.end() &&
      std::stod(clamp_cells->second) > 0.0 && !model.fixed_points.empty())
    options.refinements.push_back(pipeline::clamp_refinement(
        model.fixed_points.front(), std::stod(clamp_radius->second) * 1e-3, std::stod(clamp_cells->second)));
  const geometry::TetrahedralMesh mesh =
      pipeline::make_tetrahedra({model.surface_vertices, model.surface_triangles}, options);
  model::OrganModel refined = model;
  refined.volume_vertices = mesh.vertices;
  refined.tetrahedra = mesh.tetrahedra;
  refined.beams = {};
  return refined;
}

}  // namespace organsim::cli
