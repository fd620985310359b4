# `cmake --install`: the organsim program, the runtime libraries with their
# public headers, an exported CMake package (find_package(organsim)) and a
# pkg-config file for the runtime. docs/install.md shows how to use them.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(ORGANSIM_INSTALLED_LIBRARIES
  organsim_io organsim_model_file organsim_lockfree organsim_devices organsim_fem organsim_geometry
  organsim_vertex_kernels organsim_organ organsim_multibeam organsim_springs organsim_organ_fem organsim_realtime
  organsim_runtime organsim_openhaptics)
if(TARGET organsim_fem_direct)
  list(APPEND ORGANSIM_INSTALLED_LIBRARIES organsim_fem_direct)
endif()
foreach(library IN LISTS ORGANSIM_INSTALLED_LIBRARIES)
  string(REPLACE "organsim_" "" export_name ${library})
  set_target_properties(${library} PROPERTIES EXPORT_NAME ${export_name})
  target_include_directories(${library} INTERFACE $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
endforeach()

install(TARGETS ${ORGANSIM_INSTALLED_LIBRARIES} EXPORT organsimTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development)
foreach(headers runtime/io/include runtime/model_file/include runtime/lockfree/include runtime/devices/include
                runtime/fem/include runtime/geometry/include runtime/vertex_kernels/include runtime/organ/include
                runtime/multibeam/include runtime/springs/include runtime/organ_fem/include runtime/realtime/include
                runtime/openhaptics/include runtime/direct/include cmake/forwarding_headers)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${headers}/organsim DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
    COMPONENT development FILES_MATCHING PATTERN "*.h")
endforeach()

set(package_dir ${CMAKE_INSTALL_LIBDIR}/cmake/organsim)
install(EXPORT organsimTargets NAMESPACE organsim:: DESTINATION ${package_dir} COMPONENT development)
configure_package_config_file(cmake/package/organsimConfig.cmake.in
  ${PROJECT_BINARY_DIR}/package/organsimConfig.cmake INSTALL_DESTINATION ${package_dir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/package/organsimConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/package/organsimConfig.cmake
  ${PROJECT_BINARY_DIR}/package/organsimConfigVersion.cmake DESTINATION ${package_dir} COMPONENT development)
configure_file(cmake/package/organsim-runtime.pc.in ${PROJECT_BINARY_DIR}/package/organsim-runtime.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/package/organsim-runtime.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig
  COMPONENT development)

install(TARGETS organsim RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT program)
install(FILES LICENSE NOTICE README.md DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT program)
install(DIRECTORY data_samples/ DESTINATION ${CMAKE_INSTALL_DATADIR}/organsim/samples COMPONENT program)

# A Debian package of everything above (`cpack -G DEB` in the build folder):
# organsim_<version>_amd64.deb, its Depends computed from the binaries'
# shared libraries (dpkg-shlibdeps) plus the headers' and Python's needs.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME organsim)
set(CPACK_PACKAGE_VENDOR "the organsim authors")
set(CPACK_PACKAGE_CONTACT "organsim maintainers <organsim@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "patient-specific organ models from CT and their real-time deformation")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "libeigen3-dev (>= 3.4), python3 (>= 3.11), python3-numpy")
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "The organsim program (CT -> .organ model -> multi-beam, mass-spring and FEM
 deformation with haptic forces), its runtime libraries with headers, CMake
 package and pkg-config file, and the Python module organsim.")
include(CPack)
