# zlib: checking that a gzip-compressed image is complete before ITK reads it
# (ITK reads a truncated stream as zeros).
find_package(ZLIB REQUIRED)
