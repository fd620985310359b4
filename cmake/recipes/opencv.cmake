# OpenCV 4 (Debian libopencv-dev), only the modules the viewer uses. Asking for
# all of them would pull in `viz`, whose VTK targets break CMake generation.
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs videoio)
add_library(organsim_opencv INTERFACE)
target_include_directories(organsim_opencv SYSTEM INTERFACE ${OpenCV_INCLUDE_DIRS})
target_link_libraries(organsim_opencv INTERFACE opencv_core opencv_imgproc opencv_imgcodecs opencv_videoio)
