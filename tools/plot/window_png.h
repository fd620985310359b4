// What every off-screen picture of tools/plot shares: the check for an X
// display (Debian's VTK 9.1 renders off screen through X only) and writing a
// rendered window as a PNG, atomically.
#pragma once

#include <string>

class vtkRenderWindow;

namespace organsim::plot {

/// Throws std::runtime_error naming `png_path` and xvfb-run when DISPLAY is unset or empty.
void require_display(const std::string& png_path);

/// Renders `window` and writes its pixels as a PNG at `png_path` (io::AtomicFile:
/// the file appears whole or not at all). Throws std::runtime_error when the
/// file cannot be written.
void write_window_png(vtkRenderWindow* window, const std::string& png_path);

}  // namespace organsim::plot
