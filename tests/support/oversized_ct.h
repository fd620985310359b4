// CT files whose header announces far more voxels than any machine holds, for
// the tests of the up-front memory refusal: a real small NIfTI-1 file with its
// grid patched, written as it is or gzip-compressed (a stream that would
// inflate past the memory if its header were believed).
#pragma once

#include <string>

namespace organsim::testing {

/// Copies the uncompressed NIfTI-1 file `small_nii` to `out_path` with its
/// grid set to edge × edge × edge voxels (edge ≤ 32767), gzip-compressed when
/// `out_path` ends in ".gz". The voxels stay the small file's few.
void write_oversized_nifti(const std::string& small_nii, const std::string& out_path, int edge);

}  // namespace organsim::testing
