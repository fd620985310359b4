#include "tool_style.h"

#include <cmath>
#include <string>

#include <vtkCamera.h>
#include <vtkCellPicker.h>
#include <vtkObjectFactory.h>
#include <vtkRenderWindow.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>

namespace organsim::viewer {

vtkStandardNewMacro(ToolStyle);

void ToolStyle::attach(std::vector<devices::StreamedTool>& tools, OrganScene& scene) {
  tools_ = &tools;
  scene_ = &scene;
  poses_.assign(tools.size(), devices::ToolPose{});
  present_.assign(tools.size(), false);
  selected_ = 0;
}

void ToolStyle::OnKeyPress() {
  const std::string key = GetInteractor()->GetKeySym();
  if (key == "n") add_tool();
  if (key == "x" && present_[selected_]) {
    present_[selected_] = false;
    (*tools_)[selected_].remove();
  }
  if (key == "g" && present_[selected_]) {  // a grasper's jaws close on what the tool touches, or open
    poses_[selected_].jaws_closed = !poses_[selected_].jaws_closed;
    (*tools_)[selected_].place(poses_[selected_]);
  }
  if (key == "Tab") selected_ = (selected_ + 1) % poses_.size();
  if (key == "plus" || key == "equal") depth(0.001);
  if (key == "minus") depth(-0.001);
  vtkInteractorStyleTrackballCamera::OnKeyPress();
}

void ToolStyle::OnLeftButtonDown() {
  dragging_ = GetInteractor()->GetShiftKey() && present_[selected_];
  if (!dragging_) vtkInteractorStyleTrackballCamera::OnLeftButtonDown();
}

void ToolStyle::OnLeftButtonUp() {
  dragging_ = false;
  vtkInteractorStyleTrackballCamera::OnLeftButtonUp();
}

void ToolStyle::OnMouseMove() {
  if (!dragging_) return vtkInteractorStyleTrackballCamera::OnMouseMove();
  int* now = GetInteractor()->GetEventPosition();
  int* before = GetInteractor()->GetLastEventPosition();
  // Move in the view plane, one pixel = the world size of a pixel at the tip's depth.
  vtkCamera* camera = scene_->renderer()->GetActiveCamera();
  double up[3], focal[3], eye[3];
  camera->GetViewUp(up);
  camera->GetFocalPoint(focal);
  camera->GetPosition(eye);
  const Eigen::Vector3d view =
      (Eigen::Vector3d(focal[0], focal[1], focal[2]) - Eigen::Vector3d(eye[0], eye[1], eye[2])).normalized();
  const Eigen::Vector3d upward = Eigen::Vector3d(up[0], up[1], up[2]).normalized();
  const Eigen::Vector3d right = view.cross(upward).normalized();
  const double distance = (poses_[selected_].tip - Eigen::Vector3d(eye[0], eye[1], eye[2])).norm();
  const double pixel =
      2.0 * distance * std::tan(camera->GetViewAngle() * M_PI / 360.0) / scene_->window()->GetSize()[1];
  poses_[selected_].tip += pixel * ((now[0] - before[0]) * right + (now[1] - before[1]) * upward);
  (*tools_)[selected_].place(poses_[selected_]);
}

void ToolStyle::OnMouseWheelForward() {
  if (GetInteractor()->GetShiftKey()) return depth(0.001);
  vtkInteractorStyleTrackballCamera::OnMouseWheelForward();
}

void ToolStyle::OnMouseWheelBackward() {
  if (GetInteractor()->GetShiftKey()) return depth(-0.001);
  vtkInteractorStyleTrackballCamera::OnMouseWheelBackward();
}

void ToolStyle::depth(double metres) {
  if (!present_[selected_]) return;
  double focal[3], eye[3];
  scene_->renderer()->GetActiveCamera()->GetFocalPoint(focal);
  scene_->renderer()->GetActiveCamera()->GetPosition(eye);
  const Eigen::Vector3d view =
      (Eigen::Vector3d(focal[0], focal[1], focal[2]) - Eigen::Vector3d(eye[0], eye[1], eye[2])).normalized();
  poses_[selected_].tip += metres * view;
  (*tools_)[selected_].place(poses_[selected_]);
}

void ToolStyle::add_tool() {
  int* at = GetInteractor()->GetEventPosition();
  vtkNew<vtkCellPicker> picker;
  picker->SetTolerance(0.0005);
  if (!picker->Pick(at[0], at[1], 0.0, scene_->renderer())) return;
  std::size_t slot = 0;
  while (slot < poses_.size() && present_[slot]) ++slot;
  if (slot == poses_.size()) return;
  double* normal = picker->GetPickNormal();
  double* point = picker->GetPickPosition();
  const Eigen::Vector3d n = Eigen::Vector3d(normal[0], normal[1], normal[2]).normalized();
  poses_[slot].tip = Eigen::Vector3d(point[0], point[1], point[2]) + 0.005 * n;  // 5 mm above the surface
  poses_[slot].shaft = n;
  present_[slot] = true;
  selected_ = slot;
  (*tools_)[slot].place(poses_[slot]);
}

}  // namespace organsim::viewer
