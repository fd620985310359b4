// The image types of the pipeline: CT volumes in Hounsfield units and binary
// label masks, both in ITK physical space (LPS, millimetres).
#pragma once

#include <itkImage.h>

#include <cstdint>

namespace organsim::pipeline {

using CtImage = itk::Image<std::int16_t, 3>;    ///< Hounsfield units
using MaskImage = itk::Image<std::uint8_t, 3>;  ///< 1 inside the organ, 0 outside

}  // namespace organsim::pipeline
