// The viewer's mouse and keyboard tools (viewer/tool_style.h) driven by the
// interactor's events, off screen (ctest tool_style_rendered runs it under
// xvfb-run).
#include <cstdlib>
#include <vector>

#include <gtest/gtest.h>
#include <vtkCommand.h>
#include <vtkGenericRenderWindowInteractor.h>
#include <vtkNew.h>

#include "organsim/devices/streamed_tool.h"
#include "test_models.h"
#include "viewer/scene.h"
#include "viewer/tool_style.h"

namespace organsim::viewer {
namespace {

void press_key(vtkRenderWindowInteractor& interactor, int x, int y, char key) {
  const char symbol[2] = {key, '\0'};
  interactor.SetEventInformation(x, y, 0, 0, key, 0, symbol);
  interactor.InvokeEvent(vtkCommand::KeyPressEvent);
}

// `n` over the organ puts a tool there; `g` closes its jaws and `g` again
// opens them, and the tool's device reports it to the force loop
// (docs/realtime.md#grasping).
TEST(ToolStyle, TheGKeyClosesAndOpensTheSelectedToolsJaws) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no X display (ctest tool_style_rendered runs this)";
  const organ::Organ organ(testing::make_cylinder_model({}));
  SceneOptions options;
  options.offscreen = true;
  options.width = 640;
  options.height = 480;
  OrganScene scene(organ, 1, std::move(options));
  scene.render();
  std::vector<devices::StreamedTool> tools(1);
  vtkNew<vtkGenericRenderWindowInteractor> interactor;
  interactor->SetRenderWindow(scene.window());
  vtkNew<ToolStyle> style;
  style->attach(tools, scene);
  interactor->SetInteractorStyle(style);

  press_key(*interactor, 320, 240, 'n');  // the organ fills the window's middle
  ASSERT_TRUE(style->present()[0]) << "no tool placed on the organ";
  EXPECT_FALSE(style->poses()[0].jaws_closed);
  devices::ToolPose pose;
  for (const bool closed : {true, false}) {
    press_key(*interactor, 320, 240, 'g');
    EXPECT_EQ(style->poses()[0].jaws_closed, closed);
    ASSERT_TRUE(tools[0].read_pose(0.0, pose));
    EXPECT_EQ(pose.jaws_closed, closed) << "the force loop sees the jaws";
  }
}

}  // namespace
}  // namespace organsim::viewer
