#include "window_png.h"

#include <cstdlib>
#include <stdexcept>

#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkRenderWindow.h>
#include <vtkWindowToImageFilter.h>

#include "organsim/io/atomic_file.h"

namespace organsim::plot {

void require_display(const std::string& png_path) {
  const char* display = std::getenv("DISPLAY");
  if (display == nullptr || *display == '\0')
    throw std::runtime_error("no X display to render " + png_path +
                             " on (VTK renders off screen through X here): run under xvfb-run -a");
}

void write_window_png(vtkRenderWindow* window, const std::string& png_path) {
  window->Render();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->Update();

  io::AtomicFile file(png_path, ".png");
  vtkNew<vtkPNGWriter> writer;
  writer->SetCompressionLevel(9);
  writer->SetFileName(file.temp_path().c_str());
  writer->SetInputConnection(grab->GetOutputPort());
  writer->Write();
  if (writer->GetErrorCode() != 0) throw std::runtime_error("cannot write " + png_path + " as PNG");
  file.commit();
}

}  // namespace organsim::plot
