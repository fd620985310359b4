// Loads a model and presses its first surface vertex 5 mm inward with the
// multi-beam model: prints the force (N) and how far that vertex moved (mm).
#include <cstdio>
#include <vector>

#include "organsim/model/model_file.h"
#include "organsim/organ/organ.h"
#include "organsim/multibeam/multibeam.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: press MODEL.organ\n");
    return 2;
  }
  organsim::model::ModelReadResult read = organsim::model::read_organ_model_file(argv[1]);
  if (!read) {
    std::fprintf(stderr, "press: %s\n", read.error.c_str());
    return 1;
  }
  const organsim::organ::Organ organ(std::move(*read.model));
  organsim::multibeam::MultiBeam beam(organ, {});
  std::vector<organsim::model::Point3> normals(organ.vertex_count()), positions(organ.vertex_count());
  organsim::organ::compute_vertex_normals(organ, organ.model().surface_vertices.data(), normals.data(), 0,
                                          organ.vertex_count());
  const auto& rest = organ.model().surface_vertices[0];
  const Eigen::Vector3d at(rest[0], rest[1], rest[2]);
  const Eigen::Vector3d press = -0.005 * Eigen::Vector3d(normals[0][0], normals[0][1], normals[0][2]);
  if (beam.attach(0, at) != organsim::multibeam::Status::ok) return 1;
  Eigen::Vector3d force;
  beam.force(0, press, force);
  std::vector<Eigen::Vector3d> tips(beam.max_tools(), Eigen::Vector3d::Zero());
  tips[0] = press;
  beam.deform(tips.data(), positions.data(), normals.data(), positions.size());
  const Eigen::Vector3d moved(positions[0][0] - rest[0], positions[0][1] - rest[1], positions[0][2] - rest[2]);
  std::printf("force %.6f N, vertex moved %.3f mm\n", force.norm(), 1e3 * moved.norm());
  return force.norm() > 0.0 ? 0 : 1;
}
