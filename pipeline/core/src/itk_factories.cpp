#include "itk_factories.h"

#include <itkGDCMImageIOFactory.h>
#include <itkMetaImageIOFactory.h>
#include <itkNiftiImageIOFactory.h>
#include <itkNrrdImageIOFactory.h>

#include <mutex>

namespace organsim::pipeline {

void register_image_io_factories() {
  static std::once_flag once;
  std::call_once(once, [] {
    itk::GDCMImageIOFactory::RegisterOneFactory();
    itk::MetaImageIOFactory::RegisterOneFactory();
    itk::NiftiImageIOFactory::RegisterOneFactory();
    itk::NrrdImageIOFactory::RegisterOneFactory();
  });
}

}  // namespace organsim::pipeline
