// 3-D field views (see field_view.h).
#include "field_view.h"
#include "window_png.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellData.h>
#include <vtkDataSetSurfaceFilter.h>
#include <vtkSphereSource.h>
#include <vtkDoubleArray.h>
#include <vtkLookupTable.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkUnstructuredGrid.h>

namespace organsim::plot {
namespace {

void check(const std::vector<FieldPanel>& panels, const FieldView& view) {
  if (panels.empty()) throw std::invalid_argument("write_field_view_png: no panels to draw");
  if (!(std::isfinite(view.low) && std::isfinite(view.high) && view.low < view.high))
    throw std::invalid_argument("write_field_view_png: the colour scale needs finite low < high");
  if (view.panel_width < 64 || view.height < 64 || view.panel_width > 4096 || view.height > 4096)
    throw std::invalid_argument("write_field_view_png: panel size must be 64–4096 pixels");
  for (const FieldPanel& p : panels) {
    const std::string where = "write_field_view_png: panel '" + p.title + "': ";
    if (p.tetrahedra.empty() == p.triangles.empty())
      throw std::invalid_argument(where + "give either tetrahedra or triangles");
    const auto check_nodes = [&](const auto& cells) {
      for (const auto& cell : cells)
        for (std::int32_t n : cell)
          if (n < 0 || static_cast<std::size_t>(n) >= p.points.size())
            throw std::invalid_argument(where + "node " + std::to_string(n) + " out of range");
    };
    check_nodes(p.tetrahedra);
    check_nodes(p.triangles);
    const std::size_t cells = p.tetrahedra.size() + p.triangles.size();
    const bool per_cell = p.cell_values.size() == cells && p.point_values.empty();
    const bool per_point = p.point_values.size() == p.points.size() && p.cell_values.empty();
    if (!per_cell && !per_point) throw std::invalid_argument(where + "give one value per cell or one per node");
    for (const std::vector<double>* values : {&p.cell_values, &p.point_values})
      for (double v : *values)
        if (!std::isfinite(v)) throw std::invalid_argument(where + "a value is not finite");
  }
}

vtkSmartPointer<vtkUnstructuredGrid> grid_of(const FieldPanel& panel) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  for (const auto& p : panel.points) points->InsertNextPoint(p.data());
  auto grid = vtkSmartPointer<vtkUnstructuredGrid>::New();
  grid->SetPoints(points);
  grid->Allocate(static_cast<vtkIdType>(panel.tetrahedra.size() + panel.triangles.size()));
  for (const auto& t : panel.tetrahedra) {
    const vtkIdType ids[4] = {t[0], t[1], t[2], t[3]};
    grid->InsertNextCell(VTK_TETRA, 4, ids);
  }
  for (const auto& t : panel.triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    grid->InsertNextCell(VTK_TRIANGLE, 3, ids);
  }
  vtkNew<vtkDoubleArray> values;
  values->SetName("value");
  const std::vector<double>& source = panel.cell_values.empty() ? panel.point_values : panel.cell_values;
  values->SetNumberOfValues(static_cast<vtkIdType>(source.size()));
  for (std::size_t i = 0; i < source.size(); ++i) values->SetValue(static_cast<vtkIdType>(i), source[i]);
  if (panel.cell_values.empty())
    grid->GetPointData()->SetScalars(values);
  else
    grid->GetCellData()->SetScalars(values);
  return grid;
}

}  // namespace

void write_field_view_png(const std::vector<FieldPanel>& panels, const FieldView& view, const std::string& png_path) {
  check(panels, view);
  require_display(png_path);

  const int bar_width = 110;
  const int width = view.panel_width * static_cast<int>(panels.size()) + bar_width;
  vtkNew<vtkRenderWindow> window;
  window->SetOffScreenRendering(1);
  window->SetSize(width, view.height);
  window->SetMultiSamples(4);

  vtkNew<vtkLookupTable> colours;
  colours->SetHueRange(0.667, 0.0);  // blue (low) to red (high)
  colours->SetTableRange(view.low, view.high);
  colours->Build();

  vtkNew<vtkCamera> camera;
  camera->SetFocalPoint(0, 0, 0);
  camera->SetPosition(-view.view_direction[0], -view.view_direction[1], -view.view_direction[2]);
  camera->SetViewUp(view.view_up.data());
  std::vector<vtkSmartPointer<vtkRenderer>> renderers;
  for (std::size_t i = 0; i < panels.size(); ++i) {
    vtkNew<vtkDataSetSurfaceFilter> surface;
    surface->SetInputData(grid_of(panels[i]));
    vtkNew<vtkPolyDataMapper> mapper;
    mapper->SetInputConnection(surface->GetOutputPort());
    mapper->SetLookupTable(colours);
    mapper->UseLookupTableScalarRangeOn();
    mapper->SetScalarModeToDefault();
    vtkNew<vtkActor> actor;
    actor->SetMapper(mapper);
    actor->GetProperty()->EdgeVisibilityOn();
    actor->GetProperty()->SetEdgeColor(0.25, 0.25, 0.25);
    actor->GetProperty()->SetLineWidth(0.5);

    vtkNew<vtkTextActor> title;
    title->SetInput(panels[i].title.c_str());
    title->GetTextProperty()->SetFontSize(18);
    title->GetTextProperty()->SetColor(0, 0, 0);
    title->GetTextProperty()->SetJustificationToCentered();
    title->SetPosition(view.panel_width / 2.0, view.height - 30.0);

    vtkRenderer* renderer = renderers.emplace_back(vtkSmartPointer<vtkRenderer>::New());
    for (const auto& at : panels[i].markers) {
      vtkNew<vtkSphereSource> ball;
      ball->SetCenter(at.data());
      ball->SetRadius(panels[i].marker_radius);
      ball->SetThetaResolution(16);
      ball->SetPhiResolution(12);
      vtkNew<vtkPolyDataMapper> ball_mapper;
      ball_mapper->SetInputConnection(ball->GetOutputPort());
      ball_mapper->ScalarVisibilityOff();
      vtkNew<vtkActor> marker;
      marker->SetMapper(ball_mapper);
      marker->GetProperty()->SetColor(0.05, 0.05, 0.05);
      renderer->AddActor(marker);
    }
    renderer->SetViewport(static_cast<double>(i) * view.panel_width / width, 0.0,
                          static_cast<double>(i + 1) * view.panel_width / width, 1.0);
    renderer->SetBackground(1, 1, 1);
    renderer->AddActor(actor);
    renderer->AddActor2D(title);
    renderer->SetActiveCamera(camera);  // one camera: the panels share position and scale
    window->AddRenderer(renderer);
  }
  // Frame every panel's mesh, not only the first: grow the view to their union.
  double bounds[6] = {1e300, -1e300, 1e300, -1e300, 1e300, -1e300};
  for (auto& renderer : renderers) {
    double b[6];
    renderer->ComputeVisiblePropBounds(b);
    for (int k = 0; k < 3; ++k) {
      bounds[2 * k] = std::min(bounds[2 * k], b[2 * k]);
      bounds[2 * k + 1] = std::max(bounds[2 * k + 1], b[2 * k + 1]);
    }
  }
  renderers.front()->ResetCamera(bounds);
  camera->Zoom(1.15);

  vtkNew<vtkRenderer> bar_renderer;
  bar_renderer->SetViewport(static_cast<double>(width - bar_width) / width, 0.0, 1.0, 1.0);
  bar_renderer->SetBackground(1, 1, 1);
  vtkNew<vtkScalarBarActor> bar;
  bar->SetLookupTable(colours);
  bar->SetTitle(view.scalar_title.c_str());
  bar->SetNumberOfLabels(5);
  bar->SetLabelFormat("%.3g");
  bar->UnconstrainedFontSizeOn();
  bar->SetMaximumWidthInPixels(bar_width - 20);
  bar->SetPosition(0.1, 0.1);
  bar->SetPosition2(0.8, 0.8);
  for (vtkTextProperty* text : {bar->GetTitleTextProperty(), bar->GetLabelTextProperty()}) {
    text->SetColor(0, 0, 0);
    text->SetFontSize(14);
    text->ItalicOff();
    text->ShadowOff();
  }
  bar_renderer->AddActor2D(bar);
  window->AddRenderer(bar_renderer);

  write_window_png(window, png_path);
}

}  // namespace organsim::plot
