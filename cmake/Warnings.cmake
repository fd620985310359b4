# Project warnings, linked PRIVATE so they never leak into consumers.
add_library(organsim_warnings INTERFACE)
target_compile_options(organsim_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow>)
