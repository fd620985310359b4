// A coloured surface seen from one side, drawn as a PNG by a small software
// rasterizer (a depth buffer over the triangles, OpenCV for the image, the
// text and the file format): the training report's organ pictures. It needs no
// display, no OpenGL and no X server, so a report drawn on a headless server,
// over SSH or in CI holds the same pictures as one drawn at a desk.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace organsim::report {

struct SurfacePicture {
  std::string title;                                   ///< above the picture
  std::string scale_title;                             ///< under the colour bar, with its unit
  std::vector<std::array<double, 3>> points;           ///< the surface's vertices (any length unit)
  std::vector<std::array<std::int32_t, 3>> triangles;  ///< 0-based indices into points
  std::vector<double> values;                          ///< one per point: the colour
  double low = 0.0, high = 1.0;                        ///< the colour scale (values outside are clamped)
  /// Places marked with a black disc with a white rim of `marker_radius`
  /// (the points' unit), drawn over the surface.
  std::vector<std::array<double, 3>> markers;
  double marker_radius = 1.0;
  std::array<double, 3> view_direction{0, 1, 0};  ///< from the eye towards the surface (parallel projection)
  std::array<double, 3> view_up{0, 0, 1};         ///< the picture's up
  int width = 420, height = 380;                  ///< pixels
};

/// The picture as PNG bytes: the surface shaded by its facets' angle to the
/// eye and coloured by `values` (cool blue at `low`, pale grey between, red at
/// `high`), the markers, the title, and a colour bar labelled with the scale's
/// ends. Throws std::invalid_argument for no triangles, an index out of range,
/// a value count other than the points', a non-finite point or value,
/// low ≥ high, a view direction that is zero or parallel to `view_up`, or a
/// size under 64 × 64 pixels.
std::vector<unsigned char> draw_surface_png(const SurfacePicture& picture);

/// Where `point` (the points' unit) lands in the drawn picture: pixels from
/// its top-left corner, x to the right and y down (pixel (i, j) covers
/// [i, i + 1) × [j, j + 1)). Throws as draw_surface_png does.
std::array<double, 2> picture_pixel(const SurfacePicture& picture, const std::array<double, 3>& point);

}  // namespace organsim::report
