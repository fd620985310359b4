// `organsim view`: screenshots, recordings, backgrounds, mouse tools and
// PHANToM devices, under a virtual X server.
#include <gtest/gtest.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <array>
#include <fstream>
#include <sstream>
#include <string>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

// Runs organsim under a virtual X server (the viewer renders with OpenGL).
CommandRun run_viewer(const std::string& arguments, const fs::path& dir) {
  return run_organsim_with_prefix("xvfb-run -a -s '-screen 0 1280x1024x24' ", arguments, dir);
}

// A cylinder (helper model, axis x, radius 30 mm, clamped at x = 0) pressed by
// two tools 10 mm down into its top (+z, the top of the viewer's default
// picture) at x = 60 and 130 mm, and held.
fs::path write_press_session(const fs::path& dir) {
  const fs::path session = dir / "press.session";
  std::ofstream out(session);
  out << "# organsim session 1\n0,1,60,0,50\n0.4,1,60,0,20\n1.0,1,60,0,20\n"
         "0,2,130,0,50\n0.4,2,130,0,20\n1.0,2,130,0,20\n";
  return session;
}

TEST_F(Cli, ViewScreenshotShowsTheOrganMovedWhereTheToolsPushed) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string session = write_press_session(dir_).string();
  const fs::path rest = dir_ / "rest.png", pushed = dir_ / "pushed.png";
  const CommandRun first = run_viewer(
      "view " + model + " --session " + session + " --offscreen --hide-tools --frames 1 --screenshot " + rest.string(),
      dir_);
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const CommandRun last = run_viewer(
      "view " + model + " --session " + session + " --offscreen --hide-tools --json --screenshot " + pushed.string(),
      dir_);
  ASSERT_EQ(last.exit_code, 0) << last.err;
  const nlohmann::json j = nlohmann::json::parse(last.out);
  EXPECT_EQ(j["frames"], 61);
  std::array<Eigen::Vector2d, 2> tip;
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(j["tools"][k]["contacts"], 1);
    tip[k] = {j["tools"][k]["tip_px"][0].get<double>(), j["tools"][k]["tip_px"][1].get<double>()};
  }
  // A control spot on the organ near the clamped end (x ≈ 5 mm), where
  // neither tool's press reaches much: pixels per metre from the two tips.
  const double pixels_per_metre = (tip[1][0] - tip[0][0]) / 0.07;
  const Eigen::Vector2d clamp(tip[0][0] - 0.055 * pixels_per_metre, tip[0][1]);

  const cv::Mat a = cv::imread(rest.string()), b = cv::imread(pushed.string());
  ASSERT_FALSE(a.empty());
  ASSERT_EQ(a.size(), b.size());
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
  long changed = 0, near_clamp = 0;
  std::array<long, 2> near_tool{};
  for (int r = 0; r < difference.rows; ++r)
    for (int c = 0; c < difference.cols; ++c)
      if (difference.at<unsigned char>(r, c) > 20) {
        ++changed;
        const Eigen::Vector2d pixel(c, r);
        for (int k = 0; k < 2; ++k) near_tool[k] += (pixel - tip[k]).norm() < 80.0;
        near_clamp += (pixel - clamp).norm() < 80.0;
      }
  ASSERT_GT(changed, 300) << "the organ did not move on screen";
  for (int k = 0; k < 2; ++k) {
    EXPECT_GT(near_tool[k], 1000) << "around tool " << k + 1 << " the picture changed little";
    EXPECT_GT(near_tool[k], 3 * near_clamp)
        << near_tool[k] << " changed pixels near tool " << k + 1 << ", " << near_clamp << " near the clamp";
  }
}

// A grasper closes its jaws on the cylinder's top and lifts it 5 mm while a
// probe presses beside it: the viewer draws the grasper's tip green (closed
// jaws holding the organ; the liver texture has no green), and its JSON says
// which jaws are closed.
// --show-supports marks where the organ rests (blue) and is attached
// (orange): on a cylinder resting on its lower half, the marks are counted,
// and the picture holds blue pixels that the same view without them lacks.
TEST_F(Cli, ViewShowsTheSupportsWhereTheOrganRests) {
  model::OrganModel resting = testing::make_cylinder_model({});
  std::size_t supported = 0;
  for (const model::Point3& v : resting.surface_vertices) {
    const bool below = v[2] < -0.01;
    resting.supports.vertices.push_back(below ? std::array<double, 2>{1.0, 2.5e5} : std::array<double, 2>{0.0, 0.0});
    supported += below;
  }
  const std::string model = (dir_ / "resting.organ").string();
  model::write_organ_model_file(resting, model);
  const fs::path with = dir_ / "supports.png", without = dir_ / "plain.png";
  const CommandRun run = run_viewer(
      "view " + model + " --offscreen --frames 1 --show-supports --json --screenshot " + with.string(), dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(nlohmann::json::parse(run.out)["supported_vertices"].get<std::size_t>(), supported);
  ASSERT_EQ(run_viewer("view " + model + " --offscreen --frames 1 --screenshot " + without.string(), dir_).exit_code,
            0);
  const auto blue_pixels = [](const cv::Mat& image) {
    int count = 0;
    for (int r = 0; r < image.rows; ++r)
      for (int c = 0; c < image.cols; ++c) {
        const cv::Vec3b bgr = image.at<cv::Vec3b>(r, c);
        count += bgr[0] > 150 && bgr[0] > bgr[2] + 80 && bgr[0] > bgr[1] + 40;
      }
    return count;
  };
  const int marked = blue_pixels(cv::imread(with.string())), plain = blue_pixels(cv::imread(without.string()));
  EXPECT_GT(marked, plain + 50) << marked << " blue pixels with the supports, " << plain << " without";
}

TEST_F(Cli, ViewShowsClosedJawsHoldingTheOrgan) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const fs::path session = dir_ / "grasp.session", picture = dir_ / "grasp.png";
  std::ofstream(session) << "# organsim session 3\njaw,1,0.4,closed\n"
                            "0,1,80,0,50\n0.3,1,80,0,27\n0.45,1,80,0,27\n0.8,1,80,0,35\n1.0,1,80,0,35\n"
                            "0,2,130,0,50\n0.4,2,130,0,25\n1.0,2,130,0,25\n";
  const CommandRun run = run_viewer(
      "view " + model + " --session " + session.string() + " --offscreen --json --screenshot " + picture.string(),
      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["tools"][0]["grasps"], 1);
  EXPECT_TRUE(j["tools"][0]["jaws_closed"].get<bool>());
  EXPECT_EQ(j["tools"][1]["grasps"], 0);
  EXPECT_FALSE(j["tools"][1]["jaws_closed"].get<bool>());
  const cv::Mat image = cv::imread(picture.string());
  ASSERT_FALSE(image.empty());
  // The tip's colour: the most saturated pixel within 4 pixels of where it appears.
  const auto tip_colour = [&](int tool) {  // BGR
    const double x = j["tools"][tool]["tip_px"][0].get<double>(), y = j["tools"][tool]["tip_px"][1].get<double>();
    cv::Vec3b best(0, 0, 0);
    int best_spread = -1;
    for (int r = static_cast<int>(y) - 4; r <= static_cast<int>(y) + 4; ++r)
      for (int c = static_cast<int>(x) - 4; c <= static_cast<int>(x) + 4; ++c) {
        if (r < 0 || c < 0 || r >= image.rows || c >= image.cols) continue;
        const cv::Vec3b bgr = image.at<cv::Vec3b>(r, c);
        const int spread = std::max({bgr[0], bgr[1], bgr[2]}) - std::min({bgr[0], bgr[1], bgr[2]});
        if (spread > best_spread) best_spread = spread, best = bgr;
      }
    return best;
  };
  const cv::Vec3b grasper = tip_colour(0);
  EXPECT_GT(grasper[1], grasper[2] + 40) << "the grasper's tip is green (BGR " << grasper << ")";
  EXPECT_GT(grasper[1], grasper[0] + 40) << "BGR " << grasper;
  // The patch the jaws hold is marked on the organ; the probe holds none.
  EXPECT_GE(j["tools"][0]["held_vertices"].get<int>(), 1);
  EXPECT_EQ(j["tools"][1]["held_vertices"].get<int>(), 0);
  // Drawn without the instruments, the marks are the only green near the grasper.
  const fs::path organ_alone = dir_ / "grasp_organ.png";
  const CommandRun bare = run_viewer("view " + model + " --session " + session.string() +
                                         " --offscreen --hide-tools --screenshot " + organ_alone.string(),
                                     dir_);
  ASSERT_EQ(bare.exit_code, 0) << bare.err;
  const cv::Mat organ = cv::imread(organ_alone.string());
  ASSERT_FALSE(organ.empty());
  const auto green_near = [&](int tool) {
    const int x = static_cast<int>(j["tools"][tool]["tip_px"][0].get<double>());
    const int y = static_cast<int>(j["tools"][tool]["tip_px"][1].get<double>());
    int count = 0;
    for (int r = std::max(0, y - 40); r < std::min(organ.rows, y + 40); ++r)
      for (int c = std::max(0, x - 40); c < std::min(organ.cols, x + 40); ++c) {
        const cv::Vec3b bgr = organ.at<cv::Vec3b>(r, c);
        if (bgr[1] > bgr[2] + 60 && bgr[1] > bgr[0] + 40) ++count;
      }
    return count;
  };
  EXPECT_GT(green_near(0), 4) << "the held patch is drawn";
  EXPECT_EQ(green_near(1), 0) << "no patch where a probe presses";
}

// The disk fills during the recording (a file-size limit stands in; OpenCV's
// writer does not report it): one line naming the recording, and no video.
TEST_F(Cli, ViewRecordingOnAFullDiskFailsWithOneLineAndLeavesNoVideo) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string session = write_press_session(dir_).string();
  const fs::path video = dir_ / "session.avi";
  // The limit on organsim alone (xvfb-run's own files stay unlimited), and
  // organsim's exit code kept beside the test's directory: xvfb-run now and
  // then fails to clean up its own temporary directory (exit 5, a line on
  // stderr) when several virtual displays come and go at once.
  const fs::path exit_code = dir_.string() + ".exit";
  CommandRun run = run_organsim_with_prefix(
      "xvfb-run -a -s '-screen 0 1280x1024x24' sh -c 'ulimit -f 200; \"$0\" \"$@\"; echo $? > " + exit_code.string() +
          "' ",
      "view " + model + " --session " + session + " --offscreen --record " + video.string(), dir_);
  std::ifstream(exit_code) >> run.exit_code;
  fs::remove(exit_code);
  std::string own, line;
  for (std::istringstream lines(run.err); std::getline(lines, line);)
    if (line.rfind("xvfb-run: ", 0) != 0) own += line + "\n";
  run.err = own;
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("cannot write the recording '" + video.string() + "'"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("frames reached the file"), std::string::npos) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_FALSE(fs::exists(video));
  EXPECT_EQ(files_in_dir(), 2u);  // the model and the session
}

TEST_F(Cli, ViewRecordsEveryFrameAndStartsWithoutABrokenBackground) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string session = write_press_session(dir_).string();
  const fs::path video = dir_ / "session.avi", shot = dir_ / "shot.png";
  const CommandRun run =
      run_viewer("view " + model + " --session " + session + " --offscreen --frames 30 --record " + video.string() +
                     " --background " + (dir_ / "missing.png").string() + " --screenshot " + shot.string(),
                 dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("warning"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("missing.png does not exist"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("starting without a background"), std::string::npos) << run.err;
  EXPECT_TRUE(fs::exists(shot));
  // An unreadable background (not an image, not a video) is the same: a warning.
  const fs::path garbage = dir_ / "garbage.png";
  std::ofstream(garbage) << "not an image";
  const CommandRun unreadable = run_viewer(
      "view " + model + " --session " + session + " --offscreen --frames 2 " + "--background " + garbage.string(),
      dir_);
  ASSERT_EQ(unreadable.exit_code, 0) << unreadable.err;
  EXPECT_NE(unreadable.err.find("neither an image nor a video"), std::string::npos) << unreadable.err;
  cv::VideoCapture capture(video.string());
  ASSERT_TRUE(capture.isOpened());
  int frames = 0;
  cv::Mat frame;
  while (capture.read(frame)) ++frames;
  EXPECT_EQ(frames, 30);
  EXPECT_EQ(frame.empty() ? 0 : frame.cols, 0);  // read past the end
  // A background that is an image is drawn behind the organ.
  const fs::path backdrop = dir_ / "backdrop.png";
  cv::imwrite(backdrop.string(), cv::Mat(120, 160, CV_8UC3, cv::Scalar(0, 200, 0)));
  const fs::path green = dir_ / "green.png";
  const CommandRun with =
      run_viewer("view " + model + " --session " + session + " --offscreen --frames 1 --background " +
                     backdrop.string() + " --screenshot " + green.string(),
                 dir_);
  ASSERT_EQ(with.exit_code, 0) << with.err;
  const cv::Mat picture = cv::imread(green.string());
  const cv::Vec3b corner = picture.at<cv::Vec3b>(5, 5);
  EXPECT_GT(corner[1], 150);  // green backdrop in the corner
  EXPECT_LT(corner[2], 60);
}

TEST_F(Cli, ViewRunsMouseToolsAndPhantomDevicesInRealTime) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  // Mouse tools: a window (under Xvfb) with the loops on their threads.
  const CommandRun mouse = run_viewer("view " + model + " --frames 20 --json", dir_);
  ASSERT_EQ(mouse.exit_code, 0) << mouse.err;
  EXPECT_EQ(nlohmann::json::parse(mouse.out)["frames"], 20);
  // PHANToM devices from the HD library (here the stand-in): the servo drives the force loop.
  const CommandRun phantom = run_viewer(
      "view " + model + " --phantom --hd-library " + std::string(FAKE_HD_LIBRARY) + " --frames 20 --json", dir_);
  ASSERT_EQ(phantom.exit_code, 0) << phantom.err;
  EXPECT_EQ(nlohmann::json::parse(phantom.out)["frames"], 20);
  const CommandRun missing =
      run_viewer("view " + model + " --phantom --hd-library /nonexistent/libHD.so --frames 2", dir_);
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("cannot load the OpenHaptics HD library"), std::string::npos) << missing.err;
}

// --session --realtime: the loops on their threads in real time and each new
// surface drawn; the timings of the whole chain are reported, and the tools
// still press the organ (both tools' forces reach the drawing).
TEST_F(Cli, ViewPlaysASessionInRealTimeAndTimesTheWholeChain) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string session = write_press_session(dir_).string();
  const CommandRun run = run_viewer("view " + model + " --session " + session + " --realtime --offscreen --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  const nlohmann::json& t = j["timing"];
  // One second of session: about 1,000 force ticks and 60 frames, whatever
  // the machine. How many of them are drawn depends on the machine's load
  // (software OpenGL shares the cores with the loops), so only a drawing is
  // required here; the drawing rate is measured in docs/performance.md.
  EXPECT_GT(t["force_ticks"].get<double>(), 900.0);
  EXPECT_LT(t["force_ticks"].get<double>(), 1100.0);
  EXPECT_GT(t["deformation_frames"].get<double>() + t["frames_dropped"].get<double>(), 50.0);
  EXPECT_GE(t["frames_drawn"].get<double>(), 1.0);
  EXPECT_EQ(j["frames"].get<double>(), t["frames_drawn"].get<double>());
  EXPECT_GT(t["force_period_p50_ms"].get<double>(), 0.9);
  EXPECT_LT(t["force_period_p50_ms"].get<double>(), 1.1);
  EXPECT_GT(t["draw_p50_ms"].get<double>(), 0.0);
  EXPECT_NE(run.out.find("\"force_n\""), std::string::npos);
  for (int k = 0; k < 2; ++k) EXPECT_GT(j["tools"][k]["force_n"].get<double>(), 0.0) << "tool " << k + 1;
  const CommandRun alone = run_viewer("view " + model + " --realtime --frames 2", dir_);
  EXPECT_EQ(alone.exit_code, 2);
  EXPECT_NE(alone.err.find("--realtime"), std::string::npos) << alone.err;
}

// --report in each of the viewer's three modes: a page and metrics with one
// entry per tool; the scripted session's two presses are seen in contact.
TEST_F(Cli, ViewWritesATrainingReportInEveryMode) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string session = write_press_session(dir_).string();
  const struct {
    std::string name, arguments;
    std::size_t tools;
  } modes[] = {{"session", "--session " + session + " --offscreen", 2},
               {"mouse", "--frames 20", 4},
               {"phantom", "--phantom --hd-library " + std::string(FAKE_HD_LIBRARY) + " --frames 20", 1}};
  for (const auto& mode : modes) {
    const fs::path report = dir_ / ("report_" + mode.name);
    const CommandRun run =
        run_viewer("view " + model + " " + mode.arguments + " --json --report " + report.string(), dir_);
    ASSERT_EQ(run.exit_code, 0) << mode.name << ": " << run.err;
    EXPECT_EQ(nlohmann::json::parse(run.out)["report"], report.string() + "/index.html") << mode.name;
    ASSERT_TRUE(fs::exists(report / "index.html")) << mode.name;
    std::ifstream in(report / "metrics.json");
    const nlohmann::json metrics = nlohmann::json::parse(in);
    ASSERT_EQ(metrics["tools"].size(), mode.tools) << mode.name;
    EXPECT_GT(metrics["duration_s"].get<double>(), 0.0) << mode.name;
    if (mode.name == "session")
      for (const auto& tool : metrics["tools"]) {
        // The 2.5 mm tip meets the top (z = 30 mm) at z = 32.5 mm, 0.4 × 17.5 / 30 = 0.233 s
        // in, and stays to the end at 1 s; contacts start on the next 60 Hz frame.
        EXPECT_NEAR(tool["time_in_contact_s"].get<double>(), 1.0 - 0.233, 1.0 / 60.0 + 0.035);
        EXPECT_GT(tool["peak_force_n"].get<double>(), 0.0);
      }
  }
}

}  // namespace
}  // namespace organsim
