// Field views (tools/plot/field_view.h): bad panels are refused with a message
// naming the fault; a rendered view (under a virtual X server: the
// `field_view_rendered` test runs this binary under xvfb-run) has the asked
// size and shows the colour scale's two ends where the values are.
#include "plot/field_view.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace organsim::plot {
namespace {

/// Two tetrahedra sharing a face (mm), one value each.
FieldPanel two_tetrahedra(double first, double second) {
  FieldPanel p;
  p.title = "pair";
  p.points = {{0, 0, 0}, {10, 0, 0}, {0, 0, 10}, {0, 10, 0}, {10, 10, 10}};
  p.tetrahedra = {{0, 1, 2, 3}, {1, 2, 3, 4}};
  p.cell_values = {first, second};
  return p;
}

void expect_refused(const std::vector<FieldPanel>& panels, const FieldView& view, const std::string& words) {
  try {
    write_field_view_png(panels, view, "/nonexistent/never.png");
    ADD_FAILURE() << "accepted; expected: " << words;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(FieldView, RefusesBadPanelsWithTheFault) {
  const FieldView view;
  expect_refused({}, view, "no panels");
  FieldPanel p = two_tetrahedra(0, 1);
  p.tetrahedra[1][3] = 9;
  expect_refused({p}, view, "node 9 out of range");
  p = two_tetrahedra(0, 1);
  p.cell_values.push_back(2);
  expect_refused({p}, view, "one value per cell or one per node");
  p = two_tetrahedra(0, 1);
  p.triangles = {{0, 1, 2}};
  expect_refused({p}, view, "either tetrahedra or triangles");
  p.tetrahedra.clear();
  p.triangles = {{0, 1, 7}};
  p.cell_values = {1};
  expect_refused({p}, view, "node 7 out of range");
  p = two_tetrahedra(0, std::nan(""));
  expect_refused({p}, view, "not finite");
  FieldView flat;
  flat.low = flat.high = 1;
  expect_refused({two_tetrahedra(0, 1)}, flat, "low < high");
}

TEST(FieldView, DrawsThePanelsWithTheColourScaleEnds) {
  const char* display = std::getenv("DISPLAY");
  const std::filesystem::path png = std::filesystem::temp_directory_path() / "organsim_field_view_test.png";
  FieldView view;
  view.scalar_title = "value";
  view.panel_width = 200;
  view.height = 240;
  view.view_direction = {-1, -1, -1};
  const std::vector<FieldPanel> panels = {two_tetrahedra(0, 0), two_tetrahedra(1, 1)};
  if (display == nullptr || *display == '\0') {
    EXPECT_THROW(write_field_view_png(panels, view, png.string()), std::runtime_error);
    GTEST_SKIP() << "no X display (the field_view_rendered test runs this under xvfb-run)";
  }
  write_field_view_png(panels, view, png.string());
  const cv::Mat image = cv::imread(png.string());
  std::filesystem::remove(png);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 2 * 200 + 110);
  EXPECT_EQ(image.rows, 240);
  // Blue (low) in the first panel, red (high) in the second, shaded by the lights.
  const auto count = [&](int x0, int x1, bool red) {
    int n = 0;
    for (int y = 0; y < image.rows; ++y)
      for (int x = x0; x < x1; ++x) {
        const cv::Vec3b c = image.at<cv::Vec3b>(y, x);  // BGR
        const int strong = red ? c[2] : c[0], weak = std::max(c[1], red ? c[0] : c[2]);
        n += strong > 80 && weak < strong / 3;
      }
    return n;
  };
  EXPECT_GT(count(0, 200, false), 500);
  EXPECT_EQ(count(0, 200, true), 0);
  EXPECT_GT(count(200, 400, true), 500);
  EXPECT_EQ(count(200, 400, false), 0);
}

}  // namespace
}  // namespace organsim::plot
