#include "oversized_ct.h"

#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <vector>

namespace organsim::testing {

void write_oversized_nifti(const std::string& small_nii, const std::string& out_path, int edge) {
  std::ifstream in(small_nii, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < 348 || edge < 1 || edge > 32767)
    throw std::invalid_argument("write_oversized_nifti: needs a NIfTI-1 file and an edge of 1 to 32767");
  // NIfTI-1: dim[1..3] are little-endian int16 at bytes 42, 44 and 46.
  for (const int offset : {42, 44, 46}) {
    bytes[offset] = static_cast<char>(edge & 0xff);
    bytes[offset + 1] = static_cast<char>(edge >> 8);
  }
  if (out_path.size() > 3 && out_path.compare(out_path.size() - 3, 3, ".gz") == 0) {
    gzFile gz = ::gzopen(out_path.c_str(), "wb");
    if (!gz || ::gzwrite(gz, bytes.data(), static_cast<unsigned>(bytes.size())) != static_cast<int>(bytes.size()) ||
        ::gzclose(gz) != Z_OK)
      throw std::runtime_error("write_oversized_nifti: cannot write " + out_path);
    return;
  }
  std::ofstream(out_path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace organsim::testing
