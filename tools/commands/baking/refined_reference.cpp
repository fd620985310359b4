#include "refined_reference.h"

#include "organsim/tetrahedra/tetrahedra.h"

namespace organsim::cli {

model::OrganModel refined_at(const model::OrganModel& model, const Eigen::Vector3d& site, double size_mm,
                             double radius_mm) {
  // Meshed as the bake meshed it (the model's meshing record), finer under the
  // tool; a model that does not say keeps the mesher's default size and an
  // unrefined clamp.
  pipeline::TetrahedraOptions options;
  if (!model.meshing.empty()) options.tet_size_mm = model.meshing.tet_size * 1e3;
  options.refinements.push_back({{site.x(), site.y(), site.z()}, radius_mm, size_mm});
  if (model.meshing.clamp_cell_size > 0.0 && model.meshing.clamp_radius > 0.0 && !model.fixed_points.empty())
    options.refinements.push_back(pipeline::clamp_refinement(model.fixed_points.front(), model.meshing.clamp_radius,
                                                             model.meshing.clamp_cell_size * 1e3));
  const geometry::TetrahedralMesh mesh =
      pipeline::make_tetrahedra({model.surface_vertices, model.surface_triangles}, options);
  model::OrganModel refined = model;
  refined.volume_vertices = mesh.vertices;
  refined.tetrahedra = mesh.tetrahedra;
  refined.beams = {};
  return refined;
}

}  // namespace organsim::cli
