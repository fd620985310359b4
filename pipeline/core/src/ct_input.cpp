#include "organsim/pipeline/ct_input.h"

#include <itkBinaryThresholdImageFilter.h>
#include <itkGDCMImageIO.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkImageFileReader.h>
#include <itkImageIOFactory.h>
#include <itkImageSeriesReader.h>
#include <itkNearestNeighborInterpolateImageFunction.h>
#include <itkResampleImageFilter.h>

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>
#include <filesystem>
#include <fstream>
#include <future>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include "itk_factories.h"

namespace organsim::pipeline {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
  throw std::runtime_error("'" + path + "': " + problem);
}

/// A label map held as int (4 bytes), resampled onto the CT's grid when a
/// converter flipped an axis (4 more), and the organ's mask (1).
constexpr double kLabelBytesPerVoxel = 9.0;

void check_input_path(const std::string& path) {
  std::error_code error;
  if (!fs::exists(path, error)) fail(path, "no such file or directory; check the path");
}

/// ITK's descriptions can span lines; the first line says what went wrong.
std::string first_line(const char* text) {
  std::string s(text ? text : "");
  const auto newline = s.find('\n');
  return newline == std::string::npos ? s : s.substr(0, newline);
}

void check_three_dimensional(const std::string& path, const itk::ImageBase<3>& image) {
  const auto size = image.GetLargestPossibleRegion().GetSize();
  if (size[0] < 2 || size[1] < 2 || size[2] < 2)
    fail(path, fmt::format("is a {}x{}x{} image, not a 3-D volume; pass a CT volume or a DICOM series directory",
                           size[0], size[1], size[2]));
}

/// Refuses a grid of `voxels` whose job would not fit in the available memory.
/// `file_bytes_per_voxel`: the buffer the reader fills in the file's own
/// pixel type when it must convert (a float64 or multi-channel file's) or
/// reads more than one volume, held beside the image kept.
void check_fits_in_memory(const std::string& path, const std::array<std::uint64_t, 3>& size, const MemoryNeed& need,
                          double file_bytes_per_voxel = 0.0) {
  const double available = available_memory_bytes();
  const double voxels = static_cast<double>(size[0]) * static_cast<double>(size[1]) * static_cast<double>(size[2]);
  const double needed = voxels * (need.bytes_per_voxel + file_bytes_per_voxel) + need.fixed_bytes;
  if (available <= 0.0 || needed <= available) return;
  constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
  fail(path, fmt::format("is {}x{}x{} voxels; {} needs about {:.1f} GiB of memory and this machine has {:.1f} GiB "
                         "available; crop the CT to the organ's region or resample it to a coarser grid first",
                         size[0], size[1], size[2], need.job, needed / kGiB, available / kGiB));
}

/// The image's number of dimensions, its header read and its size checked
/// against the memory `need` asks for, read into pixels of `pixel_bytes`.
int image_dimensions(const std::string& path, const MemoryNeed& need, std::size_t pixel_bytes) {
  register_image_io_factories();
  auto io = itk::ImageIOFactory::CreateImageIO(path.c_str(), itk::CommonEnums::IOFileMode::ReadMode);
  if (!io)
    fail(path,
         "is not an image ITK can read; pass a DICOM series directory, NIfTI (.nii, .nii.gz), NRRD or "
         "MetaImage (.mha, .mhd) file");
  try {
    io->SetFileName(path);
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    fail(path, "cannot read the image header (" + first_line(e.GetDescription()) + "); the file may be truncated");
  }
  const unsigned dimensions = io->GetNumberOfDimensions();
  std::array<std::uint64_t, 3> size{1, 1, 1};
  for (unsigned k = 0; k < std::min(dimensions, 3u); ++k) size[k] = io->GetDimensions(k);
  double volumes = 1.0;  // a 4-D file is read whole before its first volume is kept
  for (unsigned k = 3; k < dimensions; ++k) volumes *= static_cast<double>(io->GetDimensions(k));
  const std::size_t file_bytes = io->GetComponentSize() * io->GetNumberOfComponents();
  const double file_buffer =
      volumes > 1.0 || file_bytes != pixel_bytes ? static_cast<double>(file_bytes) * volumes : 0.0;
  check_fits_in_memory(path, size, need, file_buffer);
  return static_cast<int>(dimensions);
}

/// ITK reads a truncated gzip stream without complaint (the missing voxels
/// come back as zeros), so a gzip-compressed input is also inflated to its
/// end here, beside the reader (read_volume_file).
void check_gzip_stream_complete(const std::string& path) {
  if (path.size() < 3 || path.compare(path.size() - 3, 3, ".gz") != 0) return;
  gzFile file = ::gzopen(path.c_str(), "rb");
  if (!file) fail(path, "cannot be opened; check the path and permissions");
  std::vector<char> buffer(1 << 20);
  int n = 0;
  while ((n = ::gzread(file, buffer.data(), static_cast<unsigned>(buffer.size()))) > 0) {
  }
  // A stream cut short ends with Z_BUF_ERROR ("unexpected end of file").
  int error = Z_OK;
  const std::string message = ::gzerror(file, &error);
  ::gzclose(file);
  if (n < 0 || error != Z_OK)
    fail(path, "is damaged (" + message + "); the file is probably truncated: copy or export it again");
}

template <typename Image>
typename Image::Pointer read_volume_file(const std::string& path, const MemoryNeed& need) {
  register_image_io_factories();
  // The header first: a file announcing more than the machine holds is refused
  // before a byte of a (possibly huge) compressed stream is inflated.
  if (image_dimensions(path, need, sizeof(typename Image::PixelType)) < 3)
    fail(path, "is a 2-D image, not a 3-D volume; pass a CT volume or a DICOM series directory");
  // A compressed stream is inflated twice: once to check that it is whole
  // (the reader would fill a truncated one's missing voxels silently), once
  // by the reader. The two run side by side; a damaged stream's message wins,
  // as it says what to do.
  std::future<void> complete = std::async(std::launch::async, [&path] { check_gzip_stream_complete(path); });
  auto reader = itk::ImageFileReader<Image>::New();
  reader->SetFileName(path);
  std::optional<std::string> read_error;
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    read_error = first_line(e.GetDescription());
  }
  complete.get();
  if (read_error) fail(path, "cannot read the voxels (" + *read_error + "); the file may be truncated");
  typename Image::Pointer image = reader->GetOutput();
  check_three_dimensional(path, *image);
  return image;
}

/// Same size, spacing, origin and direction (within 1e-3 mm and 1e-4).
template <typename A, typename B>
bool same_grid(const A& a, const B& b) {
  if (a.GetLargestPossibleRegion().GetSize() != b.GetLargestPossibleRegion().GetSize()) return false;
  for (unsigned k = 0; k < 3; ++k) {
    if (std::abs(a.GetSpacing()[k] - b.GetSpacing()[k]) >= 1e-3) return false;
    if (std::abs(a.GetOrigin()[k] - b.GetOrigin()[k]) >= 1e-3) return false;
    for (unsigned j = 0; j < 3; ++j)
      if (std::abs(a.GetDirection()[k][j] - b.GetDirection()[k][j]) >= 1e-4) return false;
  }
  return true;
}

/// Whether every voxel centre of `reference` is a voxel centre of `labels` and
/// the two have as many voxels: the same lattice, in another axis order.
template <typename A, typename B>
bool same_lattice(const A& labels, const B& reference) {
  if (labels.GetLargestPossibleRegion().GetNumberOfPixels() != reference.GetLargestPossibleRegion().GetNumberOfPixels())
    return false;
  const auto size = reference.GetLargestPossibleRegion().GetSize();
  const auto label_size = labels.GetLargestPossibleRegion().GetSize();
  // The index map is affine: the origin, the three unit steps and the eight
  // corners landing on in-range integer indices settle it.
  std::vector<std::array<long, 3>> probes = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int corner = 0; corner < 8; ++corner)
    probes.push_back({corner & 1 ? static_cast<long>(size[0]) - 1 : 0, corner & 2 ? static_cast<long>(size[1]) - 1 : 0,
                      corner & 4 ? static_cast<long>(size[2]) - 1 : 0});
  for (const auto& probe : probes) {
    typename B::IndexType index;
    for (unsigned k = 0; k < 3; ++k) index[k] = probe[k];
    typename B::PointType point;
    reference.TransformIndexToPhysicalPoint(index, point);
    itk::ContinuousIndex<double, 3> at;
    labels.TransformPhysicalPointToContinuousIndex(point, at);
    for (unsigned k = 0; k < 3; ++k)
      if (std::abs(at[k] - std::round(at[k])) > 1e-3 || std::round(at[k]) < 0 ||
          std::round(at[k]) > static_cast<double>(label_size[k]) - 1)
        return false;
  }
  return true;
}

}  // namespace

std::vector<DicomSeriesSummary> list_dicom_series(const std::string& directory) {
  auto names = itk::GDCMSeriesFileNames::New();
  names->SetUseSeriesDetails(false);
  names->SetDirectory(directory);
  std::vector<DicomSeriesSummary> series;
  for (const std::string& uid : names->GetSeriesUIDs()) {
    DicomSeriesSummary s;
    s.uid = uid;
    const auto files = names->GetFileNames(uid);
    s.files = files.size();
    if (!files.empty()) {
      auto io = itk::GDCMImageIO::New();
      io->SetFileName(files.front());
      try {
        io->ReadImageInformation();
        io->GetValueFromTag("0008|103e", s.description);
      } catch (const itk::ExceptionObject&) {
        // A series without a readable description is still listed by its UID.
      }
      while (!s.description.empty() && s.description.back() == ' ') s.description.pop_back();
    }
    series.push_back(s);
  }
  return series;
}

double available_memory_bytes() {
  double available = 0.0;
  std::ifstream meminfo("/proc/meminfo");
  std::string key, unit;
  double kib = 0.0;
  while (meminfo >> key >> kib >> unit)
    if (key == "MemAvailable:") available = kib * 1024.0;
  // In a container the cgroup's limit is the one that kills (cgroup v2; "max": none).
  double limit = 0.0, current = 0.0;
  if ((std::ifstream("/sys/fs/cgroup/memory.max") >> limit) &&
      (std::ifstream("/sys/fs/cgroup/memory.current") >> current))
    available = available > 0.0 ? std::min(available, std::max(0.0, limit - current)) : std::max(0.0, limit - current);
  return available;
}

CtImage::Pointer read_ct(const std::string& path, const std::string& series_uid, const MemoryNeed& need) {
  check_input_path(path);
  if (!fs::is_directory(path)) return read_volume_file<CtImage>(path, need);

  const auto series = list_dicom_series(path);
  if (series.empty()) fail(path, "holds no DICOM series; pass a directory of DICOM files or a volume file");
  std::string chosen = series_uid;
  if (chosen.empty()) {
    if (series.size() > 1) {
      std::string list;
      for (const auto& s : series)
        list += fmt::format("{}{} ({} files{})", list.empty() ? "" : ", ", s.uid, s.files,
                            s.description.empty() ? "" : ", \"" + s.description + "\"");
      fail(path, fmt::format("holds {} DICOM series; choose one with --series UID: {}", series.size(), list));
    }
    chosen = series.front().uid;
  }
  auto names = itk::GDCMSeriesFileNames::New();
  names->SetUseSeriesDetails(false);
  names->SetDirectory(path);
  // GDCM sorts the files of a series by their position along the slice normal.
  const auto files = names->GetFileNames(chosen);
  if (files.empty()) fail(path, "holds no DICOM series with UID " + chosen + "; list them by omitting --series");
  if (files.size() < 2) fail(path, "the series has a single slice, not a 3-D volume");
  {
    auto first = itk::GDCMImageIO::New();
    first->SetFileName(files.front());
    try {
      first->ReadImageInformation();
    } catch (const itk::ExceptionObject& e) {
      fail(path, "cannot read the DICOM series (" + first_line(e.GetDescription()) + ")");
    }
    const std::uint64_t frames = first->GetNumberOfDimensions() > 2 ? first->GetDimensions(2) : 1;  // multi-frame files
    check_fits_in_memory(path, {first->GetDimensions(0), first->GetDimensions(1), files.size() * frames}, need);
  }
  auto reader = itk::ImageSeriesReader<CtImage>::New();
  reader->SetImageIO(itk::GDCMImageIO::New());
  reader->SetFileNames(files);
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    fail(path, "cannot read the DICOM series (" + first_line(e.GetDescription()) + ")");
  }
  CtImage::Pointer image = reader->GetOutput();
  // Keep only the geometry: the series' metadata (patient tags) stays behind.
  image->SetMetaDataDictionary(itk::MetaDataDictionary());
  check_three_dimensional(path, *image);
  return image;
}

MaskImage::Pointer read_label_mask(const std::string& path, int label_value, const CtImage& reference) {
  check_input_path(path);
  using LabelImage = itk::Image<int, 3>;
  LabelImage::Pointer labels =
      fs::is_directory(path) ? nullptr
                             : read_volume_file<LabelImage>(
                                   path, {kLabelBytesPerVoxel, 0.0, "reading it as a label map (onto the CT's grid)"});
  if (!labels) fail(path, "is a directory; pass the label map as one NIfTI, NRRD or MetaImage file");

  const auto size = labels->GetLargestPossibleRegion().GetSize();
  const auto reference_size = reference.GetLargestPossibleRegion().GetSize();
  if (!same_grid(*labels, reference)) {
    // Converters (dcm2niix, for one) may store the same voxels with an axis
    // flipped or permuted: then the label map is re-ordered onto the CT's grid,
    // exactly (nearest neighbour on a shared lattice). Anything else is an error.
    if (!same_lattice(*labels, reference))
      fail(path, fmt::format("the label map's grid ({}x{}x{} voxels) does not match the CT's ({}x{}x{} voxels, with "
                             "spacing, origin and direction); resample it onto the CT grid first",
                             size[0], size[1], size[2], reference_size[0], reference_size[1], reference_size[2]));
    auto resample = itk::ResampleImageFilter<LabelImage, LabelImage>::New();
    resample->SetInput(labels);
    resample->SetInterpolator(itk::NearestNeighborInterpolateImageFunction<LabelImage>::New());
    resample->SetSize(reference_size);
    resample->SetOutputOrigin(reference.GetOrigin());
    resample->SetOutputSpacing(reference.GetSpacing());
    resample->SetOutputDirection(reference.GetDirection());
    resample->SetOutputStartIndex(reference.GetLargestPossibleRegion().GetIndex());
    resample->SetDefaultPixelValue(0);
    resample->Update();
    labels = resample->GetOutput();
  }

  auto threshold = itk::BinaryThresholdImageFilter<LabelImage, MaskImage>::New();
  threshold->SetInput(labels);
  threshold->SetLowerThreshold(label_value);
  threshold->SetUpperThreshold(label_value);
  threshold->SetInsideValue(1);
  threshold->SetOutsideValue(0);
  threshold->Update();
  MaskImage::Pointer mask = threshold->GetOutput();
  const std::uint8_t* voxels = mask->GetBufferPointer();
  const std::size_t count = mask->GetLargestPossibleRegion().GetNumberOfPixels();
  if (std::find(voxels, voxels + count, 1) == voxels + count)
    fail(path, fmt::format("no voxel has label value {}; check --label-value", label_value));
  // Geometry is the CT's (equal within tolerance): downstream stages use one grid.
  mask->CopyInformation(&reference);
  return mask;
}

}  // namespace organsim::pipeline
