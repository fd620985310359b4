#include "organsim/pipeline/image_io.h"

#include <itkGDCMImageIO.h>
#include <itkImageFileWriter.h>
#include <itkImageSeriesWriter.h>
#include <itkMetaDataObject.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "itk_factories.h"
#include "organsim/io/atomic_file.h"

namespace organsim::pipeline {
namespace {

namespace fs = std::filesystem;

const char* const kWritableExtensions[] = {".nii.gz", ".nii", ".nrrd", ".mha"};

std::string image_extension(const std::string& path) {
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* extension : kWritableExtensions) {
    const std::size_t n = std::strlen(extension);
    if (lower.size() > n && lower.compare(lower.size() - n, n, extension) == 0) return path.substr(path.size() - n);
  }
  throw std::runtime_error("cannot write '" + path + "': unsupported extension; use .nii.gz, .nii, .nrrd or .mha");
}

template <typename ImageType>
void write_image(const ImageType& image, const std::string& path) {
  register_image_io_factories();
  io::AtomicFile output(path, image_extension(path));
  auto writer = itk::ImageFileWriter<ImageType>::New();
  writer->SetInput(&image);
  writer->SetFileName(output.temp_path());
  writer->UseCompressionOn();
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw std::runtime_error("cannot write '" + path + "': " + e.GetDescription());
  }
  output.commit();
}

/// A DICOM UID under the 2.25 (UUID-derived) root, deterministic in `seed` and `item`.
std::string make_uid(std::uint64_t seed, std::uint64_t item) {
  std::uint64_t h = seed * 0x9E3779B97F4A7C15ull ^ (item + 0x632BE59BD9B4E019ull);
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 27;
  return fmt::format("2.25.{}{:06d}", h, item % 1000000);
}

}  // namespace

void write_ct_image(const CtImage& image, const std::string& path) { write_image(image, path); }
void write_mask_image(const MaskImage& image, const std::string& path) { write_image(image, path); }

void write_dicom_series(const CtImage& image, const std::string& directory, const DicomSeriesInfo& info) {
  io::AtomicDirectory output(directory);
  const fs::path temp(output.temp_path());

  using SliceType = itk::Image<std::int16_t, 2>;
  const auto region = image.GetLargestPossibleRegion();
  const unsigned slices = region.GetSize(2);
  const auto spacing = image.GetSpacing();
  const auto direction = image.GetDirection();
  const std::string study_uid = make_uid(info.uid_seed, 1000001);
  const std::string series_uid = make_uid(info.uid_seed, 1000002);
  const std::string frame_uid = make_uid(info.uid_seed, 1000003);

  auto io = itk::GDCMImageIO::New();
  io->KeepOriginalUIDOn();
  std::vector<itk::MetaDataDictionary> dictionaries(slices);
  std::vector<itk::MetaDataDictionary*> dictionary_pointers;
  std::vector<std::string> file_names;
  for (unsigned s = 0; s < slices; ++s) {
    itk::MetaDataDictionary& d = dictionaries[s];
    auto set = [&d](const char* tag, const std::string& value) {
      itk::EncapsulateMetaData<std::string>(d, tag, value);
    };
    CtImage::IndexType index{{0, 0, static_cast<itk::IndexValueType>(s)}};
    CtImage::PointType position;
    image.TransformIndexToPhysicalPoint(index, position);
    set("0008|0016", "1.2.840.10008.5.1.4.1.1.2");  // CT Image Storage
    set("0008|0018", make_uid(info.uid_seed, s));
    set("0008|0060", "CT");
    set("0028|0004", "MONOCHROME2");
    set("0008|0020", "20000101");
    set("0008|0030", "000000");
    set("0008|103e", info.series_description);
    set("0010|0010", info.patient_name);
    set("0010|0020", info.patient_id);
    set("0020|000d", study_uid);
    set("0020|000e", series_uid);
    set("0020|0052", frame_uid);
    set("0020|0011", "1");
    set("0020|0013", std::to_string(s + 1));
    set("0020|0032", fmt::format("{:.6f}\\{:.6f}\\{:.6f}", position[0], position[1], position[2]));
    set("0020|0037", fmt::format("{:.6f}\\{:.6f}\\{:.6f}\\{:.6f}\\{:.6f}\\{:.6f}", direction[0][0], direction[1][0],
                                 direction[2][0], direction[0][1], direction[1][1], direction[2][1]));
    set("0028|0030", fmt::format("{:.6f}\\{:.6f}", spacing[1], spacing[0]));
    set("0018|0050", fmt::format("{:.6f}", spacing[2]));
    set("0028|1052", "0");
    set("0028|1053", "1");
    dictionary_pointers.push_back(&d);
    file_names.push_back((temp / fmt::format("slice{:04d}.dcm", s + 1)).string());
  }
  auto writer = itk::ImageSeriesWriter<CtImage, SliceType>::New();
  writer->SetInput(&image);
  writer->SetImageIO(io);
  writer->SetFileNames(file_names);
  writer->SetMetaDataDictionaryArray(&dictionary_pointers);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw std::runtime_error("cannot write the DICOM series to '" + directory + "': " + e.GetDescription());
  }
  output.commit();
}

}  // namespace organsim::pipeline
