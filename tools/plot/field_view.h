// 3-D views of a field on tetrahedral meshes as one PNG (VTK, rendered off
// screen): each panel is a (deformed) mesh whose boundary is coloured by a
// per-tetrahedron or per-node value on one shared colour scale, side by side
// under one camera — the paper's pressure pictures (Figs. 3–5) for
// tools/experiments/fem_paper.
//
// As for line plots, Debian's VTK 9.1 renders off screen through X only:
// without a display, run under a virtual one (`xvfb-run -a …`).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace organsim::plot {

struct FieldPanel {
  std::string title;
  std::vector<std::array<double, 3>> points;  ///< the mesh's nodes where they are drawn (any length unit)
  /// 0-based node indices: tetrahedra (their boundary is drawn), or a
  /// surface's triangles.
  std::vector<std::array<std::int32_t, 4>> tetrahedra;
  std::vector<std::array<std::int32_t, 3>> triangles;
  /// Exactly one is filled: a value per cell (drawn flat) or per node
  /// (interpolated).
  std::vector<double> cell_values, point_values;
  /// Places marked with a black ball of `marker_radius` (the points' unit).
  std::vector<std::array<double, 3>> markers;
  double marker_radius = 1.0;
};

struct FieldView {
  std::string scalar_title;                       ///< the colour bar's title, with units
  double low = 0, high = 1;                       ///< the colour scale (values outside are clamped)
  std::array<double, 3> view_direction{0, 1, 0};  ///< from the camera towards the meshes
  std::array<double, 3> view_up{0, 0, 1};
  int panel_width = 320, height = 560;  ///< pixels
};

/// Renders the panels left to right, each mesh's boundary coloured by its
/// values (blue low, red high) with a shared colour bar, and writes the image
/// atomically to `png_path`. Throws std::invalid_argument for no panels, a
/// panel with no cells or with both kinds, a node index out of range, a value
/// count that fits neither the cells nor the nodes, a non-finite value, or
/// low ≥ high; std::runtime_error when there is no X display or the file
/// cannot be written.
void write_field_view_png(const std::vector<FieldPanel>& panels, const FieldView& view, const std::string& png_path);

}  // namespace organsim::plot
