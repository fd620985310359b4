# xxHash (Debian libxxhash-dev), used header-only (XXH_INLINE_ALL) for the model file's checksums.
find_path(XXHASH_INCLUDE_DIR xxhash.h REQUIRED)
add_library(organsim_xxhash INTERFACE)
target_include_directories(organsim_xxhash SYSTEM INTERFACE ${XXHASH_INCLUDE_DIR})
