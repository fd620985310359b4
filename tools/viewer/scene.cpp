#include "scene.h"

#include <array>
#include <cmath>
#include <limits>

#include <vtkActor.h>
#include <vtkArrowSource.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkCoordinate.h>
#include <vtkCylinderSource.h>
#include <vtkDoubleArray.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkLight.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkSphereSource.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkTexture.h>
#include <vtkTransform.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowToImageFilter.h>

#include <opencv2/imgproc.hpp>

namespace organsim::viewer {
namespace {

// A BGR OpenCV image as an RGB VTK image (VTK's rows run bottom-up).
vtkSmartPointer<vtkImageData> to_vtk(const cv::Mat& bgr) {
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  cv::flip(rgb, rgb, 0);
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(rgb.cols, rgb.rows, 1);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  auto* target = static_cast<unsigned char*>(image->GetScalarPointer());
  for (int r = 0; r < rgb.rows; ++r) std::copy_n(rgb.ptr<unsigned char>(r), 3 * rgb.cols, target + 3 * r * rgb.cols);
  return image;
}

// Spherical (u, v) about the centroid, for models without texture coordinates.
std::vector<model::TexCoord> spherical(const std::vector<model::Point3>& vertices) {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const model::Point3& p : vertices)
    centre += Eigen::Vector3d(p[0], p[1], p[2]) / static_cast<double>(vertices.size());
  std::vector<model::TexCoord> uv;
  for (const model::Point3& p : vertices) {
    const Eigen::Vector3d d = Eigen::Vector3d(p[0], p[1], p[2]) - centre;
    const double r = d.norm();
    uv.push_back(
        {0.5 + std::atan2(d[1], d[0]) / (2.0 * M_PI), r > 0 ? std::acos(std::clamp(d[2] / r, -1.0, 1.0)) / M_PI : 0.5});
  }
  return uv;
}

struct ToolActors {
  vtkNew<vtkActor> shaft, tip, arrow;
  vtkNew<vtkTransform> shaft_pose, tip_pose, arrow_pose;
};

}  // namespace

struct OrganScene::Parts {
  SceneOptions options;
  vtkNew<vtkRenderWindow> window;
  vtkNew<vtkRenderer> renderer;
  vtkNew<vtkPolyData> surface;
  vtkNew<vtkPoints> points;
  vtkNew<vtkDoubleArray> normals;
  vtkNew<vtkActor> organ;
  vtkNew<vtkTexture> texture;
  vtkNew<vtkTexture> background;
  vtkNew<vtkTextActor> text;
  vtkNew<vtkCylinderSource> cylinder;
  vtkNew<vtkSphereSource> sphere;
  vtkNew<vtkArrowSource> arrow_source;
  std::vector<std::unique_ptr<ToolActors>> tools;
  std::vector<model::Point3> rest;  ///< the rest surface, m: where the held patches are found
  vtkNew<vtkPolyData> held;         ///< the held patches' vertices, drawn as green points
  vtkNew<vtkPoints> held_points;
  vtkNew<vtkActor> held_actor;
  std::vector<std::size_t> held_counts;
  /// The supports' vertices by kind (contact, attachment), drawn as points.
  std::array<std::vector<std::size_t>, 2> supported;
  std::array<vtkNew<vtkPolyData>, 2> support_marks;
  std::array<vtkNew<vtkPoints>, 2> support_points;
  std::array<vtkNew<vtkActor>, 2> support_actors;
};

OrganScene::OrganScene(const organ::Organ& organ, std::size_t tools, SceneOptions options)
    : parts_(std::make_unique<Parts>()) {
  Parts& p = *parts_;
  p.options = std::move(options);
  const model::OrganModel& model = organ.model();

  // The organ: points, normals and texture coordinates per vertex.
  p.points->SetDataTypeToDouble();
  p.points->SetNumberOfPoints(static_cast<vtkIdType>(model.surface_vertices.size()));
  p.normals->SetNumberOfComponents(3);
  p.normals->SetNumberOfTuples(static_cast<vtkIdType>(model.surface_vertices.size()));
  p.normals->SetName("Normals");
  vtkNew<vtkCellArray> triangles;
  for (const model::Triangle& t : model.surface_triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    triangles->InsertNextCell(3, ids);
  }
  vtkNew<vtkFloatArray> uv;
  uv->SetNumberOfComponents(2);
  uv->SetName("TextureCoordinates");
  const std::vector<model::TexCoord> coordinates =
      model.surface_texcoords.empty() ? spherical(model.surface_vertices) : model.surface_texcoords;
  for (const model::TexCoord& c : coordinates) uv->InsertNextTuple2(c[0], c[1]);
  p.surface->SetPoints(p.points);
  p.surface->SetPolys(triangles);
  p.surface->GetPointData()->SetNormals(p.normals);
  p.surface->GetPointData()->SetTCoords(uv);
  vtkNew<vtkPolyDataMapper> organ_mapper;
  organ_mapper->SetInputData(p.surface);
  p.organ->SetMapper(organ_mapper);
  p.texture->SetInputData(to_vtk(p.options.texture.empty() ? procedural_liver_texture() : p.options.texture));
  p.texture->InterpolateOn();
  p.texture->RepeatOn();
  p.organ->SetTexture(p.texture);
  vtkProperty* skin = p.organ->GetProperty();
  skin->SetInterpolationToPhong();
  skin->SetAmbient(0.15);
  skin->SetDiffuse(0.85);
  skin->SetSpecular(0.35);  // the wet sheen of a liver under the laparoscope's light
  skin->SetSpecularPower(25.0);
  p.renderer->AddActor(p.organ);

  // Tools: a steel shaft, a dark tip, a yellow force arrow.
  p.cylinder->SetRadius(0.0025);
  p.cylinder->SetHeight(1.0);
  p.cylinder->SetResolution(24);
  p.sphere->SetRadius(0.003);
  p.sphere->SetThetaResolution(24);
  p.sphere->SetPhiResolution(16);
  p.arrow_source->SetTipResolution(16);
  p.arrow_source->SetShaftResolution(16);
  for (std::size_t i = 0; i < tools; ++i) {
    auto actors = std::make_unique<ToolActors>();
    auto attach = [&](vtkActor* actor, vtkAlgorithm* source, vtkTransform* pose, double r, double g, double b) {
      vtkNew<vtkPolyDataMapper> mapper;
      mapper->SetInputConnection(source->GetOutputPort());
      actor->SetMapper(mapper);
      actor->SetUserTransform(pose);
      actor->GetProperty()->SetColor(r, g, b);
      actor->GetProperty()->SetSpecular(0.6);
      actor->VisibilityOff();
      p.renderer->AddActor(actor);
    };
    attach(actors->shaft, p.cylinder, actors->shaft_pose, 0.72, 0.74, 0.76);
    attach(actors->tip, p.sphere, actors->tip_pose, 0.15, 0.15, 0.17);
    attach(actors->arrow, p.arrow_source, actors->arrow_pose, 1.0, 0.85, 0.1);
    p.tools.push_back(std::move(actors));
  }

  p.text->GetTextProperty()->SetFontSize(16);
  p.text->GetTextProperty()->SetColor(1.0, 1.0, 1.0);
  p.text->SetDisplayPosition(12, 12);
  p.renderer->AddActor2D(p.text);

  if (p.options.background) {
    p.background->SetInputData(to_vtk(p.options.background->next()));
    p.renderer->SetBackgroundTexture(p.background);
    p.renderer->TexturedBackgroundOn();
  } else {
    p.renderer->SetBackground(0.10, 0.04, 0.04);  // the dark red of an insufflated abdomen
    p.renderer->SetBackground2(0.02, 0.01, 0.01);
    p.renderer->GradientBackgroundOn();
  }

  // The laparoscope: a wide-angle camera with its light at the lens.
  p.renderer->SetLightFollowCamera(true);
  p.window->SetSize(p.options.width, p.options.height);
  p.window->SetOffScreenRendering(p.options.offscreen ? 1 : 0);
  p.window->SetWindowName("organsim");
  p.window->AddRenderer(p.renderer);
  // The held patches: green points on the organ where grasping jaws hold it.
  p.rest = model.surface_vertices;
  p.held_counts.assign(tools, 0);
  p.held_points->SetDataTypeToDouble();
  p.held->SetPoints(p.held_points);
  vtkNew<vtkPolyDataMapper> held_mapper;
  held_mapper->SetInputData(p.held);
  p.held_actor->SetMapper(held_mapper);
  p.held_actor->GetProperty()->SetColor(0.15, 0.9, 0.3);
  p.held_actor->GetProperty()->SetPointSize(7.0);
  p.held_actor->GetProperty()->RenderPointsAsSpheresOn();
  p.held_actor->GetProperty()->LightingOff();
  p.held_actor->VisibilityOff();
  p.renderer->AddActor(p.held_actor);

  // The supports: blue where the organ rests on a neighbour, orange where it is attached.
  if (p.options.show_supports && !model.supports.empty()) {
    for (std::size_t v = 0; v < model.supports.vertices.size(); ++v)
      if (const auto kind = model.supports.kind(v); kind != model::Supports::Kind::kFree)
        p.supported[kind == model::Supports::Kind::kContact ? 0 : 1].push_back(v);
    const double colours[2][3] = {{0.2, 0.45, 1.0}, {1.0, 0.55, 0.1}};
    for (int k = 0; k < 2; ++k) {
      p.support_points[k]->SetDataTypeToDouble();
      p.support_marks[k]->SetPoints(p.support_points[k]);
      vtkNew<vtkPolyDataMapper> mapper;
      mapper->SetInputData(p.support_marks[k]);
      p.support_actors[k]->SetMapper(mapper);
      p.support_actors[k]->GetProperty()->SetColor(colours[k][0], colours[k][1], colours[k][2]);
      p.support_actors[k]->GetProperty()->SetPointSize(5.0);
      p.support_actors[k]->GetProperty()->RenderPointsAsSpheresOn();
      p.support_actors[k]->GetProperty()->LightingOff();
      p.renderer->AddActor(p.support_actors[k]);
    }
  }

  realtime::SurfaceFrame rest;
  rest.positions = model.surface_vertices;
  rest.normals.resize(rest.positions.size());
  organ::compute_vertex_normals(organ, rest.positions.data(), rest.normals.data(), 0, rest.positions.size());
  show_surface(rest);
  vtkCamera* camera = p.renderer->GetActiveCamera();
  camera->SetViewAngle(60.0);
  camera->SetPosition(0.0, -1.0, 0.3);  // from the front (anterior is −y in LPS), a little from above
  camera->SetFocalPoint(0.0, 0.0, 0.0);
  camera->SetViewUp(0.0, 0.0, 1.0);
  p.renderer->ResetCamera();
  camera->Dolly(1.3);
  p.renderer->ResetCameraClippingRange();
}

OrganScene::~OrganScene() = default;

void OrganScene::show_surface(const realtime::SurfaceFrame& frame) {
  Parts& p = *parts_;
  for (std::size_t v = 0; v < frame.positions.size(); ++v) {
    p.points->SetPoint(static_cast<vtkIdType>(v), frame.positions[v].data());
    p.normals->SetTuple(static_cast<vtkIdType>(v), frame.normals[v].data());
  }
  p.points->Modified();
  p.normals->Modified();
  p.surface->Modified();

  // The held patches, a little outside the surface so that the organ does not hide them.
  constexpr double kLift = 3e-4;  // m
  p.held_points->Reset();
  vtkNew<vtkCellArray> vertices;
  const auto mark = [&](std::size_t v) {
    const Eigen::Vector3d x =
        Eigen::Vector3d(frame.positions[v].data()) + kLift * Eigen::Vector3d(frame.normals[v].data());
    const vtkIdType id = p.held_points->InsertNextPoint(x.data());
    vertices->InsertNextCell(1, &id);
  };
  for (std::size_t i = 0; i < p.held_counts.size(); ++i) {
    p.held_counts[i] = 0;
    if (!frame.holding[i] || frame.positions.size() != p.rest.size()) continue;
    std::size_t nearest = 0;
    double nearest_distance = std::numeric_limits<double>::infinity();
    for (std::size_t v = 0; v < p.rest.size(); ++v) {
      const double distance = (Eigen::Vector3d(p.rest[v].data()) - frame.held_point[i]).norm();
      if (distance <= frame.held_radius[i]) mark(v), ++p.held_counts[i];
      if (distance < nearest_distance) nearest_distance = distance, nearest = v;
    }
    if (p.held_counts[i] == 0 && !p.rest.empty()) mark(nearest), p.held_counts[i] = 1;
  }
  p.held->SetVerts(vertices);
  p.held_points->Modified();
  p.held->Modified();
  p.held_actor->SetVisibility(p.held_points->GetNumberOfPoints() > 0);

  for (int k = 0; k < 2; ++k) {
    if (p.supported[k].empty() || frame.positions.size() != p.rest.size()) continue;
    p.support_points[k]->Reset();
    vtkNew<vtkCellArray> marks;
    for (const std::size_t v : p.supported[k]) {
      const Eigen::Vector3d x =
          Eigen::Vector3d(frame.positions[v].data()) + kLift * Eigen::Vector3d(frame.normals[v].data());
      const vtkIdType id = p.support_points[k]->InsertNextPoint(x.data());
      marks->InsertNextCell(1, &id);
    }
    p.support_marks[k]->SetVerts(marks);
    p.support_points[k]->Modified();
    p.support_marks[k]->Modified();
  }
}

std::size_t OrganScene::supported_vertices() const { return parts_->supported[0].size() + parts_->supported[1].size(); }

std::size_t OrganScene::held_vertices(std::size_t i) const {
  return i < parts_->held_counts.size() ? parts_->held_counts[i] : 0;
}

void OrganScene::show_tool(std::size_t i, bool present, const devices::ToolPose& pose, const Eigen::Vector3d& force,
                           bool in_contact) {
  Parts& p = *parts_;
  ToolActors& t = *p.tools[i];
  t.shaft->SetVisibility(present);
  t.tip->SetVisibility(present);
  t.arrow->SetVisibility(present && force.norm() > 1e-4);
  if (!present) return;
  // Without a known shaft the instrument comes from above and from the
  // camera's side, as through a trocar near the laparoscope.
  Eigen::Vector3d shaft = pose.shaft;
  if (shaft.squaredNorm() == 0.0) {
    double eye[3], up[3];
    p.renderer->GetActiveCamera()->GetPosition(eye);
    p.renderer->GetActiveCamera()->GetViewUp(up);
    const Eigen::Vector3d towards_eye = (Eigen::Vector3d(eye[0], eye[1], eye[2]) - pose.tip).normalized();
    shaft = (0.6 * towards_eye + Eigen::Vector3d(up[0], up[1], up[2]).normalized()).normalized();
  }
  const double length = p.options.shaft_length;
  // vtkCylinderSource lies along y, centred: rotate y onto the shaft, stretch to its length.
  const Eigen::Vector3d y(0.0, 1.0, 0.0);
  const Eigen::Vector3d axis = y.cross(shaft);
  const double angle = std::atan2(axis.norm(), y.dot(shaft)) * 180.0 / M_PI;
  const Eigen::Vector3d middle = pose.tip + 0.5 * length * shaft;
  t.shaft_pose->Identity();
  t.shaft_pose->Translate(middle.data());
  if (axis.norm() > 1e-12) t.shaft_pose->RotateWXYZ(angle, axis[0], axis[1], axis[2]);
  t.shaft_pose->Scale(1.0, length, 1.0);
  t.tip_pose->Identity();
  t.tip_pose->Translate(pose.tip.data());
  // The tip: red while it touches, green while its closed jaws hold the
  // organ, blue when they are closed in the air, dark when open and free.
  if (pose.jaws_closed)
    t.tip->GetProperty()->SetColor(0.15, in_contact ? 0.85 : 0.35, in_contact ? 0.25 : 0.85);
  else
    t.tip->GetProperty()->SetColor(in_contact ? 0.9 : 0.15, in_contact ? 0.3 : 0.15, 0.15);
  // vtkArrowSource points along x with length 1.
  const double magnitude = force.norm();
  if (magnitude > 1e-4) {
    const Eigen::Vector3d direction = force / magnitude, x(1.0, 0.0, 0.0);
    const Eigen::Vector3d turn = x.cross(direction);
    const double turn_angle = std::atan2(turn.norm(), x.dot(direction)) * 180.0 / M_PI;
    t.arrow_pose->Identity();
    t.arrow_pose->Translate(pose.tip.data());
    if (turn.norm() > 1e-12) t.arrow_pose->RotateWXYZ(turn_angle, turn[0], turn[1], turn[2]);
    const double scale = p.options.force_arrow_scale * magnitude;
    t.arrow_pose->Scale(scale, scale, scale);
  }
}

void OrganScene::show_text(const std::string& text) { parts_->text->SetInput(text.c_str()); }

void OrganScene::next_background_frame() {
  Parts& p = *parts_;
  if (!p.options.background || !p.options.background->is_video()) return;
  p.background->SetInputData(to_vtk(p.options.background->next()));
}

void OrganScene::render() {
  parts_->renderer->ResetCameraClippingRange();
  parts_->window->Render();
}

cv::Mat OrganScene::capture() {
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(parts_->window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->Update();
  vtkImageData* image = grab->GetOutput();
  int dims[3];
  image->GetDimensions(dims);
  cv::Mat rgb(dims[1], dims[0], CV_8UC3, image->GetScalarPointer());
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  cv::flip(bgr, bgr, 0);
  return bgr;
}

Eigen::Vector2d OrganScene::project(const Eigen::Vector3d& point) {
  vtkNew<vtkCoordinate> coordinate;
  coordinate->SetCoordinateSystemToWorld();
  coordinate->SetValue(point[0], point[1], point[2]);
  const double* display = coordinate->GetComputedDoubleDisplayValue(parts_->renderer);
  return {display[0], parts_->window->GetSize()[1] - display[1]};
}

vtkRenderWindow* OrganScene::window() { return parts_->window; }
vtkRenderer* OrganScene::renderer() { return parts_->renderer; }

}  // namespace organsim::viewer
