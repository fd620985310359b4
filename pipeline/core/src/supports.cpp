#include "organsim/pipeline/supports.h"

#include <itkLinearInterpolateImageFunction.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <fmt/format.h>

namespace organsim::pipeline {

model::Supports find_supports(const CtImage& ct, const model::OrganModel& model, const SupportOptions& o,
                              SupportReport* report) {
  if (!(o.near_mm >= 0.0 && o.far_mm > o.near_mm && o.samples >= 2 && o.attachment_radius_mm >= 0.0 &&
        o.tissue_young_modulus >= 0.0 && o.yielding_depth_mm > 0.0 && std::isfinite(o.far_mm) &&
        std::isfinite(o.tissue_low_hu)))
    throw std::runtime_error(
        "supports: the band must run outwards (0 <= near < far), with at least 2 samples, and the attachment radius, "
        "the tissue's modulus and a positive yielding depth must be finite and not negative");
  const double young = o.tissue_young_modulus > 0.0 ? o.tissue_young_modulus : model.material.young_modulus;
  const double modulus = young / (o.yielding_depth_mm * 1e-3);
  if (!(modulus > 0.0 && modulus <= model::Supports::kMaxModulus))
    throw std::runtime_error(fmt::format("supports: a foundation modulus of {:g} Pa/m is out of range", modulus));

  // Area-weighted outward normals and a third of each triangle's area per vertex.
  const std::size_t n = model.surface_vertices.size();
  std::vector<Eigen::Vector3d> normals(n, Eigen::Vector3d::Zero());
  std::vector<double> areas(n, 0.0);
  const auto at = [&](std::uint32_t v) {
    const auto& p = model.surface_vertices[v];
    return Eigen::Vector3d(p[0], p[1], p[2]);
  };
  for (const auto& t : model.surface_triangles) {
    const Eigen::Vector3d twice_area = (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0]));
    for (const std::uint32_t v : t) normals[v] += twice_area, areas[v] += twice_area.norm() / 6.0;
  }

  auto interpolate = itk::LinearInterpolateImageFunction<CtImage, double>::New();
  interpolate->SetInputImage(&ct);
  // The attachments lie about the surface point nearest the clamp (the hilum
  // for a fixed point at the portal vein's entry).
  const Eigen::Vector3d fixed_point(model.fixed_points.front()[0], model.fixed_points.front()[1],
                                    model.fixed_points.front()[2]);
  Eigen::Vector3d anchor = at(0);
  for (std::uint32_t v = 1; v < n; ++v)
    if ((at(v) - fixed_point).squaredNorm() < (anchor - fixed_point).squaredNorm()) anchor = at(v);
  const double attachment_m = o.attachment_radius_mm * 1e-3;

  SupportReport r;
  r.modulus = modulus;
  model::Supports supports;
  supports.vertices.resize(n, {0.0, 0.0});
  for (std::size_t v = 0; v < n; ++v) {
    r.surface_area_cm2 += areas[v] * 1e4;
    const double length = normals[v].norm();
    int seen = 0, tissue = 0;
    if (length > 0.0) {
      const Eigen::Vector3d outward = normals[v] / length;
      for (int k = 0; k < o.samples; ++k) {
        const double out_mm = o.near_mm + (o.far_mm - o.near_mm) * k / (o.samples - 1);
        const Eigen::Vector3d p_mm = at(static_cast<std::uint32_t>(v)) * 1e3 + out_mm * outward;
        CtImage::PointType point;
        for (unsigned d = 0; d < 3; ++d) point[d] = p_mm[d];
        if (!interpolate->IsInsideBuffer(point)) continue;
        ++seen;
        if (interpolate->Evaluate(point) >= o.tissue_low_hu) ++tissue;
      }
    }
    // Most of the band seen and most of what is seen tissue: the organ lies
    // against a neighbour there.
    if (2 * seen <= o.samples) {
      ++r.unseen_vertices, ++r.free_vertices;
      continue;
    }
    if (2 * tissue <= seen) {
      ++r.free_vertices;
      continue;
    }
    const bool attached = (at(static_cast<std::uint32_t>(v)) - anchor).norm() <= attachment_m;
    const model::Supports::Kind kind = attached ? model::Supports::Kind::kAttachment : model::Supports::Kind::kContact;
    supports.vertices[v] = {static_cast<double>(static_cast<int>(kind)), modulus};
    if (attached)
      ++r.attachment_vertices, r.attachment_area_cm2 += areas[v] * 1e4;
    else
      ++r.contact_vertices, r.contact_area_cm2 += areas[v] * 1e4;
  }
  if (report) *report = r;
  return supports;
}

}  // namespace organsim::pipeline
