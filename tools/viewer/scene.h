// The laparoscopic scene in VTK: the textured, lit organ with smooth normals,
// each tool as an instrument (shaft and tip) with its force arrow, a text
// overlay, and an optional image or video background. Rendering on screen or
// off screen (Xvfb, CI), with screenshots and frames for recordings.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "imagery.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/engine.h"

class vtkRenderWindow;
class vtkRenderer;

namespace organsim::viewer {

struct SceneOptions {
  int width = 960;
  int height = 720;
  bool offscreen = false;
  cv::Mat texture;                         ///< BGR; empty: the procedural liver texture
  std::unique_ptr<Background> background;  ///< may be null: a dark abdominal backdrop
  double shaft_length = 0.30;              ///< m
  double force_arrow_scale = 0.03;         ///< m of arrow per newton
  /// Mark the model's supports (docs/supports.md) on the organ: blue points
  /// where it rests on a neighbour, orange where it is attached.
  bool show_supports = false;
};

class OrganScene {
 public:
  OrganScene(const organ::Organ& organ, std::size_t tools, SceneOptions options);
  ~OrganScene();

  /// The deformed surface (organ::Organ's vertex order), with the patch each
  /// grasping tool holds marked: the surface vertices within its tip radius of
  /// the point its jaws hold (the nearest one where none is), drawn green.
  void show_surface(const realtime::SurfaceFrame& frame);
  /// The vertices marked as tool `i`'s held patch in the last surface shown.
  std::size_t held_vertices(std::size_t i) const;
  /// The supported vertices marked (SceneOptions::show_supports; 0 without).
  std::size_t supported_vertices() const;
  /// Tool `i`: its pose, the force it feels (N) and whether it touches.
  void show_tool(std::size_t i, bool present, const devices::ToolPose& pose, const Eigen::Vector3d& force,
                 bool in_contact);
  void show_text(const std::string& text);
  /// Advances a video background by one frame.
  void next_background_frame();
  void render();
  /// The window's pixels (BGR).
  cv::Mat capture();
  /// Where a model point appears, in pixels from the top-left corner.
  Eigen::Vector2d project(const Eigen::Vector3d& point);
  vtkRenderWindow* window();
  vtkRenderer* renderer();

 private:
  struct Parts;
  std::unique_ptr<Parts> parts_;
};

}  // namespace organsim::viewer
