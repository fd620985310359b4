// ITK finds image readers and writers through IO factories. ITK_USE_FILE would
// register them with a generated header in every target of the directory; the
// pipeline registers the four formats it supports, once, before any image IO.
#pragma once

namespace organsim::pipeline {

/// Registers the DICOM (GDCM), MetaImage, NIfTI and NRRD image IO factories,
/// in that order (the order ITK's generated registration used). Thread-safe;
/// only the first call does anything.
void register_image_io_factories();

}  // namespace organsim::pipeline
