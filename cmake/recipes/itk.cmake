# ITK 5.2 (Debian libinsighttoolkit5-dev): image IO (DICOM through GDCM, NIfTI,
# NRRD, MetaImage) and the segmentation filters. Consumed through the
# interface target `organsim_itk` rather than ITK_USE_FILE, which would add ITK's
# include directories and definitions to every target of the directory. The IO
# factories are registered in code (pipeline/core/src/itk_factories.cpp).
find_package(ITK 5.2 REQUIRED COMPONENTS
  ITKCommon ITKIOImageBase ITKIONIFTI ITKIONRRD ITKIOMeta ITKIOGDCM ITKImageGrid ITKImageIntensity
  ITKThresholding ITKRegionGrowing ITKBinaryMathematicalMorphology ITKMathematicalMorphology
  ITKConnectedComponents ITKLabelMap ITKDistanceMap ITKImageStatistics ITKAnisotropicSmoothing ITKImageGradient
  ITKWatersheds ITKImageFunction)
add_library(organsim_itk INTERFACE)
target_include_directories(organsim_itk SYSTEM INTERFACE ${ITK_INCLUDE_DIRS})
target_link_libraries(organsim_itk INTERFACE ${ITK_LIBRARIES})
