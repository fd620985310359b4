// Mouse and keyboard tools on top of the usual camera controls: `n` puts a tool
// above the organ where the mouse points, shift + drag moves it in the view
// plane, shift + wheel (or +/-) pushes it in or pulls it out, `g` closes or
// opens its jaws (docs/realtime.md#grasping), Tab selects the next tool, `x`
// removes it. Dragging alone turns the camera.
#pragma once

#include <cstddef>
#include <vector>

#include <vtkInteractorStyleTrackballCamera.h>

#include "organsim/devices/streamed_tool.h"
#include "scene.h"

namespace organsim::viewer {

class ToolStyle : public vtkInteractorStyleTrackballCamera {
 public:
  static ToolStyle* New();
  vtkTypeMacro(ToolStyle, vtkInteractorStyleTrackballCamera)

      /// The tools it moves and the scene it picks in; `poses` and `present` say
      /// where each tool is and whether it is placed (read by the drawing).
      void attach(std::vector<devices::StreamedTool>& tools, OrganScene& scene);
  const std::vector<devices::ToolPose>& poses() const { return poses_; }
  const std::vector<bool>& present() const { return present_; }

  void OnKeyPress() override;
  void OnLeftButtonDown() override;
  void OnLeftButtonUp() override;
  void OnMouseMove() override;
  void OnMouseWheelForward() override;
  void OnMouseWheelBackward() override;

 private:
  void depth(double metres);
  void add_tool();

  std::vector<devices::StreamedTool>* tools_ = nullptr;
  OrganScene* scene_ = nullptr;
  std::vector<devices::ToolPose> poses_;
  std::vector<bool> present_;
  std::size_t selected_ = 0;
  bool dragging_ = false;
};

}  // namespace organsim::viewer
