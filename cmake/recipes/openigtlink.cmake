# OpenIGTLink (Debian libopenigtlink-dev, library 1.11, protocol 2): the
# messages `organsim serve` reads and sends. Debian's config file names the
# library without a target, so one is made here.
find_package(OpenIGTLink REQUIRED CONFIG PATHS /usr/lib/openigtlink)
find_library(ORGANSIM_OPENIGTLINK_LIBRARY NAMES ${OpenIGTLink_LIBRARIES} HINTS ${OpenIGTLink_LIBRARY_DIRS} REQUIRED)
add_library(organsim_openigtlink INTERFACE)
target_include_directories(organsim_openigtlink SYSTEM INTERFACE ${OpenIGTLink_INCLUDE_DIRS})
target_link_libraries(organsim_openigtlink INTERFACE ${ORGANSIM_OPENIGTLINK_LIBRARY})
