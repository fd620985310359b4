// Edge-preserving smoothing for the seeded segmentation: Whitaker and Xue's
// modified curvature diffusion, as ITK's CurvatureAnisotropicDiffusionImageFilter
// computes it, to the bit, in about half its time.
//
// ITK's filter spends most of its time in its general machinery (a
// neighbourhood iterator and an inner-product object per derivative, nine
// derivatives a voxel), not in the arithmetic. Here each voxel reads its
// eighteen face and edge neighbours directly (the volume's border clamped,
// as ITK's zero-flux Neumann condition does) and does ITK's operations in
// ITK's order and precision, so a bake's model file stays byte-identical to
// one smoothed by ITK in a portable build (tests/pipeline/core/
// curvature_diffusion_test.cpp compares every voxel's bits). The conductance's scale, a serial sum over
// the image whose order fixes its last bit, is ITK's own function.
#pragma once

#include <itkImage.h>

namespace organsim::pipeline {

using FloatImage = itk::Image<float, 3>;

struct CurvatureDiffusionOptions {
  unsigned iterations = 5;
  double time_step = 0.0625;  ///< ITK's TimeStep (the stability limit in 3D is spacing / 16)
  double conductance = 1.0;   ///< ITK's ConductanceParameter
  unsigned threads = 0;       ///< 0: as many as ITK's filters use; the result does not depend on it
};

/// `image` smoothed: the image ITK's CurvatureAnisotropicDiffusionImageFilter
/// returns with these options and the image's spacing (UseImageSpacing on).
FloatImage::Pointer curvature_diffusion(const FloatImage& image, const CurvatureDiffusionOptions& options);

}  // namespace organsim::pipeline
