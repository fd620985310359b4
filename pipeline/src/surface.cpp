#include "organsim/pipeline/surface.h"

#include <vtkCellArray.h>
#include <vtkCleanPolyData.h>
#include <vtkFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkQuadricDecimation.h>
#include <vtkSmartPointer.h>
#include <vtkTriangleFilter.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowedSincPolyDataFilter.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

namespace organsim::pipeline {
namespace {

template <typename T>
using Ptr = vtkSmartPointer<T>;

/// The mask as VTK image data in "scaled index" space (index × spacing, origin
/// 0): VTK 9.1's filters ignore a direction matrix, so the patient-frame
/// transform is applied to the output points afterwards.
Ptr<vtkImageData> to_vtk(const MaskImage& mask) {
  const auto size = mask.GetLargestPossibleRegion().GetSize();
  auto image = Ptr<vtkImageData>::New();
  // One voxel of zero padding on every side so that the surface is closed at the border.
  image->SetDimensions(static_cast<int>(size[0]) + 2, static_cast<int>(size[1]) + 2, static_cast<int>(size[2]) + 2);
  image->SetSpacing(mask.GetSpacing()[0], mask.GetSpacing()[1], mask.GetSpacing()[2]);
  image->SetOrigin(-mask.GetSpacing()[0], -mask.GetSpacing()[1], -mask.GetSpacing()[2]);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* out = static_cast<std::uint8_t*>(image->GetScalarPointer());
  std::memset(out, 0, (size[0] + 2) * (size[1] + 2) * (size[2] + 2));
  const std::uint8_t* in = mask.GetBufferPointer();
  for (std::size_t k = 0; k < size[2]; ++k)
    for (std::size_t j = 0; j < size[1]; ++j)
      for (std::size_t i = 0; i < size[0]; ++i)
        out[((k + 1) * (size[1] + 2) + (j + 1)) * (size[0] + 2) + (i + 1)] =
            in[(k * size[1] + j) * size[0] + i] ? 1 : 0;
  return image;
}

void check_closed_manifold(const SurfaceMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const Triangle& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  for (const auto& [edge, count] : directed) {
    const auto opposite = directed.find({edge.second, edge.first});
    if (count != 1 || opposite == directed.end() || opposite->second != 1)
      throw std::runtime_error(fmt::format(
          "the extracted surface is not a closed, consistently oriented manifold (edge {}-{}); try more smoothing, "
          "a larger --surface-vertices or a cleaner mask (--closing)",
          edge.first, edge.second));
  }
}

}  // namespace

double enclosed_volume(const SurfaceMesh& m) {
  double volume = 0.0;
  for (const Triangle& t : m.triangles) {
    const Point3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    volume += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
               a[2] * (b[0] * c[1] - b[1] * c[0])) /
              6.0;
  }
  return volume;
}

double surface_area(const SurfaceMesh& m) {
  double area = 0.0;
  for (const Triangle& t : m.triangles) {
    const Point3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    area += 0.5 * std::sqrt(std::pow(u[1] * v[2] - u[2] * v[1], 2) + std::pow(u[2] * v[0] - u[0] * v[2], 2) +
                            std::pow(u[0] * v[1] - u[1] * v[0], 2));
  }
  return area;
}

SurfaceMesh extract_surface(const MaskImage& mask, const SurfaceOptions& options) {
  auto contour = Ptr<vtkFlyingEdges3D>::New();
  contour->SetInputData(to_vtk(mask));
  contour->SetValue(0, 0.5);
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  contour->ComputeScalarsOff();
  contour->Update();
  if (contour->GetOutput()->GetNumberOfCells() == 0) throw std::runtime_error("the segmentation is empty");

  auto smooth = Ptr<vtkWindowedSincPolyDataFilter>::New();
  smooth->SetInputConnection(contour->GetOutputPort());
  smooth->SetNumberOfIterations(options.smoothing_iterations);
  smooth->SetPassBand(options.smoothing_passband);
  smooth->NormalizeCoordinatesOn();
  smooth->BoundarySmoothingOff();
  smooth->FeatureEdgeSmoothingOff();
  smooth->NonManifoldSmoothingOn();
  smooth->Update();

  Ptr<vtkPolyData> surface = smooth->GetOutput();
  const auto points = static_cast<std::size_t>(surface->GetNumberOfPoints());
  if (points > options.target_vertices) {
    auto decimate = Ptr<vtkQuadricDecimation>::New();
    decimate->SetInputData(surface);
    decimate->SetTargetReduction(1.0 - static_cast<double>(options.target_vertices) / points);
    decimate->VolumePreservationOn();
    auto clean = Ptr<vtkCleanPolyData>::New();
    clean->SetInputConnection(decimate->GetOutputPort());
    auto triangles = Ptr<vtkTriangleFilter>::New();
    triangles->SetInputConnection(clean->GetOutputPort());
    triangles->Update();
    surface = triangles->GetOutput();
  }

  SurfaceMesh mesh;
  const auto direction = mask.GetDirection();
  const auto origin = mask.GetOrigin();
  mesh.vertices.resize(static_cast<std::size_t>(surface->GetNumberOfPoints()));
  for (vtkIdType i = 0; i < surface->GetNumberOfPoints(); ++i) {
    double q[3];
    surface->GetPoint(i, q);
    for (int r = 0; r < 3; ++r)
      mesh.vertices[i][r] =
          (origin[r] + direction[r][0] * q[0] + direction[r][1] * q[1] + direction[r][2] * q[2]) * 1e-3;
  }
  vtkCellArray* polys = surface->GetPolys();
  polys->InitTraversal();
  vtkIdType n = 0;
  const vtkIdType* ids = nullptr;
  while (polys->GetNextCell(n, ids))
    if (n == 3)
      mesh.triangles.push_back({static_cast<std::uint32_t>(ids[0]), static_cast<std::uint32_t>(ids[1]),
                                static_cast<std::uint32_t>(ids[2])});
  // Flying edges' orientation depends on the image axes' handedness: make it outward.
  if (enclosed_volume(mesh) < 0)
    for (Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
  check_closed_manifold(mesh);
  return mesh;
}

}  // namespace organsim::pipeline
