# Project warnings, linked PRIVATE so they never leak into consumers.
add_library(organsim_warnings INTERFACE)
target_compile_options(organsim_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow>)

# GCC 12's AVX-512 intrinsics (used by Eigen under -march=native) trip its own
# uninitialized-variable analysis on _mm512_undefined_*() (GCC bug 105593,
# fixed in GCC 13); the warnings point into the compiler's headers, not ours.
if(ORGANSIM_NATIVE AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  target_compile_options(organsim_warnings INTERFACE -Wno-maybe-uninitialized -Wno-uninitialized)
endif()
