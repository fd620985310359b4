// `organsim phantom -o CT [--mask MASK] [--dicom DIR] [--seed N] [--size ...] [--spacing ...]`
#include <fmt/format.h>

#include "command_line/command_line.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/phantom.h"

namespace organsim::cli {
namespace {

struct PhantomCommandOptions {
  std::string ct_path;
  std::string mask_path;
  std::string dicom_directory;
  pipeline::PhantomOptions phantom;
  std::vector<unsigned> size{128, 104, 64};
  std::vector<double> spacing{3.0, 3.0, 3.0};
};

int run_phantom(PhantomCommandOptions& o) {
  for (int k = 0; k < 3; ++k) {
    o.phantom.size[k] = o.size[k];
    o.phantom.spacing_mm[k] = o.spacing[k];
  }
  const pipeline::Phantom phantom = pipeline::make_phantom(o.phantom);
  pipeline::write_ct_image(*phantom.ct, o.ct_path);
  if (!o.mask_path.empty()) pipeline::write_mask_image(*phantom.liver_mask, o.mask_path);
  if (!o.dicom_directory.empty()) {
    pipeline::DicomSeriesInfo info;
    info.uid_seed = o.phantom.seed;
    pipeline::write_dicom_series(*phantom.ct, o.dicom_directory, info);
  }
  const auto& p = o.phantom;
  fmt::print("phantom CT      {} ({}x{}x{} voxels, {}x{}x{} mm, seed {})\n", o.ct_path, p.size[0], p.size[1], p.size[2],
             p.spacing_mm[0], p.spacing_mm[1], p.spacing_mm[2], p.seed);
  if (!o.mask_path.empty()) fmt::print("liver mask      {}\n", o.mask_path);
  if (!o.dicom_directory.empty()) fmt::print("DICOM series    {}/ ({} slices)\n", o.dicom_directory, p.size[2]);
  fmt::print("liver volume    {:.1f} mL\n", phantom.liver_volume_ml);
  fmt::print("fixed point     {:.2f},{:.2f},{:.2f} mm (LPS; portal vein entry into the liver)\n",
             phantom.fixed_point_mm[0], phantom.fixed_point_mm[1], phantom.fixed_point_mm[2]);
  return 0;
}

}  // namespace

Command add_phantom_command(CLI::App& app) {
  auto o = std::make_shared<PhantomCommandOptions>();
  app.add_option("-o,--output", o->ct_path, "CT image to write (.nii.gz, .nii, .nrrd or .mha)")->required();
  app.add_option("--mask", o->mask_path, "Also write the ground-truth liver mask (same formats)");
  app.add_option("--dicom", o->dicom_directory, "Also write the CT as a DICOM series into this new directory");
  app.add_option("--seed", o->phantom.seed, "Noise seed (same seed, same image)")->capture_default_str();
  app.add_option("--size", o->size, "Voxels NX,NY,NZ")->delimiter(',')->expected(3)->capture_default_str();
  app.add_option("--spacing", o->spacing, "Voxel size SX,SY,SZ in mm")
      ->delimiter(',')
      ->expected(3)
      ->capture_default_str();
  app.add_option("--noise", o->phantom.noise_sigma_hu, "Noise standard deviation, HU")->capture_default_str();
  return [o] { return run_phantom(*o); };
}

}  // namespace organsim::cli
