// The only identification of the input CT that a model file keeps: a hash of
// its grid and voxels, never a file name or a DICOM tag.
#pragma once

#include <string>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

/// SHA-256 (lowercase hex) of a CT's grid (size, spacing, origin, direction as
/// little-endian u64/f64) followed by its voxels (little-endian int16).
std::string image_sha256(const CtImage& ct);

}  // namespace organsim::pipeline
