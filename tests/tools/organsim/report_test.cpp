// `replay --report` and `organsim report`: a training report's metrics on a
// session whose answers are known by hand, the page's shape (self-contained,
// no URL, no patient data), loop-health warnings and a reference run.
#include <gtest/gtest.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <vtkBase64Utilities.h>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), {}};
}

nlohmann::json read_json(const fs::path& path) { return nlohmann::json::parse(read_text(path)); }

/// The helper cylinder (radius 30 mm, 150 mm along x, clamped at x = 0) in a
/// file whose name looks like a patient's, and a one-tool session: the point
/// tool reaches the far cap (x = 150 mm) at 0.1 s, is 4 mm in at 0.2 s, holds
/// until 1.2 s, is back at the cap at 1.3 s and away at 1.4 s.
struct KnownPress {
  std::string model, session;
  static constexpr double kContact = 1.2, kDepthMm = 4.0, kPathMm = 2 * 14.0;
};

KnownPress write_known_press(const fs::path& dir) {
  KnownPress p;
  p.model = (dir / "DOE^JANE_1234.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), p.model);
  p.session = (dir / "DOE^JANE_press.session").string();
  std::ofstream out(p.session);
  out << "# organsim session 1\n"
         "0,1,160,0,0\n0.1,1,150,0,0\n0.2,1,146,0,0\n1.2,1,146,0,0\n1.3,1,150,0,0\n1.4,1,160,0,0\n";
  return p;
}

TEST_F(Cli, ReportMetricsAreTheHandWorkedOnesOfAKnownPress) {
  const KnownPress press = write_known_press(dir_);
  const fs::path report = dir_ / "report", forces = dir_ / "forces.csv";
  const CommandRun replay = run_organsim("replay " + press.model + " " + press.session +
                                             " --fast --tip-radius 0 --force-limit 1000 --forces " + forces.string() +
                                             " --report " + report.string(),
                                         dir_);
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  for (const char* file : {"index.html", "metrics.json", "ticks.csv", "frames.csv", "surface.csv", "run.json"})
    EXPECT_TRUE(fs::exists(report / file)) << file;
  nlohmann::json m = read_json(report / "metrics.json");
  EXPECT_DOUBLE_EQ(m["duration_s"].get<double>(), 1.4);
  EXPECT_DOUBLE_EQ(m["force_limit_n"].get<double>(), 1000.0);
  ASSERT_EQ(m["tools"].size(), 1u);
  const nlohmann::json& tool = m["tools"][0];
  EXPECT_EQ(tool["tool"], 1);
  // Contacts begin and end on deformation frames (60 Hz): within a frame.
  EXPECT_NEAR(tool["time_in_contact_s"].get<double>(), KnownPress::kContact, 1.0 / 60.0 + 2e-3);
  EXPECT_NEAR(tool["peak_depth_mm"].get<double>(), KnownPress::kDepthMm, 0.05);
  EXPECT_NEAR(tool["path_length_mm"].get<double>(), KnownPress::kPathMm, 1e-3);
  EXPECT_NEAR(tool["mean_speed_mm_s"].get<double>(), KnownPress::kPathMm / 1.4, 1e-3);
  EXPECT_EQ(tool["events_above_limit"], 0);
  EXPECT_EQ(tool["time_above_limit_s"].get<double>(), 0.0);
  // peak_force_n is the largest force the device received: the forces CSV's.
  double largest = 0.0;
  std::ifstream csv(forces);
  std::string line;
  std::getline(csv, line);
  while (std::getline(csv, line)) {
    double t, fx, fy, fz;
    int id, contact;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%d,%lf,%lf,%lf,%d", &t, &id, &fx, &fy, &fz, &contact), 6);
    largest = std::max(largest, std::sqrt(fx * fx + fy * fy + fz * fz));
  }
  const double peak = tool["peak_force_n"].get<double>();
  EXPECT_NEAR(peak, largest, 1e-8 * largest);
  EXPECT_GT(peak, 0.0);

  // Rebuilt with the limit at half the held force: the multi-beam force is
  // linear in the depth, so it is above the limit from half the way in (0.15 s)
  // to half the way out (1.25 s): one event of 1.1 s.
  const CommandRun rebuilt = run_organsim(fmt::format("report {} --force-limit {}", report.string(), peak / 2), dir_);
  ASSERT_EQ(rebuilt.exit_code, 0) << rebuilt.err;
  m = read_json(report / "metrics.json");
  const nlohmann::json& again = m["tools"][0];
  EXPECT_EQ(again["events_above_limit"], 1);
  EXPECT_NEAR(again["time_above_limit_s"].get<double>(), 1.1, 1.0 / 60.0 + 2e-3);
  EXPECT_NEAR(again["events"][0]["start_s"].get<double>(), 0.15, 1.0 / 60.0 + 2e-3);
  EXPECT_NEAR(again["events"][0]["duration_s"].get<double>(), 1.1, 1.0 / 60.0 + 2e-3);
  EXPECT_NEAR(again["events"][0]["where_mm"][0].get<double>(), 146.0, 0.05);  // at the deepest point
  EXPECT_DOUBLE_EQ(again["peak_force_n"].get<double>(), peak);                // the limit changes no force
}

// A grasper presses the cylinder's side 3 mm, closes its jaws at 0.4 s, lifts
// the side 5 mm above rest and lets go at 1.1 s: the report lists one grasp
// per hold, where the jaws closed and how it ended; held harder than
// --grasp-limit allows, it slips. A run recorded before the jaw columns existed
// (12 values per tick) still makes a report, without grasps.
TEST_F(Cli, ReportListsEachGraspAndHowItEnded) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string session = (dir_ / "grasp.session").string();
  std::ofstream(session) << "# organsim session 3\njaw,1,0.4,closed\njaw,1,1.1,open\n"
                            "0,1,80,45,0\n0.3,1,80,27,0\n0.45,1,80,27,0\n0.8,1,80,35,0\n1.2,1,80,35,0\n1.4,1,80,50,0\n";
  const fs::path report = dir_ / "report";
  const CommandRun replay =
      run_organsim("replay " + model + " " + session + " --fast --report " + report.string(), dir_);
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  const nlohmann::json tool = read_json(report / "metrics.json")["tools"][0];
  ASSERT_EQ(tool["grasps"].size(), 1u);
  const nlohmann::json& grasp = tool["grasps"][0];
  EXPECT_NEAR(grasp["start_s"].get<double>(), 0.4, 2e-3);
  EXPECT_NEAR(grasp["duration_s"].get<double>(), 0.7, 2e-3);
  EXPECT_NEAR(grasp["where_mm"][1].get<double>(), 27.0, 0.05);
  EXPECT_GT(grasp["peak_model_force_n"].get<double>(), 0.0);
  EXPECT_FALSE(grasp["slipped"].get<bool>());
  EXPECT_EQ(tool["grasp_slips"], 0);
  EXPECT_NE(read_text(report / "index.html").find("the jaws let go"), std::string::npos);
  EXPECT_NE(read_text(report / "index.html").find("<title>grasp</title>"), std::string::npos)
      << "the grasp is shaded on the force chart";

  // Held harder than --grasp-limit allows, the tissue slips out of the jaws.
  const fs::path slipped = dir_ / "slipped";
  const CommandRun weak = run_organsim(
      "replay " + model + " " + session + " --fast --json --grasp-limit 0.005 --report " + slipped.string(), dir_);
  ASSERT_EQ(weak.exit_code, 0) << weak.err;
  EXPECT_EQ(nlohmann::json::parse(weak.out)["tools"][0]["grasp_slips"], 1);
  const nlohmann::json weak_tool = read_json(slipped / "metrics.json")["tools"][0];
  ASSERT_EQ(weak_tool["grasps"].size(), 1u);
  EXPECT_TRUE(weak_tool["grasps"][0]["slipped"].get<bool>());
  EXPECT_EQ(weak_tool["grasp_slips"], 1);
  EXPECT_NE(read_text(slipped / "index.html").find("the tissue slipped out of the jaws"), std::string::npos);
  EXPECT_NE(read_text(slipped / "index.html").find("<title>grasp that slipped</title>"), std::string::npos);

  // The ticks without the jaw columns, as an older run wrote them.
  std::istringstream ticks(read_text(report / "ticks.csv"));
  std::ostringstream older;
  for (std::string line; std::getline(ticks, line);) {
    std::size_t cut = line.size();
    for (int k = 0; k < 3; ++k) cut = line.rfind(',', cut - 1);
    older << line.substr(0, cut) << '\n';
  }
  std::ofstream(report / "ticks.csv") << older.str();
  const CommandRun rebuilt = run_organsim("report " + report.string(), dir_);
  ASSERT_EQ(rebuilt.exit_code, 0) << rebuilt.err;
  EXPECT_TRUE(read_json(report / "metrics.json")["tools"][0]["grasps"].empty());
}

// The limit is judged on the force the model computed, before the device's
// clamp: a clamp below the limit still lets the page see the force go past
// it, while the force sent stays at the clamp. A rebuild without
// --force-limit keeps the limit the page was made with.
TEST_F(Cli, ReportJudgesTheLimitOnTheModelsForceBeforeTheDevicesClamp) {
  const KnownPress press = write_known_press(dir_);
  const fs::path free_run = dir_ / "free", clamped = dir_ / "clamped";
  ASSERT_EQ(run_organsim("replay " + press.model + " " + press.session + " --fast --tip-radius 0 --force-limit 1000 " +
                             "--report " + free_run.string(),
                         dir_)
                .exit_code,
            0);
  const double peak = read_json(free_run / "metrics.json")["tools"][0]["peak_force_n"].get<double>();
  ASSERT_GT(peak, 0.0);
  const CommandRun replay =
      run_organsim(fmt::format("replay {} {} --fast --tip-radius 0 --max-force {} --force-limit {} --report {}",
                               press.model, press.session, peak / 4, peak / 2, clamped.string()),
                   dir_);
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  const auto check = [&](const nlohmann::json& tool) {
    EXPECT_LE(tool["peak_force_n"].get<double>(), peak / 4 * (1 + 1e-9)) << "the device got no more than its clamp";
    EXPECT_NEAR(tool["peak_model_force_n"].get<double>(), peak, 1e-6 * peak);
    EXPECT_EQ(tool["events_above_limit"], 1) << "the model's force passed the limit above the clamp";
    EXPECT_NEAR(tool["time_above_limit_s"].get<double>(), 1.1, 1.0 / 60.0 + 2e-3);
  };
  nlohmann::json m = read_json(clamped / "metrics.json");
  EXPECT_DOUBLE_EQ(m["force_limit_n"].get<double>(), peak / 2);
  check(m["tools"][0]);

  const CommandRun rebuilt = run_organsim("report " + clamped.string(), dir_);
  ASSERT_EQ(rebuilt.exit_code, 0) << rebuilt.err;
  m = read_json(clamped / "metrics.json");
  EXPECT_DOUBLE_EQ(m["force_limit_n"].get<double>(), peak / 2) << "the limit the page was made with";
  check(m["tools"][0]);
}

// `replay --model a,b --report DIR`: one report per model in DIR/<model>/
// (a FEM model among them: every model reports), and `organsim report DIR`
// rebuilds them all.
TEST_F(Cli, ReplayOfSeveralModelsWritesAReportPerModelThatReportRebuildsAll) {
  const KnownPress press = write_known_press(dir_);
  const fs::path report = dir_ / "report";
  const CommandRun replay =
      run_organsim("replay " + press.model + " " + press.session +
                       " --fast --tip-radius 0 --fixed-radius 31 --model beam,springs,psh --report " + report.string(),
                   dir_);
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  EXPECT_FALSE(fs::exists(report / "index.html"));
  for (const char* model : {"beam", "springs", "psh"}) {
    ASSERT_TRUE(fs::exists(report / model / "index.html")) << model;
    const nlohmann::json m = read_json(report / model / "metrics.json");
    EXPECT_EQ(m["deformation_model"], model);
    EXPECT_DOUBLE_EQ(m["duration_s"].get<double>(), 1.4);
    EXPECT_GT(m["tools"][0]["peak_force_n"].get<double>(), 0.0) << model;
  }
  const CommandRun rebuilt = run_organsim("report " + report.string() + " --force-limit 0.001", dir_);
  ASSERT_EQ(rebuilt.exit_code, 0) << rebuilt.err;
  for (const char* model : {"beam", "springs", "psh"}) {
    EXPECT_NE(rebuilt.out.find((report / model / "index.html").string()), std::string::npos) << rebuilt.out;
    const nlohmann::json m = read_json(report / model / "metrics.json");
    EXPECT_DOUBLE_EQ(m["force_limit_n"].get<double>(), 0.001) << model;
    EXPECT_EQ(m["tools"][0]["events_above_limit"], 1) << model;
  }
}

TEST_F(Cli, ReportPageIsSelfContainedAndHoldsNoPatientData) {
  const KnownPress press = write_known_press(dir_);
  const fs::path report = dir_ / "report";
  // No display at all: the organ's pictures need none.
  ASSERT_EQ(run_organsim_with_prefix(
                "env -u DISPLAY ",
                "replay " + press.model + " " + press.session + " --fast --report " + report.string(), dir_)
                .exit_code,
            0);
  const std::string html = read_text(report / "index.html");
  EXPECT_NE(html.find("<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src "
                      "'unsafe-inline'; img-src data:\">"),
            std::string::npos);
  for (const char* url : {"http:", "https:", "=\"//", "='//", "url(", "<script", "<link"})
    EXPECT_EQ(html.find(url), std::string::npos) << url;
  // The answer first: a plain summary before any chart, the engineering detail last.
  const std::size_t summary = html.find("<h2>Summary</h2>"), first_chart = html.find("<svg"),
                    detail = html.find("<h2>Engineering detail</h2>"), health = html.find("<h2>Loop health</h2>");
  ASSERT_NE(summary, std::string::npos);
  EXPECT_LT(summary, first_chart);
  EXPECT_GT(detail, html.rfind("<svg"));
  EXPECT_GT(health, detail);
  const std::string summary_text = html.substr(summary, first_chart - summary);
  EXPECT_NE(summary_text.find("The strongest force: tool 1, "), std::string::npos) << summary_text;
  EXPECT_NE(summary_text.find("No damage"), std::string::npos) << summary_text;
  EXPECT_NE(html.find("@media print"), std::string::npos);
  // Force, depth and speed per tool, and the volume: four charts.
  std::size_t charts = 0;
  for (std::size_t at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1)) ++charts;
  EXPECT_EQ(charts, 4u);
  EXPECT_NE(html.find("<polyline"), std::string::npos);
  // The organ from the front, the right and the top, and face-on where it was
  // pressed deepest: each a picture of the organ on a white page, the last
  // with the pressed place in the indentation's colour (red at the deepest).
  const std::string prefix = "data:image/png;base64,";
  std::size_t pictures = 0;
  int red_in_last = 0;
  cv::Vec3b at_deepest_point;
  for (std::size_t at = html.find(prefix); at != std::string::npos; at = html.find(prefix, at + 1)) {
    ++pictures;
    const std::size_t begin = at + prefix.size(), end = html.find('"', begin);
    const std::string encoded = html.substr(begin, end - begin);
    std::vector<unsigned char> png(encoded.size());
    png.resize(vtkBase64Utilities::DecodeSafely(reinterpret_cast<const unsigned char*>(encoded.data()), encoded.size(),
                                                png.data(), png.size()));
    const cv::Mat image = cv::imdecode(png, cv::IMREAD_COLOR);
    ASSERT_FALSE(image.empty()) << "picture " << pictures;
    EXPECT_EQ(image.cols, 420);
    EXPECT_EQ(image.rows, 380);
    EXPECT_EQ(image.at<cv::Vec3b>(2, 2), cv::Vec3b(255, 255, 255)) << "picture " << pictures;
    const cv::Vec3b middle = image.at<cv::Vec3b>(image.rows / 2, image.cols / 2);
    EXPECT_LT(middle[0] + middle[1] + middle[2], 3 * 250) << "the organ fills the middle: picture " << pictures;
    // metrics.json says where the point pressed deepest lands in each picture.
    const nlohmann::json view = read_json(report / "metrics.json")["pictures"][pictures - 1];
    ASSERT_TRUE(view.contains("deepest_point_pixel")) << view.dump();
    const int x = static_cast<int>(view["deepest_point_pixel"][0].get<double>()),
              y = static_cast<int>(view["deepest_point_pixel"][1].get<double>());
    ASSERT_TRUE(x >= 0 && x < image.cols && y >= 0 && y < image.rows) << view.dump();
    at_deepest_point = image.at<cv::Vec3b>(y, x);
    red_in_last = 0;
    for (int r = 0; r < image.rows; ++r)
      for (int c = 0; c < image.cols; ++c) {
        const cv::Vec3b bgr = image.at<cv::Vec3b>(r, c);
        red_in_last += bgr[2] > bgr[0] + 60 && bgr[2] > bgr[1] + 60;
      }
  }
  EXPECT_EQ(pictures, 4u);
  EXPECT_GT(red_in_last, 20) << "the pressed place, seen face-on, in the deepest indentation's colour";
  EXPECT_GT(at_deepest_point[2], at_deepest_point[0] + 60) << "face-on, the deepest point's pixel is red";
  EXPECT_GT(at_deepest_point[2], at_deepest_point[1] + 60) << "face-on, the deepest point's pixel is red";
  EXPECT_EQ(html.find("not drawn"), std::string::npos);
  // Nothing of the (file-name) patient anywhere in the report's files.
  for (const auto& entry : fs::directory_iterator(report)) {
    const std::string text = read_text(entry.path());
    EXPECT_EQ(text.find("DOE"), std::string::npos) << entry.path();
    EXPECT_EQ(text.find("JANE"), std::string::npos) << entry.path();
  }
  EXPECT_EQ(read_json(report / "run.json")["model_sha256"].get<std::string>().size(), 64u);
}

// Two tools that never touch the organ (100 mm above the cylinder's axis), with
// motions whose measures are worked by hand: tool 1 rests 0.3 s and then
// moves x = c (t − 0.3)³; tool 2 goes 30 mm out along x and 20 mm back.
std::string write_known_motion(const fs::path& dir) {
  const std::string session = (dir / "motion.session").string();
  std::ofstream out(session);
  out << "# organsim session 1\n";
  constexpr double c = 20000.0;  // mm/s³
  for (int k = 0; k <= 50; ++k) {
    const double t = 0.01 * k, tau = std::max(0.0, t - 0.3);
    out << fmt::format("{:.2f},1,{:.9f},100,0\n", t, 40.0 + c * tau * tau * tau);
  }
  out << "0,2,40,100,50\n0.25,2,70,100,50\n0.5,2,50,100,50\n";
  return session;
}

TEST_F(Cli, ReportSkillMeasuresAreTheHandWorkedOnes) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const fs::path report = dir_ / "report";
  const CommandRun replay =
      run_organsim("replay " + model + " " + write_known_motion(dir_) + " --fast --report " + report.string(), dir_);
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  const nlohmann::json m = read_json(report / "metrics.json");
  const nlohmann::json &one = m["tools"][0], &two = m["tools"][1];
  // Tool 1: 160 mm straight (economy 1). Its tip every 10 ms: 28 windows of
  // four samples at rest (jerk 0), then c, 5c and 18 of 6c as the cubic
  // begins: mean squared jerk (1 + 25 + 18 · 36) c² / 48. Idle: the 30
  // intervals at rest and the cubic's first (0.02 mm in 10 ms, under 5 mm/s).
  constexpr double c = 20000.0;
  EXPECT_NEAR(one["path_length_mm"].get<double>(), 160.0, 1e-3);
  EXPECT_NEAR(one["economy_of_motion"].get<double>(), 1.0, 1e-6);
  EXPECT_NEAR(one["mean_squared_jerk_mm2_s6"].get<double>(), 674.0 / 48.0 * c * c, 1e-4 * c * c);
  EXPECT_NEAR(one["idle_time_s"].get<double>(), 0.31, 1e-9);
  // Tool 2: 50 mm travelled for 10 mm from start to end, no contact between.
  EXPECT_NEAR(two["path_length_mm"].get<double>(), 50.0, 1e-3);
  EXPECT_NEAR(two["economy_of_motion"].get<double>(), 10.0 / 50.0, 1e-4);
  EXPECT_NEAR(two["idle_time_s"].get<double>(), 0.0, 1e-9);
  // No touch, no strain: nothing damaged.
  EXPECT_EQ(m["damaged_area_mm2"].get<double>(), 0.0);
  EXPECT_EQ(m["largest_surface_strain"].get<double>(), 0.0);

  // Expert bands: tool 1's path inside, tool 2's economy below its band.
  const fs::path bands = dir_ / "bands.json";
  std::ofstream(bands) << R"({"path_length_mm": [40, 200], "economy_of_motion": [0.6, 1.0], "task_time_s": [0, 1]})";
  ASSERT_EQ(run_organsim("report " + report.string() + " --expert-bands " + bands.string(), dir_).exit_code, 0);
  const nlohmann::json judged = read_json(report / "metrics.json")["proficiency"];
  EXPECT_EQ(judged["measures"], 5);  // the task time, and two measures for each of two tools
  EXPECT_EQ(judged["within"], 4);
  const std::string html = read_text(report / "index.html");
  EXPECT_NE(html.find("Against the expert band: 4 of 5 measures within it (80 %)"), std::string::npos);
  EXPECT_NE(html.find("tool 2: economy of motion 0.2 (below the band 0.6–1)"), std::string::npos);
  std::ofstream(dir_ / "bad.json") << R"({"speed": [0, 1]})";
  const CommandRun bad =
      run_organsim("report " + report.string() + " --expert-bands " + (dir_ / "bad.json").string(), dir_);
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("unknown measure 'speed'"), std::string::npos) << bad.err;
}

// A learning curve of three attempts: three points per measure, the band
// shaded, a table row per attempt; rebuilt from the raw data alone.
TEST_F(Cli, ReportHistoryShowsEachMeasureOverTheAttempts) {
  const KnownPress press = write_known_press(dir_);
  std::vector<std::string> runs;
  for (int k = 1; k <= 3; ++k) {
    const fs::path run = dir_ / "attempts" / fmt::format("attempt_{}", k);
    ASSERT_EQ(run_organsim("replay " + press.model + " " + press.session + " --fast --report " + run.string(), dir_)
                  .exit_code,
              0);
    fs::remove(run / "index.html");
    fs::remove(run / "metrics.json");
    runs.push_back(run.string());
  }
  const fs::path bands = dir_ / "bands.json", page = dir_ / "history.html";
  std::ofstream(bands) << R"({"path_length_mm": [10, 40]})";
  const CommandRun history = run_organsim(
      "report --history " + (dir_ / "attempts").string() + " --expert-bands " + bands.string() + " -o " + page.string(),
      dir_);
  ASSERT_EQ(history.exit_code, 0) << history.err;
  EXPECT_NE(history.out.find("(3 attempts)"), std::string::npos) << history.out;
  const std::string html = read_text(page);
  EXPECT_NE(html.find("<h1>Learning curve</h1>"), std::string::npos);
  EXPECT_NE(html.find("default-src 'none'"), std::string::npos);
  // The path length's chart: three dots, and the expert band.
  const std::size_t path = html.find("<h2>path length of the tip</h2>");
  ASSERT_NE(path, std::string::npos);
  const std::string chart = html.substr(path, html.find("</svg>", path) - path);
  std::size_t dots = 0;
  for (std::size_t at = chart.find("<circle"); at != std::string::npos; at = chart.find("<circle", at + 1)) ++dots;
  EXPECT_EQ(dots, 3u);
  EXPECT_NE(chart.find("<title>expert band</title>"), std::string::npos);
  std::size_t rows = 0;
  for (std::size_t at = html.find("<tr><td>"); at != std::string::npos; at = html.find("<tr><td>", at + 1)) ++rows;
  EXPECT_EQ(rows, 3u);
  // Every measure: three dots on each of its lines (one line per tool, or one for the run).
  std::size_t measures = 0;
  for (std::size_t at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1)) {
    const std::string measure = html.substr(at, html.find("</svg>", at) - at);
    std::size_t lines = 0, points = 0;
    for (std::size_t k = measure.find("<polyline"); k != std::string::npos; k = measure.find("<polyline", k + 1))
      ++lines;
    for (std::size_t k = measure.find("<circle"); k != std::string::npos; k = measure.find("<circle", k + 1)) ++points;
    EXPECT_GE(lines, 1u) << measure.substr(0, 300);
    EXPECT_EQ(points, 3 * lines) << measure.substr(0, 300);
    ++measures;
  }
  EXPECT_GE(measures, 10u) << "task time, path, economy, jerk, idle, force, time above the limit, damage, ...";
}

TEST_F(Cli, ReportSaysWhenTheLoopsFailedAndComparesWithAReferenceRun) {
  const KnownPress press = write_known_press(dir_);
  const fs::path trainee = dir_ / "trainee", expert = dir_ / "expert";
  // The trainee's run in real time: the machine's floor is probed after it, for as long.
  ASSERT_EQ(
      run_organsim("replay " + press.model + " " + press.session + " --report " + trainee.string(), dir_).exit_code, 0);
  const nlohmann::json floor = read_json(trainee / "metrics.json")["loop_health"]["machine_floor"];
  EXPECT_DOUBLE_EQ(floor["probe_s"].get<double>(), 1.4);
  EXPECT_GE(floor["stalls_over_2ms"].get<int>(), 0);
  ASSERT_EQ(
      run_organsim(
          "replay " + press.model + " " + press.session + " --fast --model springs --report " + expert.string(), dir_)
          .exit_code,
      0);
  std::string html = read_text(trainee / "index.html");
  EXPECT_NE(html.find("in a 1.4 s probe after the session"), std::string::npos);
  // A run stepped in session time (--fast) has no deadlines: its page says
  // they were not measured rather than showing a healthy zero.
  const std::string fast_page = read_text(expert / "index.html");
  EXPECT_NE(fast_page.find("<tr><th>force-loop deadline misses (&gt; 2 ms)</th><td>not measured by this command</td>"),
            std::string::npos);
  EXPECT_NE(fast_page.find("<tr><th>deformation frames dropped</th><td>not measured by this command</td>"),
            std::string::npos);
  EXPECT_EQ(html.find("not measured"), std::string::npos) << "a real-time replay measures its loops";
  // Loop trouble is shown only where there was some (a real-time run may miss a deadline).
  nlohmann::json run = read_json(trainee / "run.json");
  EXPECT_EQ(html.find("<td class=\"warn\">") == std::string::npos,
            run["loop_health"]["force_deadline_misses"].get<int>() == 0 && run["loop_health"]["frames_dropped"] == 0);
  // A device that failed and frames that were dropped are reported as such.
  run["loop_health"]["frames_dropped"] = 7;
  run["loop_health"]["pose_faults"] = 2;
  std::ofstream(trainee / "run.json") << run.dump(2);
  const CommandRun rebuilt = run_organsim("report " + trainee.string() + " --reference-run " + expert.string(), dir_);
  ASSERT_EQ(rebuilt.exit_code, 0) << rebuilt.err;
  html = read_text(trainee / "index.html");
  EXPECT_NE(html.find("<td class=\"warn\">7 — the organ's picture lagged the tools</td>"), std::string::npos);
  EXPECT_NE(html.find("<td class=\"warn\">2 — a tool's device stopped giving its pose</td>"), std::string::npos);
  // Both runs, side by side and overlaid.
  EXPECT_NE(html.find("<th>reference</th><th>difference</th>"), std::string::npos);
  EXPECT_NE(html.find("reference: force sent"), std::string::npos);
  EXPECT_NE(html.find("reference run of the springs model"), std::string::npos);
  // The session too: durations, the trainee's dropped frames against the
  // --fast reference's unmeasured ones.
  EXPECT_NE(html.find("<tr><td>duration</td><td>1.40 s</td><td>1.40 s</td><td>+0.00 s</td></tr>"), std::string::npos);
  EXPECT_NE(html.find("<tr><td>deformation frames dropped</td><td>7</td><td>–</td><td>–</td></tr>"), std::string::npos);
  EXPECT_NE(html.find("<tr><td>device faults (lost poses)</td><td>2</td><td>0</td><td>+2</td></tr>"),
            std::string::npos);

  // A directory without a recorded run is a one-line error.
  const CommandRun missing = run_organsim("report " + (dir_ / "nothing").string(), dir_);
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("run.json: missing; was the run recorded with --report?"), std::string::npos)
      << missing.err;
}

}  // namespace
}  // namespace organsim
