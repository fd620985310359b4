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

/// The memory a job on a CT holds at its peak: `bytes_per_voxel` for every
/// voxel the CT's header announces (the CT and what is derived from it) and
/// `fixed_bytes` whatever its size. Checked against the memory the machine
/// has available before a voxel is read, so that a CT too large for the
/// machine is refused in one line instead of being killed halfway.
struct MemoryNeed {
  double bytes_per_voxel = 2.0;  ///< the CT itself, 16-bit
  double fixed_bytes = 0.0;
  std::string job = "reading it";  ///< for the message: "baking it needs about …"
};

/// The memory the machine can give a new job now (/proc/meminfo's
/// MemAvailable), bytes; 0 when it cannot be read (then nothing is refused).
double available_memory_bytes();

/// Reads a CT. A directory is read as a DICOM series, sorted by slice position
/// (never by file name); when it holds several series, `series_uid` must name
/// one, otherwise the error lists them. Refuses 2-D images, and a CT whose
/// header announces more voxels than `need` leaves room for in the available
/// memory (the message says how much it needs and how much there is).
CtImage::Pointer read_ct(const std::string& path, const std::string& series_uid = "", const MemoryNeed& need = {});

/// Reads a label map (as exported by 3D Slicer or TotalSegmentator) and returns
/// the mask of `label_value`. Refuses a grid that does not match `reference`
/// (size, spacing, origin, direction within 1e-3 mm / 1e-4) and a label value
/// that does not occur, or a label map too large for the available memory.
MaskImage::Pointer read_label_mask(const std::string& path, int label_value, const CtImage& reference);

}  // namespace organsim::pipeline
