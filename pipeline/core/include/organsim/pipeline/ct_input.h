// Stage 1 of the pipeline: reading a CT (a DICOM series directory, NIfTI, NRRD,
// MHA/MHD) in ITK physical space (LPS, millimetres), keeping spacing, origin and
// direction. Errors are std::runtime_error with one line saying what is wrong
// and what to do; no patient-identifying DICOM tag ever appears in them.
#pragma once

#include <string>
#include <vector>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

struct DicomSeriesSummary {
  std::string uid;
  std::string description;  ///< SeriesDescription (0008,103E), may be empty
  std::size_t files = 0;
};

/// The DICOM series in `directory` (not recursive), in a stable order.
std::vector<DicomSeriesSummary> list_dicom_series(const std::string& directory);

/// Reads a CT. A directory is read as a DICOM series, sorted by slice position
/// (never by file name); when it holds several series, `series_uid` must name
/// one, otherwise the error lists them. Refuses 2-D images.
CtImage::Pointer read_ct(const std::string& path, const std::string& series_uid = "");

/// Reads a label map (as exported by 3D Slicer or TotalSegmentator) and returns
/// the mask of `label_value`. Refuses a grid that does not match `reference`
/// (size, spacing, origin, direction within 1e-3 mm / 1e-4) and a label value
/// that does not occur.
MaskImage::Pointer read_label_mask(const std::string& path, int label_value, const CtImage& reference);

}  // namespace organsim::pipeline
