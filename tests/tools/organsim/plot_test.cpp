// `organsim plot`: a CSV's columns as a PNG line chart (VTK, off screen under a
// virtual X server), read back with OpenCV; bad CSV files.
#include <gtest/gtest.h>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "cli_fixture.h"

namespace organsim {
namespace {

using namespace cli::testing;

// VTK 9.1 here renders off screen through X only: a virtual X server.
CommandRun run_plot(const std::string& arguments, const fs::path& dir) {
  return run_organsim_with_prefix("xvfb-run -a -s '-screen 0 1280x1024x24' ", "plot " + arguments, dir);
}

/// Pixels of `image` (BGR) within `tolerance` of the colour (r, g, b) in every channel.
int pixels_near(const cv::Mat& image, int r, int g, int b, int tolerance = 40) {
  cv::Mat mask;
  cv::inRange(image, cv::Scalar(std::max(b - tolerance, 0), std::max(g - tolerance, 0), std::max(r - tolerance, 0)),
              cv::Scalar(std::min(b + tolerance, 255), std::min(g + tolerance, 255), std::min(r + tolerance, 255)),
              mask);
  return cv::countNonZero(mask);
}

TEST_F(Cli, PlotDrawsEachColumnAsALineInAPngOfTheAskedSize) {
  const fs::path csv = dir_ / "waves.csv", png = dir_ / "waves.png";
  {
    std::ofstream out(csv);
    // "early" has values in the first 51 rows only: an empty field is a missing value.
    out << "t_s, sine ,cosine,label,early\n";
    for (int i = 0; i <= 200; ++i)
      out << fmt::format("{},{},{},x,{}\n", i * 0.01, std::sin(i * 0.05), 0.5 * std::cos(i * 0.05),
                         i <= 50 ? fmt::format("{}", -0.02 * i) : std::string());
  }
  const CommandRun run = run_plot(
      fmt::format("{} --x t_s --y sine,cosine,early -o {} --title Waves --size 640,400", csv.string(), png.string()),
      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(run.err.empty()) << run.err;
  EXPECT_NE(run.out.find("3 series of up to 201 points"), std::string::npos) << run.out;
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 400);
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  double darkest = 0.0, brightest = 0.0;
  cv::minMaxLoc(grey, &darkest, &brightest);
  EXPECT_GT(brightest - darkest, 100.0) << "the picture is uniform";
  // A white background with the lines in the palette's first three colours (blue, orange, green).
  EXPECT_GT(pixels_near(image, 255, 255, 255, 5), static_cast<int>(image.total() / 2));
  EXPECT_GT(pixels_near(image, 31, 119, 180), 300);
  EXPECT_GT(pixels_near(image, 255, 127, 14), 300);
  EXPECT_GT(pixels_near(image, 44, 160, 44), 100);
  EXPECT_EQ(files_in_dir(), 2u);  // the CSV and the plot, no temporary file
}

// Scaling curves: power laws on log-log axes, each with its fitted exponent
// printed and in its legend; a value a logarithmic axis cannot show is an error.
TEST_F(Cli, PlotOnLogLogAxesFitsEachSeriesExponent) {
  const fs::path csv = dir_ / "scaling.csv", png = dir_ / "scaling.png";
  {
    std::ofstream out(csv);
    out << "vertices,load_s,tick_s,zero\n";
    for (int k = 0; k <= 12; ++k) {
      const double n = 1000.0 * std::pow(10.0, k / 4.0);
      out << fmt::format("{},{},{},{}\n", n, 3e-9 * std::pow(n, 1.5), 2e-7 * std::pow(n, 0.02), k == 5 ? 0.0 : 1.0);
    }
  }
  const CommandRun run = run_plot(
      fmt::format("{} --x vertices --y load_s,tick_s --log-x --log-y -o {}", csv.string(), png.string()), dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("load_s: exponent 1.50"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("tick_s: exponent 0.02"), std::string::npos) << run.out;
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_GT(pixels_near(image, 31, 119, 180), 300);
  EXPECT_GT(pixels_near(image, 255, 127, 14), 300);

  const fs::path bad = dir_ / "bad.png";
  const CommandRun zero =
      run_plot(fmt::format("{} --x vertices --y zero --log-y -o {}", csv.string(), bad.string()), dir_);
  EXPECT_EQ(zero.exit_code, 1);
  EXPECT_NE(zero.err.find("not positive at point 6"), std::string::npos) << zero.err;
  EXPECT_FALSE(fs::exists(bad));
}

TEST_F(Cli, PlotReadsASpringsTrace) {
  const fs::path trace = dir_ / "trace.csv", png = dir_ / "dz.png";
  const CommandRun springs = run_organsim("springs --grid 9x9 --dt 0.002 --steps 40 --trace " + trace.string(), dir_);
  ASSERT_EQ(springs.exit_code, 0) << springs.err;
  const CommandRun run = run_plot(
      fmt::format("{} --x step --y force_vertex_dz_m -o {} --y-label 'dz (m)'", trace.string(), png.string()), dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 800);  // the default size
  EXPECT_EQ(image.rows, 500);
  EXPECT_GT(pixels_near(image, 31, 119, 180), 300);
}

TEST_F(Cli, PlotBadCsvFilesAreOneErrorLineAndLeaveNoPicture) {
  auto write = [this](const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {write("no_column.csv", "t,a\n0,1\n1,2\n"), "no column 'b'"},
      {write("not_a_number.csv", "t,b\n0,1\n1,two\n"), "not_a_number.csv:3: column 'b' is not a finite number: 'two'"},
      {write("not_finite.csv", "t,b\n0,nan\n"), "not_finite.csv:2: column 'b' is not a finite number"},
      {write("no_rows.csv", "t,b\n"), "has a header but no data rows"},
      {write("no_values.csv", "t,b,c\n0,,1\n1,,2\n"), "column 'b' has no values"},
      {write("empty.csv", ""), "is empty"},
      {write("short_row.csv", "t,b\n0,1\n1\n"), "short_row.csv:3: expected 2 comma-separated fields"},
      {(dir_ / "absent.csv").string(), "cannot open the CSV file"},
  };
  const long inputs = static_cast<long>(files_in_dir());
  for (const auto& [csv, message] : cases) {
    // No X server: these fail before anything is drawn.
    const CommandRun run =
        run_organsim(fmt::format("plot {} --x t --y b -o {}", csv, (dir_ / "out.png").string()), dir_);
    EXPECT_EQ(run.exit_code, 1) << csv << "\n" << run.err;
    EXPECT_TRUE(run.out.empty()) << run.out;
    EXPECT_EQ(run.err.rfind("organsim plot: error: ", 0), 0u) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_NE(run.err.find(message), std::string::npos) << run.err;
  }
  EXPECT_EQ(static_cast<long>(files_in_dir()), inputs) << "a failed plot left a file";
  // Not a PNG name: an input error; a missing option: a usage error.
  const std::string good = write("good.csv", "t,b\n0,1\n1,2\n");
  const CommandRun text =
      run_organsim(fmt::format("plot {} --x t --y b -o {}", good, (dir_ / "out.txt").string()), dir_);
  EXPECT_EQ(text.exit_code, 1) << text.err;
  EXPECT_NE(text.err.find("name it .png"), std::string::npos) << text.err;
  const CommandRun no_y = run_organsim(fmt::format("plot {} --x t -o {}", good, (dir_ / "out.png").string()), dir_);
  EXPECT_EQ(no_y.exit_code, 2) << no_y.err;
  EXPECT_NE(no_y.err.find("--y is required"), std::string::npos) << no_y.err;
}

}  // namespace
}  // namespace organsim
