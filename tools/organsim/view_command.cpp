// `organsim view MODEL`: the trainee's view. A replayed session, or tools
// moved with the mouse, deforming the organ in a laparoscopic-looking scene;
// screenshots and recordings for engineers.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCellPicker.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkObjectFactory.h>
#include <vtkRenderWindow.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>

#include "commands.h"
#include "haptic_rig.h"
#include "organsim/model/model_file.h"
#include "organsim/realtime/loop_runner.h"
#include "organsim/realtime/session.h"
#include "viewer/mouse_tool.h"
#include "viewer/scene.h"

namespace organsim::cli {
namespace {

namespace fs = std::filesystem;
using namespace organsim::realtime;
using viewer::MouseTool;
using viewer::OrganScene;

constexpr std::size_t kMouseTools = 4;

struct ViewOptions {
  std::string model_path;
  std::string session_path;
  std::string background_path;
  std::string texture_path;
  std::string screenshot_path;
  std::string record_path;
  bool offscreen = false;
  bool hide_tools = false;
  bool json = false;
  long frames = 0;  // 0: the whole session, or until the window closes
  double seconds = 600.0;
  bool phantom = false;
  HapticRigOptions rig;
  std::vector<int> size{960, 720};
};

// Writes the recording to a temporary file and renames it into place at the end.
class Recorder {
 public:
  Recorder(const std::string& path, cv::Size size) : path_(path) {
    if (path.empty()) return;
    temporary_ = path + ".partial.avi";
    writer_.open(temporary_, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 60.0, size);
    if (!writer_.isOpened()) throw std::runtime_error("cannot write the recording " + path + "; check the directory");
  }
  ~Recorder() {
    if (!path_.empty() && !finished_) fs::remove(temporary_);
  }
  void add(const cv::Mat& frame) {
    if (writer_.isOpened()) {
      writer_.write(frame);
      ++count_;
    }
  }
  void finish() {
    if (path_.empty()) return;
    writer_.release();
    fs::rename(temporary_, path_);
    finished_ = true;
  }
  long count() const { return count_; }

 private:
  std::string path_, temporary_;
  cv::VideoWriter writer_;
  long count_ = 0;
  bool finished_ = false;
};

void write_png(const cv::Mat& image, const std::string& path) {
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", image, bytes)) throw std::runtime_error("cannot encode the screenshot as PNG");
  write_file_atomically(path, bytes.data(), bytes.size());
}

std::string overlay(const std::vector<Eigen::Vector3d>& forces, const std::vector<bool>& present, double force_hz,
                    double frame_hz, bool mouse) {
  std::string text;
  for (std::size_t i = 0; i < forces.size(); ++i)
    if (present[i]) text += fmt::format("tool {}: {:.3f} N\n", i + 1, forces[i].norm());
  text += fmt::format("force loop {:.0f} Hz, deformation {:.0f} Hz", force_hz, frame_hz);
  if (mouse)
    text += "\nn: new tool at the mouse   shift+drag: move it   shift+wheel or +/-: depth   tab: next   x: remove";
  return text;
}

// Mouse and keyboard tools on top of the usual camera controls.
class ToolStyle : public vtkInteractorStyleTrackballCamera {
 public:
  static ToolStyle* New();
  vtkTypeMacro(ToolStyle, vtkInteractorStyleTrackballCamera)

  std::vector<MouseTool>* tools = nullptr;
  std::vector<ToolPose> poses;
  std::vector<bool> present;
  std::size_t selected = 0;
  OrganScene* scene = nullptr;

  void OnKeyPress() override {
    const std::string key = GetInteractor()->GetKeySym();
    if (key == "n") add_tool();
    if (key == "x" && present[selected]) {
      present[selected] = false;
      (*tools)[selected].remove();
    }
    if (key == "Tab") selected = (selected + 1) % poses.size();
    if (key == "plus" || key == "equal") depth(0.001);
    if (key == "minus") depth(-0.001);
    vtkInteractorStyleTrackballCamera::OnKeyPress();
  }
  void OnLeftButtonDown() override {
    dragging_ = GetInteractor()->GetShiftKey() && present[selected];
    if (!dragging_) vtkInteractorStyleTrackballCamera::OnLeftButtonDown();
  }
  void OnLeftButtonUp() override {
    dragging_ = false;
    vtkInteractorStyleTrackballCamera::OnLeftButtonUp();
  }
  void OnMouseMove() override {
    if (!dragging_) return vtkInteractorStyleTrackballCamera::OnMouseMove();
    int* now = GetInteractor()->GetEventPosition();
    int* before = GetInteractor()->GetLastEventPosition();
    // Move in the view plane, one pixel = the world size of a pixel at the tip's depth.
    vtkCamera* camera = scene->renderer()->GetActiveCamera();
    double up[3], focal[3], eye[3];
    camera->GetViewUp(up);
    camera->GetFocalPoint(focal);
    camera->GetPosition(eye);
    const Eigen::Vector3d view = (Eigen::Vector3d(focal[0], focal[1], focal[2]) - Eigen::Vector3d(eye[0], eye[1], eye[2])).normalized();
    const Eigen::Vector3d upward = Eigen::Vector3d(up[0], up[1], up[2]).normalized();
    const Eigen::Vector3d right = view.cross(upward).normalized();
    const double distance = (poses[selected].tip - Eigen::Vector3d(eye[0], eye[1], eye[2])).norm();
    const double pixel = 2.0 * distance * std::tan(camera->GetViewAngle() * M_PI / 360.0) / scene->window()->GetSize()[1];
    poses[selected].tip += pixel * ((now[0] - before[0]) * right + (now[1] - before[1]) * upward);
    (*tools)[selected].place(poses[selected]);
  }
  void OnMouseWheelForward() override {
    if (GetInteractor()->GetShiftKey()) return depth(0.001);
    vtkInteractorStyleTrackballCamera::OnMouseWheelForward();
  }
  void OnMouseWheelBackward() override {
    if (GetInteractor()->GetShiftKey()) return depth(-0.001);
    vtkInteractorStyleTrackballCamera::OnMouseWheelBackward();
  }

 private:
  void depth(double metres) {
    if (!present[selected]) return;
    double focal[3], eye[3];
    scene->renderer()->GetActiveCamera()->GetFocalPoint(focal);
    scene->renderer()->GetActiveCamera()->GetPosition(eye);
    const Eigen::Vector3d view = (Eigen::Vector3d(focal[0], focal[1], focal[2]) - Eigen::Vector3d(eye[0], eye[1], eye[2])).normalized();
    poses[selected].tip += metres * view;
    (*tools)[selected].place(poses[selected]);
  }
  void add_tool() {
    int* at = GetInteractor()->GetEventPosition();
    vtkNew<vtkCellPicker> picker;
    picker->SetTolerance(0.0005);
    if (!picker->Pick(at[0], at[1], 0.0, scene->renderer())) return;
    std::size_t slot = 0;
    while (slot < poses.size() && present[slot]) ++slot;
    if (slot == poses.size()) return;
    double* normal = picker->GetPickNormal();
    double* point = picker->GetPickPosition();
    const Eigen::Vector3d n = Eigen::Vector3d(normal[0], normal[1], normal[2]).normalized();
    poses[slot].tip = Eigen::Vector3d(point[0], point[1], point[2]) + 0.005 * n;  // 5 mm above the surface
    poses[slot].shaft = n;
    present[slot] = true;
    selected = slot;
    (*tools)[slot].place(poses[slot]);
  }
  bool dragging_ = false;
};
vtkStandardNewMacro(ToolStyle);

int run_view(const ViewOptions& o) {
  if (o.size.size() != 2 || o.size[0] < 64 || o.size[1] < 64) throw std::runtime_error("--size takes WIDTH,HEIGHT of at least 64,64");
  if (!o.record_path.empty() && fs::path(o.record_path).extension() != ".avi")
    throw std::runtime_error("--record " + o.record_path + ": recordings are Motion-JPEG AVI files; name it .avi");
  if (!o.screenshot_path.empty() && fs::path(o.screenshot_path).extension() != ".png")
    throw std::runtime_error("--screenshot " + o.screenshot_path + ": screenshots are PNG files; name it .png");
  ModelReadResult read = read_organ_model_file(o.model_path);
  if (!read) throw std::runtime_error(read.error);
  if (read.model->beams.empty())
    throw std::runtime_error(o.model_path + ": the model has no beam tables; re-bake it with --stations N");
  const multibeam::BeamOrgan organ(std::move(*read.model));

  std::vector<std::string> warnings;
  viewer::SceneOptions scene_options;
  scene_options.width = o.size[0];
  scene_options.height = o.size[1];
  scene_options.offscreen = o.offscreen;
  if (!o.texture_path.empty()) scene_options.texture = viewer::read_image(o.texture_path);
  if (!o.background_path.empty()) {
    try {
      scene_options.background = std::make_unique<viewer::Background>(o.background_path);
    } catch (const std::exception& e) {
      warnings.push_back(std::string(e.what()) + "; starting without a background");
      std::fprintf(stderr, "organsim view: warning: %s\n", warnings.back().c_str());
    }
  }

  if (o.phantom && !o.session_path.empty()) throw std::runtime_error("--phantom and --session are exclusive; choose one");
  const bool scripted = !o.session_path.empty();
  Session session;
  if (scripted) session = read_session(o.session_path);
  HapticRig rig;
  if (o.phantom) rig = open_haptic_rig(o.rig, organ);
  const std::size_t tool_count = scripted ? session.tools.size() : o.phantom ? rig.devices.size() : kMouseTools;
  OrganScene scene(organ, tool_count, std::move(scene_options));
  Recorder recorder(o.record_path, cv::Size(o.size[0], o.size[1]));
  long frames = 0;
  nlohmann::json tools_json = nlohmann::json::array();

  if (scripted) {
    // The session's own time, stepped like `replay --fast`; drawn at every
    // deformation frame, paced to the wall clock when a window is shown.
    std::vector<std::unique_ptr<ScriptedDevice>> devices;
    std::vector<HapticDevice*> pointers;
    for (const Trajectory& t : session.tools) {
      devices.push_back(std::make_unique<ScriptedDevice>(t, SafetyLimits{}, 16));
      pointers.push_back(devices.back().get());
    }
    Engine engine(organ, pointers, {});
    const double frame_period = engine.options().deformation_period;
    const auto wall_start = std::chrono::steady_clock::now();
    std::vector<Eigen::Vector3d> forces(devices.size());
    std::vector<bool> present(devices.size(), !o.hide_tools);
    double time = 0.0;
    bool stop = false;
    run_fast(engine, session.duration, [&] {
      if (stop) return;
      engine.surfaces().update();
      const SurfaceFrame& surface = engine.surfaces().read();
      time = surface.time;
      scene.show_surface(surface);
      for (std::size_t i = 0; i < devices.size(); ++i) {
        ToolPose pose;
        devices[i]->read_pose(time, pose);
        forces[i] = engine.telemetry(i).last_force;
        scene.show_tool(i, present[i], pose, forces[i], engine.telemetry(i).in_contact);
      }
      if (!o.hide_tools)
        scene.show_text(overlay(forces, std::vector<bool>(devices.size(), true), 1.0 / engine.options().force_period,
                                1.0 / frame_period, false));
      scene.next_background_frame();
      scene.render();
      ++frames;
      if (!o.record_path.empty()) recorder.add(scene.capture());
      if (!o.offscreen) std::this_thread::sleep_until(wall_start + std::chrono::duration<double>(time));
      // What the last drawn frame shows, for scripts and tests.
      tools_json = nlohmann::json::array();
      for (std::size_t i = 0; i < devices.size(); ++i) {
        ToolPose pose;
        devices[i]->read_pose(time, pose);
        const Eigen::Vector2d pixel = scene.project(pose.tip);
        tools_json.push_back({{"tool", i + 1},
                              {"contacts", engine.telemetry(i).contacts},
                              {"tip_px", {pixel[0], pixel[1]}},
                              {"force_n", forces[i].norm()}});
      }
      if (o.frames > 0 && frames >= o.frames) stop = true;
    });
  } else if (o.phantom) {
    // PHANToM / Touch devices: the HD servo runs the force loop; the
    // deformation loop and the drawing run here at 60 Hz.
    const std::vector<HapticDevice*> pointers = rig.tools();
    Engine engine(organ, pointers, {});
    devices::OpenHapticsServo servo(*rig.library, rig.servo_devices(), engine);
    vtkNew<vtkRenderWindowInteractor> interactor;
    vtkNew<vtkInteractorStyleTrackballCamera> style;
    interactor->SetInteractorStyle(style);
    interactor->SetRenderWindow(scene.window());
    interactor->Initialize();
    const auto start = std::chrono::steady_clock::now();
    auto next = start;
    servo.start();
    std::vector<Eigen::Vector3d> forces(pointers.size());
    while (!interactor->GetDone() && (o.frames == 0 || frames < o.frames) &&
           std::chrono::steady_clock::now() - start < std::chrono::duration<double>(o.seconds)) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      engine.deformation_step(elapsed);
      engine.surfaces().update();
      scene.show_surface(engine.surfaces().read());
      for (std::size_t i = 0; i < pointers.size(); ++i) {
        ToolPose pose;
        // Drawing only: the device reports the pose the servo last read.
        const bool seen = rig.devices[i]->last_pose(pose);
        forces[i] = rig.devices[i]->last_force();
        scene.show_tool(i, seen && !o.hide_tools, pose, forces[i], forces[i].norm() > 0.0);
      }
      if (!o.hide_tools)
        scene.show_text(overlay(forces, std::vector<bool>(pointers.size(), true), servo.ticks() / std::max(elapsed, 1e-3),
                                frames / std::max(elapsed, 1e-3), false));
      scene.next_background_frame();
      scene.render();
      interactor->ProcessEvents();
      ++frames;
      if (!o.record_path.empty()) recorder.add(scene.capture());
      next += std::chrono::microseconds(16667);
      std::this_thread::sleep_until(next);
    }
    servo.stop();
  } else {
    // Mouse and keyboard tools, with the loops on their threads in real time.
    std::vector<MouseTool> tools(kMouseTools);
    std::vector<HapticDevice*> pointers;
    for (MouseTool& t : tools) pointers.push_back(&t);
    Engine engine(organ, pointers, {});
    vtkNew<vtkRenderWindowInteractor> interactor;
    vtkNew<ToolStyle> style;
    style->tools = &tools;
    style->poses.assign(kMouseTools, ToolPose{});
    style->present.assign(kMouseTools, false);
    style->scene = &scene;
    interactor->SetInteractorStyle(style);
    interactor->SetRenderWindow(scene.window());
    interactor->Initialize();
    std::vector<Eigen::Vector3d> forces(kMouseTools);
    const auto start = std::chrono::steady_clock::now();
    run_realtime(engine, o.seconds, [&] {
      interactor->ProcessEvents();
      if (interactor->GetDone() || (o.frames > 0 && frames >= o.frames)) return false;
      if (!engine.surfaces().update()) return true;
      scene.show_surface(engine.surfaces().read());
      for (std::size_t i = 0; i < kMouseTools; ++i) {
        bool touching = false;
        forces[i] = tools[i].last_force(touching);
        scene.show_tool(i, style->present[i] && !o.hide_tools, style->poses[i], forces[i], touching);
      }
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (!o.hide_tools)
        scene.show_text(overlay(forces, style->present, tools[0].ticks() / std::max(elapsed, 1e-3),
                                engine.surfaces().read().frame / std::max(elapsed, 1e-3), true));
      scene.next_background_frame();
      scene.render();
      ++frames;
      if (!o.record_path.empty()) recorder.add(scene.capture());
      return true;
    });
  }

  recorder.finish();
  if (!o.screenshot_path.empty()) {
    scene.render();
    write_png(scene.capture(), o.screenshot_path);
  }
  if (o.json) {
    nlohmann::json j{{"model", o.model_path},
                     {"frames", frames},
                     {"tools", tools_json},
                     {"warnings", warnings},
                     {"size", {o.size[0], o.size[1]}}};
    if (!o.screenshot_path.empty()) j["screenshot"] = o.screenshot_path;
    if (!o.record_path.empty()) j["record"] = {{"path", o.record_path}, {"frames", recorder.count()}};
    std::cout << j.dump() << '\n';
  } else {
    std::cout << fmt::format("{:<12}{} frames drawn{}{}\n", "view", frames,
                             o.screenshot_path.empty() ? "" : ", screenshot " + o.screenshot_path,
                             o.record_path.empty() ? "" : fmt::format(", recording {} ({} frames)", o.record_path, recorder.count()));
  }
  return 0;
}

}  // namespace

Command add_view_command(CLI::App& app) {
  auto o = std::make_shared<ViewOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  app.add_option("--session", o->session_path, "Replay this session with scripted tools (default: mouse tools)");
  app.add_option("--background", o->background_path, "Laparoscopic background: an image or a video (looped)");
  app.add_option("--texture", o->texture_path, "Organ texture image (default: a procedural liver texture)");
  app.add_option("--screenshot", o->screenshot_path, "Write a PNG of the last frame");
  app.add_option("--record", o->record_path, "Record every frame into a Motion-JPEG AVI");
  app.add_flag("--offscreen", o->offscreen, "Render without a window (works under Xvfb)");
  app.add_option("--frames", o->frames, "Stop after this many frames")->check(CLI::NonNegativeNumber);
  app.add_option("--seconds", o->seconds, "With mouse tools: stop after this long")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--size", o->size, "Window size WIDTH,HEIGHT in pixels")->delimiter(',')->expected(2)->capture_default_str();
  app.add_flag("--hide-tools", o->hide_tools, "Draw the organ alone: no instruments, arrows or text");
  app.add_flag("--json", o->json, "Print a summary as one JSON object on stdout");
  app.add_flag("--phantom", o->phantom, "Tools are PHANToM / Touch devices (OpenHaptics, loaded at run time)");
  o->rig.add_to(app);
  return [o] { return run_view(*o); };
}

}  // namespace organsim::cli
