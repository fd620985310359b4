// Writing CT volumes and masks. The file type follows the extension:
// .nii/.nii.gz (NIfTI), .nrrd/.nhdr (NRRD), .mha/.mhd (MetaImage). Every file is
// written to a temporary name in the target directory and renamed into place.
#pragma once

#include <string>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

/// Throws std::runtime_error naming the path when the extension is not one of
/// the supported ones or the file cannot be written.
void write_ct_image(const CtImage& image, const std::string& path);
void write_mask_image(const MaskImage& image, const std::string& path);

/// What goes into the DICOM headers of a synthetic series; never a real patient.
struct DicomSeriesInfo {
  std::string patient_name = "PHANTOM^ORGANSIM";
  std::string patient_id = "ORGANSIM-PHANTOM";
  std::string series_description = "organsim synthetic abdominal CT";
  std::uint64_t uid_seed = 0;  ///< makes the study/series/instance UIDs deterministic
};

/// Writes one DICOM file per axial slice (CT image storage, 16-bit signed,
/// rescale 1/0) into `directory`, which is created when missing. Each slice
/// carries its own ImagePositionPatient, so readers can sort by position.
void write_dicom_series(const CtImage& image, const std::string& directory, const DicomSeriesInfo& info);

}  // namespace organsim::pipeline
