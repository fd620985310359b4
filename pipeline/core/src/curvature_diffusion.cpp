#include "organsim/pipeline/curvature_diffusion.h"

#include <itkCurvatureNDAnisotropicDiffusionFunction.h>
#include <itkMultiThreaderBase.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <thread>
#include <vector>

namespace organsim::pipeline {
namespace {

/// ITK's NeighborhoodInnerProduct of a float image with the first-order
/// DerivativeOperator (coefficients ½, 0, −½ as floats) over the three
/// samples before, at and after a voxel: products in double, summed in
/// double in that order, returned as a float.
inline float derivative(float before, float at, float after) {
  double sum = 0.0;
  sum += static_cast<double>(0.5f * static_cast<double>(before));
  sum += static_cast<double>(0.0f * static_cast<double>(at));
  sum += static_cast<double>(-0.5f * static_cast<double>(after));
  return static_cast<float>(sum);
}

/// Offsets in a voxel's 3×3×3 neighbourhood, x fastest: the centre is 13,
/// a step along axis a is kStride[a].
constexpr int kCentre = 13;
constexpr int kStride[3] = {1, 3, 9};

/// CurvatureNDAnisotropicDiffusionFunction::ComputeUpdate for a 3D float
/// image, from the voxel's neighbourhood `n` (its corners unused): the same
/// operations in the same order and precision. `k` is its m_K, `scale` its
/// m_ScaleCoefficients.
inline float update_from(const float (&n)[27], float k, const double (&scale)[3]) {
  constexpr double kMinNorm = 1.0e-10;  // CurvatureNDAnisotropicDiffusionFunction::m_MIN_NORM
  // The derivative along axis `along` at neighbourhood place `at` (ITK's x, xa and xd slices).
  const auto derivative_at = [&](int along, int at) {
    return derivative(n[at - kStride[along]], n[at], n[at + kStride[along]]);
  };
  const float centre = n[kCentre];
  double dx_forward[3], dx_backward[3], dx[3];
  for (int i = 0; i < 3; ++i) {
    dx_forward[i] = n[kCentre + kStride[i]] - centre;  // float arithmetic, as ITK's PixelType
    dx_forward[i] *= scale[i];
    dx_backward[i] = centre - n[kCentre - kStride[i]];
    dx_backward[i] *= scale[i];
    dx[i] = derivative_at(i, kCentre);
    dx[i] *= scale[i];
  }
  double speed = 0.0;
  for (int i = 0; i < 3; ++i) {
    double grad_mag_sq = dx_forward[i] * dx_forward[i];
    double grad_mag_sq_d = dx_backward[i] * dx_backward[i];
    for (int j = 0; j < 3; ++j) {
      if (j == i) continue;
      double dx_aug = derivative_at(j, kCentre + kStride[i]);
      dx_aug *= scale[j];
      double dx_dim = derivative_at(j, kCentre - kStride[i]);
      dx_dim *= scale[j];
      grad_mag_sq += 0.25f * (dx[j] + dx_aug) * (dx[j] + dx_aug);
      grad_mag_sq_d += 0.25f * (dx[j] + dx_dim) * (dx[j] + dx_dim);
    }
    const double grad_mag = std::sqrt(kMinNorm + grad_mag_sq);
    const double grad_mag_d = std::sqrt(kMinNorm + grad_mag_sq_d);
    double cx = 0.0, cxd = 0.0;
    if (k != 0.0) {
      cx = std::exp(grad_mag_sq / k);
      cxd = std::exp(grad_mag_sq_d / k);
    }
    const double dx_forward_cn = (dx_forward[i] / grad_mag) * cx;
    const double dx_backward_cn = (dx_backward[i] / grad_mag_d) * cxd;
    speed += (dx_forward_cn - dx_backward_cn);
  }
  double propagation_gradient = 0.0;
  const auto square = [](double x) { return x * x; };
  if (speed > 0) {
    for (int i = 0; i < 3; ++i)
      propagation_gradient += square(std::min(dx_backward[i], 0.0)) + square(std::max(dx_forward[i], 0.0));
  } else {
    for (int i = 0; i < 3; ++i)
      propagation_gradient += square(std::max(dx_backward[i], 0.0)) + square(std::min(dx_forward[i], 0.0));
  }
  return static_cast<float>(std::sqrt(propagation_gradient) * speed);
}

/// The updates of the slices [first, end) of `image` (size[0] × size[1] ×
/// size[2] voxels) into `update`.
void compute_updates(const float* image, const long (&size)[3], long first, long end, float k, const double (&scale)[3],
                     float* update) {
  const long row = size[0], slice = size[0] * size[1];
  float n[27] = {};
  for (long z = first; z < end; ++z)
    for (long y = 0; y < size[1]; ++y) {
      const bool inner_row = z > 0 && z + 1 < size[2] && y > 0 && y + 1 < size[1];
      for (long x = 0; x < size[0]; ++x) {
        const long v = (z * size[1] + y) * row + x;
        if (inner_row && x > 0 && x + 1 < size[0]) {
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx)
                n[kCentre + dz * 9 + dy * 3 + dx] = image[v + dz * slice + dy * row + dx];
        } else {
          // The volume's border: each coordinate clamped into the volume
          // (ITK's ZeroFluxNeumannBoundaryCondition).
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                const long cx = std::clamp(x + dx, 0L, size[0] - 1), cy = std::clamp(y + dy, 0L, size[1] - 1),
                           cz = std::clamp(z + dz, 0L, size[2] - 1);
                n[kCentre + dz * 9 + dy * 3 + dx] = image[(cz * size[1] + cy) * row + cx];
              }
        }
        update[v] = update_from(n, k, scale);
      }
    }
}

/// Runs work(first_slice, end_slice) on `threads` threads over the slices.
template <typename Work>
void over_slices(long slices, unsigned threads, Work work) {
  std::vector<std::thread> pool;
  const auto join = [&pool] {
    for (std::thread& thread : pool) thread.join();
  };
  try {
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work, slices * t / threads, slices * (t + 1) / threads);
  } catch (...) {  // no thread for the rest: those started finish first
    join();
    throw;
  }
  work(0L, slices / threads);
  join();
}

}  // namespace

FloatImage::Pointer curvature_diffusion(const FloatImage& image, const CurvatureDiffusionOptions& o) {
  const FloatImage::RegionType region = image.GetLargestPossibleRegion();
  auto output = FloatImage::New();
  output->CopyInformation(&image);
  output->SetRegions(region);
  output->Allocate();
  const std::size_t voxels = region.GetNumberOfPixels();
  std::memcpy(output->GetBufferPointer(), image.GetBufferPointer(), voxels * sizeof(float));
  if (o.iterations == 0) return output;

  long size[3];
  double scale[3];
  for (unsigned k = 0; k < 3; ++k) {
    size[k] = static_cast<long>(region.GetSize(k));
    scale[k] = 1.0 / static_cast<double>(image.GetSpacing()[k]);  // FiniteDifferenceImageFilter, UseImageSpacing
  }
  // ITK's own function for the conductance's scale (the mean squared
  // gradient magnitude), as AnisotropicDiffusionImageFilter calls it before
  // each iteration.
  using Function = itk::CurvatureNDAnisotropicDiffusionFunction<FloatImage>;
  auto function = Function::New();
  Function::PixelRealType coefficients[3] = {scale[0], scale[1], scale[2]};
  function->SetScaleCoefficients(coefficients);
  function->SetConductanceParameter(o.conductance);
  function->SetTimeStep(o.time_step);

  // As many threads as ITK's filters use (ITK_GLOBAL_DEFAULT_NUMBER_OF_THREADS).
  const unsigned threads =
      std::max(1u, o.threads > 0 ? o.threads : itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads());
  std::vector<float> update(voxels);
  float* values = output->GetBufferPointer();
  for (unsigned iteration = 0; iteration < o.iterations; ++iteration) {
    function->CalculateAverageGradientMagnitudeSquared(output);
    // CurvatureNDAnisotropicDiffusionFunction::InitializeIteration.
    const auto k =
        static_cast<float>(function->GetAverageGradientMagnitudeSquared() * function->GetConductanceParameter() *
                           function->GetConductanceParameter() * -2.0f);
    // Every update from the same image (DenseFiniteDifferenceImageFilter's
    // CalculateChange), then all applied (its ApplyUpdate).
    over_slices(size[2], threads,
                [&](long first, long end) { compute_updates(values, size, first, end, k, scale, update.data()); });
    const double dt = function->GetTimeStep();
    for (std::size_t v = 0; v < voxels; ++v) values[v] += static_cast<float>(update[v] * dt);
  }
  return output;
}

}  // namespace organsim::pipeline
