#include "organsim/pipeline/surface.h"

#include <vtkCellArray.h>
#include <vtkCleanPolyData.h>
#include <vtkFlyingEdges3D.h>
#include <vtkImageData.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyDataConnectivityFilter.h>
#include <vtkPolyData.h>
#include <vtkQuadricDecimation.h>
#include <vtkSmartPointer.h>
#include <vtkSmoothPolyDataFilter.h>
#include <vtkTriangleFilter.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowedSincPolyDataFilter.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

#include "organsim/geometry/model_measures.h"
#include "organsim/pipeline/segmentation.h"
#include "organsim/tetrahedra/volume_matching.h"

namespace organsim::pipeline {
namespace {

template <typename T>
using Ptr = vtkSmartPointer<T>;

// Contour at most this many times the target vertex count before decimating.
constexpr double kVerticesPerTarget = 8.0;
// Coarsest down-sampling: blocks of 4³ voxels.
constexpr long kLargestBlock = 4;
constexpr double kCubicMetresPerCubicMillimetre = 1e-9;
// The Laplacian pass after decimation (see decimated()).
constexpr int kDespikeIterations = 20;
constexpr double kDespikeRelaxation = 0.1;

/// Faces between organ and background voxels inside `box`: about the number
/// of vertices flying edges makes at full resolution.
std::size_t boundary_faces(const MaskImage& mask, const MaskImage::RegionType& box) {
  const long nx = static_cast<long>(mask.GetLargestPossibleRegion().GetSize(0)),
             ny = static_cast<long>(mask.GetLargestPossibleRegion().GetSize(1));
  const std::uint8_t* v = mask.GetBufferPointer();
  const long x0 = box.GetIndex(0), y0 = box.GetIndex(1), z0 = box.GetIndex(2);
  const long x1 = x0 + static_cast<long>(box.GetSize(0)), y1 = y0 + static_cast<long>(box.GetSize(1)),
             z1 = z0 + static_cast<long>(box.GetSize(2));
  std::size_t faces = 0;
  for (long k = z0; k < z1; ++k)
    for (long j = y0; j < y1; ++j)
      for (long i = x0; i < x1; ++i) {
        const std::uint8_t here = v[(k * ny + j) * nx + i] != 0;
        if (i + 1 < x1) faces += here != (v[(k * ny + j) * nx + i + 1] != 0);
        if (j + 1 < y1) faces += here != (v[(k * ny + j + 1) * nx + i] != 0);
        if (k + 1 < z1) faces += here != (v[((k + 1) * ny + j) * nx + i] != 0);
      }
  return faces;
}

/// The organ's part of the mask as VTK image data in "scaled index" space
/// (index × spacing, origin 0: VTK 9.1's filters ignore a direction matrix,
/// so the patient-frame transform is applied to the output points afterwards).
/// Each output voxel is the mean of a `factor`³ block of mask voxels: a
/// partial-volume image whose 0.5 contour follows the organ to sub-block
/// precision with factor² fewer triangles. One block of zero padding on every
/// side closes the surface at the volume border.
Ptr<vtkImageData> to_vtk(const MaskImage& mask, const MaskImage::RegionType& box, long factor) {
  const auto size = mask.GetLargestPossibleRegion().GetSize();
  const auto spacing = mask.GetSpacing();
  long blocks[3];
  auto image = Ptr<vtkImageData>::New();
  for (unsigned k = 0; k < 3; ++k) blocks[k] = (static_cast<long>(box.GetSize(k)) + factor - 1) / factor;
  image->SetDimensions(static_cast<int>(blocks[0] + 2), static_cast<int>(blocks[1] + 2),
                       static_cast<int>(blocks[2] + 2));
  image->SetSpacing(factor * spacing[0], factor * spacing[1], factor * spacing[2]);
  image->SetOrigin((box.GetIndex(0) - factor + 0.5 * (factor - 1)) * spacing[0],
                   (box.GetIndex(1) - factor + 0.5 * (factor - 1)) * spacing[1],
                   (box.GetIndex(2) - factor + 0.5 * (factor - 1)) * spacing[2]);
  image->AllocateScalars(VTK_FLOAT, 1);
  auto* out = static_cast<float*>(image->GetScalarPointer());
  std::fill(out, out + (blocks[0] + 2) * (blocks[1] + 2) * (blocks[2] + 2), 0.0f);
  const std::uint8_t* in = mask.GetBufferPointer();
  const float weight = 1.0f / static_cast<float>(factor * factor * factor);
  const long nx = static_cast<long>(size[0]), ny = static_cast<long>(size[1]);
  for (long k = 0; k < static_cast<long>(box.GetSize(2)); ++k)
    for (long j = 0; j < static_cast<long>(box.GetSize(1)); ++j)
      for (long i = 0; i < static_cast<long>(box.GetSize(0)); ++i)
        if (in[((box.GetIndex(2) + k) * ny + box.GetIndex(1) + j) * nx + box.GetIndex(0) + i])
          out[((k / factor + 1) * (blocks[1] + 2) + (j / factor + 1)) * (blocks[0] + 2) + (i / factor + 1)] += weight;
  return image;
}

/// The first edge that is not shared by exactly two consistently oriented
/// triangles, as a message; empty for a closed, oriented manifold.
std::string manifold_problem(const geometry::SurfaceMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const model::Triangle& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  for (const auto& [edge, count] : directed) {
    const auto opposite = directed.find({edge.second, edge.first});
    if (count != 1 || opposite == directed.end() || opposite->second != 1) {
      const model::Point3& p = mesh.vertices[edge.first];
      return fmt::format("edge {}-{} at ({:.1f}, {:.1f}, {:.1f}) mm {}", edge.first, edge.second, p[0] * 1e3,
                         p[1] * 1e3, p[2] * 1e3,
                         opposite == directed.end() ? "borders a hole" : "is shared by more than two triangles");
    }
  }
  return {};
}

/// The contour level between the values a block of factor³ voxels can take:
/// a level equal to a voxel value puts surface vertices on grid points, where
/// sheets of the surface touch and it stops being a manifold.
double contour_level(long factor) {
  const long voxels = factor * factor * factor;
  return voxels % 2 == 0 ? (voxels / 2 - 0.5) / static_cast<double>(voxels) : 0.5;
}

/// Signed volume and area of a VTK triangle surface (scaled index space, mm).
std::pair<double, double> volume_and_area(vtkPolyData* surface) {
  double volume = 0.0, area = 0.0;
  vtkCellArray* polys = surface->GetPolys();
  polys->InitTraversal();
  vtkIdType n = 0;
  const vtkIdType* ids = nullptr;
  while (polys->GetNextCell(n, ids)) {
    if (n != 3) continue;
    double a[3], b[3], c[3];
    surface->GetPoint(ids[0], a), surface->GetPoint(ids[1], b), surface->GetPoint(ids[2], c);
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double cross[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    volume += (a[0] * cross[0] + a[1] * cross[1] + a[2] * cross[2]) / 6.0;
    area += 0.5 * std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
  }
  return {volume, area};
}

/// Windowed-sinc smoothing (Taubin's low-pass filter without shrinkage) of a
/// closed triangle surface; the points move, the triangles stay.
Ptr<vtkPolyData> smoothed(vtkPolyData* surface, const SurfaceOptions& options) {
  auto smooth = Ptr<vtkWindowedSincPolyDataFilter>::New();
  smooth->SetInputData(surface);
  smooth->SetNumberOfIterations(options.smoothing_iterations);
  smooth->SetPassBand(options.smoothing_passband);
  smooth->NormalizeCoordinatesOn();
  smooth->BoundarySmoothingOff();
  smooth->FeatureEdgeSmoothingOff();
  smooth->NonManifoldSmoothingOn();
  smooth->Update();
  return smooth->GetOutput();
}

struct Contour {
  Ptr<vtkPolyData> surface;  ///< smoothed largest sheet, scaled index space (mm)
  double target_volume_mm3;  ///< the mask's volume within that sheet
};

/// Flying edges, windowed-sinc smoothing and the largest connected sheet (a
/// down-sampled thin bridge can part the organ into pieces; a model is one).
/// The contour of the block means is offset from the mask's boundary by a
/// fraction of a block (the level is not 0.5, and corners are cut), so the
/// target volume is the kept sheet's volume corrected by the offset that gives
/// all sheets together the mask's voxel volume.
Contour smoothed_contour(const MaskImage& mask, const MaskImage::RegionType& box, long factor,
                         const SurfaceOptions& options) {
  auto contour = Ptr<vtkFlyingEdges3D>::New();
  contour->SetInputData(to_vtk(mask, box, factor));
  contour->SetValue(0, contour_level(factor));
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  contour->ComputeScalarsOff();
  auto largest = Ptr<vtkPolyDataConnectivityFilter>::New();
  largest->SetInputConnection(contour->GetOutputPort());
  largest->SetExtractionModeToLargestRegion();
  auto clean = Ptr<vtkCleanPolyData>::New();  // drops the points of the other pieces
  clean->SetInputConnection(largest->GetOutputPort());
  clean->PointMergingOff();
  clean->Update();
  if (clean->GetOutput()->GetNumberOfCells() == 0) throw std::runtime_error("the segmentation is empty");

  const auto spacing = mask.GetSpacing();
  const double mask_volume_mm3 = static_cast<double>(count_voxels(mask)) * spacing[0] * spacing[1] * spacing[2];
  auto [all_volume, all_area] = volume_and_area(contour->GetOutput());
  auto [kept_volume, kept_area] = volume_and_area(clean->GetOutput());
  if (all_volume < 0.0) all_volume = -all_volume, kept_volume = -kept_volume;  // the axes' handedness
  const double bias_offset_mm = (mask_volume_mm3 - all_volume) / all_area;

  return {smoothed(clean->GetOutput(), options), kept_volume + bias_offset_mm * kept_area};
}

/// Quadric decimation to about `target_vertices`, then a gentle Laplacian
/// pass. Quadric decimation keeps what its error metric reads as ridges: on a
/// CT of thick slices the smoothed contour still ripples from slice to slice,
/// and decimating it leaves spikes (the DICOM sample, 2 mm slices: 77 vertices
/// whose angle deficit exceeds 45°, up to 214°; a tool pressed there meets a
/// cone's tip, a one-node contact for the FEM). The pass pulls each vertex a
/// tenth of the way to its neighbours' centroid, 20 times (the DICOM sample's
/// bake: 2 vertices above 45°, the larger a corner where the field of view
/// cuts a ridge). The windowed-sinc filter is not used here: on the
/// decimated surface's long strips (a cylinder's side) its low-pass slides
/// vertices along the strip and past the caps, into zero-volume fins 9 mm
/// long. The Laplacian pass's slight shrinkage is what the enclosed-volume
/// match after it corrects.
Ptr<vtkPolyData> decimated(vtkPolyData* surface, std::size_t target_vertices) {
  const auto points = static_cast<std::size_t>(surface->GetNumberOfPoints());
  if (points <= target_vertices) return surface;
  auto decimate = Ptr<vtkQuadricDecimation>::New();
  decimate->SetInputData(surface);
  decimate->SetTargetReduction(1.0 - static_cast<double>(target_vertices) / static_cast<double>(points));
  decimate->VolumePreservationOn();
  auto clean = Ptr<vtkCleanPolyData>::New();
  clean->SetInputConnection(decimate->GetOutputPort());
  auto triangles = Ptr<vtkTriangleFilter>::New();
  triangles->SetInputConnection(clean->GetOutputPort());
  auto despike = Ptr<vtkSmoothPolyDataFilter>::New();
  despike->SetInputConnection(triangles->GetOutputPort());
  despike->SetNumberOfIterations(kDespikeIterations);
  despike->SetRelaxationFactor(kDespikeRelaxation);
  despike->FeatureEdgeSmoothingOff();  // spikes are what it would call features
  despike->BoundarySmoothingOff();
  despike->Update();
  return despike->GetOutput();
}

/// VTK's scaled-index points into the patient frame (metres), outward triangles.
geometry::SurfaceMesh to_mesh(vtkPolyData* surface, const MaskImage& mask) {
  geometry::SurfaceMesh mesh;
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
      mesh.triangles.push_back(
          {static_cast<std::uint32_t>(ids[0]), static_cast<std::uint32_t>(ids[1]), static_cast<std::uint32_t>(ids[2])});
  // Flying edges' orientation depends on the image axes' handedness: make it outward.
  if (geometry::enclosed_volume(mesh.vertices, mesh.triangles) < 0)
    for (model::Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
  return mesh;
}

}  // namespace

geometry::SurfaceMesh extract_surface(const MaskImage& mask, const SurfaceOptions& options) {
  if (options.block_factor < 0 || options.block_factor > kLargestBlock)
    throw std::invalid_argument(fmt::format("the contouring block must be 1 to {} voxels, or 0 to choose it (got {})",
                                            kLargestBlock, options.block_factor));
  const MaskImage::RegionType box = organ_bounding_box(mask, {0, 0, 0});
  // Down-sample when full resolution would give far more vertices than the
  // target: decimation, not contouring, dominates the cost on fine CTs.
  const double faces = static_cast<double>(boundary_faces(mask, box));
  const double oversampling = faces / (kVerticesPerTarget * static_cast<double>(options.target_vertices));
  const long factor = options.block_factor > 0
                          ? options.block_factor
                          : std::clamp(static_cast<long>(std::ceil(std::sqrt(oversampling))), 1L, kLargestBlock);
  const Contour contour = smoothed_contour(mask, box, factor, options);

  // Quadric decimation can fold a thin part of the organ into edges shared by
  // four triangles: then decimate less, and at last not at all.
  std::string problem;
  for (const std::size_t target : {options.target_vertices, 2 * options.target_vertices, std::size_t{0}}) {
    geometry::SurfaceMesh mesh =
        to_mesh(target == 0 ? contour.surface.Get() : decimated(contour.surface, target).Get(), mask);
    problem = manifold_problem(mesh);
    if (problem.empty()) {
      match_enclosed_volume(mesh.vertices, mesh.triangles, contour.target_volume_mm3 * kCubicMetresPerCubicMillimetre);
      return mesh;
    }
  }
  throw std::runtime_error(fmt::format(
      "the extracted surface is not a closed, consistently oriented manifold even without decimation ({}); check the "
      "mask there (--intermediates) or clean it with --closing",
      problem));
}

std::vector<model::TexCoord> spherical_texture_coordinates(const std::vector<model::Point3>& vertices) {
  constexpr double kPi = 3.14159265358979323846;
  model::Point3 centre{0.0, 0.0, 0.0};
  for (const model::Point3& v : vertices)
    for (int k = 0; k < 3; ++k) centre[k] += v[k] / static_cast<double>(vertices.size());
  std::vector<model::TexCoord> coordinates;
  coordinates.reserve(vertices.size());
  for (const model::Point3& v : vertices) {
    const double x = v[0] - centre[0], y = v[1] - centre[1], z = v[2] - centre[2];
    const double r = std::sqrt(x * x + y * y + z * z);
    if (r == 0.0) {
      coordinates.push_back({0.5, 0.5});
      continue;
    }
    coordinates.push_back({0.5 + std::atan2(y, x) / (2.0 * kPi), std::acos(std::clamp(z / r, -1.0, 1.0)) / kPi});
  }
  return coordinates;
}

}  // namespace organsim::pipeline
