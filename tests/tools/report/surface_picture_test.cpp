// The report's organ pictures, drawn without a display: colours, depth order,
// markers and refusals.
#include "report/surface_picture.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace organsim::report {
namespace {

/// A UV sphere of radius `r` (mm) around `centre`, valued by its height z.
SurfacePicture sphere(double r, std::array<double, 3> centre = {0, 0, 0}) {
  SurfacePicture p;
  constexpr int kRings = 24, kSegments = 48;
  for (int i = 0; i <= kRings; ++i)
    for (int j = 0; j < kSegments; ++j) {
      const double theta = M_PI * i / kRings, phi = 2 * M_PI * j / kSegments;
      p.points.push_back({centre[0] + r * std::sin(theta) * std::cos(phi),
                          centre[1] + r * std::sin(theta) * std::sin(phi), centre[2] + r * std::cos(theta)});
      p.values.push_back(p.points.back()[2]);
    }
  for (int i = 0; i < kRings; ++i)
    for (int j = 0; j < kSegments; ++j) {
      const int a = i * kSegments + j, b = i * kSegments + (j + 1) % kSegments;
      p.triangles.push_back({a, b, a + kSegments});
      p.triangles.push_back({b, b + kSegments, a + kSegments});
    }
  p.low = -r;
  p.high = r;
  return p;
}

cv::Mat decoded(const SurfacePicture& p) {
  const std::vector<unsigned char> png = draw_surface_png(p);
  return cv::imdecode(png, cv::IMREAD_COLOR);
}

// Where a point lands: the sphere's centre in the middle of the space between
// the title and the colour bar, its top and bottom symmetric about it, and the
// drawn colour there the point's own.
TEST(SurfacePicture, SaysWhereAPointOfTheSurfaceLandsInThePicture) {
  const SurfacePicture p = sphere(10.0, {5, -3, 2});
  const cv::Mat image = decoded(p);
  const std::array<double, 2> centre = picture_pixel(p, {5, -3, 2}), top = picture_pixel(p, {5, -3 - 10, 12}),
                              bottom = picture_pixel(p, {5, -3 - 10, -8});
  EXPECT_NEAR(centre[0], 210.0, 1e-9);
  EXPECT_NEAR(centre[1], 0.5 * (28 + 380 - 46), 1e-9);  // between the title band and the scale band
  EXPECT_NEAR(top[0], centre[0], 1e-9);
  EXPECT_NEAR(centre[1] - top[1], bottom[1] - centre[1], 1e-9);
  EXPECT_NEAR(bottom[1] - top[1], 0.9 * (380 - 28 - 46), 1e-9) << "the sphere fills 90 % of the height";
  // Seen from the front, the sphere's point 45° up faces the eye and is red, 45° down blue.
  const double h = 10.0 * std::sqrt(0.5);
  const std::array<double, 2> up = picture_pixel(p, {5, -3 - h, 2 + h}), down = picture_pixel(p, {5, -3 - h, 2 - h});
  const cv::Vec3b red = image.at<cv::Vec3b>(static_cast<int>(up[1]), static_cast<int>(up[0]));
  const cv::Vec3b blue = image.at<cv::Vec3b>(static_cast<int>(down[1]), static_cast<int>(down[0]));
  EXPECT_GT(red[2], red[0] + 60);
  EXPECT_GT(blue[0], blue[2] + 40);
  SurfacePicture flat = p;
  flat.view_direction = {0, 0, 0};
  EXPECT_THROW(picture_pixel(flat, {0, 0, 0}), std::invalid_argument);
}

TEST(SurfacePicture, ColoursTheSurfaceByItsValuesOnAWhitePage) {
  SurfacePicture p = sphere(10.0);
  p.title = "front";
  p.scale_title = "height (mm)";
  const cv::Mat image = decoded(p);
  ASSERT_EQ(image.cols, 420);
  ASSERT_EQ(image.rows, 380);
  EXPECT_EQ(image.at<cv::Vec3b>(40, 5), cv::Vec3b(255, 255, 255));  // the page beside the organ
  // Seen from the front (along +y, z up): the top of the sphere red, the bottom blue.
  int top_row = -1, bottom_row = -1;
  for (int r = 30; r < image.rows - 50; ++r) {
    const cv::Vec3b bgr = image.at<cv::Vec3b>(r, image.cols / 2);
    if (bgr != cv::Vec3b(255, 255, 255)) {
      if (top_row < 0) top_row = r;
      bottom_row = r;
    }
  }
  ASSERT_GT(bottom_row - top_row, 200) << "the sphere fills the space between title and scale";
  const cv::Vec3b top = image.at<cv::Vec3b>(top_row + 25, image.cols / 2);
  const cv::Vec3b bottom = image.at<cv::Vec3b>(bottom_row - 25, image.cols / 2);
  EXPECT_GT(top[2], top[0] + 60) << "red at the top, BGR " << top;
  EXPECT_GT(bottom[0], bottom[2] + 60) << "blue at the bottom, BGR " << bottom;
  // Lit from the eye: the centre, facing it, is brighter than the rim.
  const cv::Vec3b centre = image.at<cv::Vec3b>((top_row + bottom_row) / 2, image.cols / 2);
  int rim = image.cols / 2;
  while (image.at<cv::Vec3b>((top_row + bottom_row) / 2, rim + 1) != cv::Vec3b(255, 255, 255)) ++rim;
  const cv::Vec3b edge = image.at<cv::Vec3b>((top_row + bottom_row) / 2, rim - 2);
  EXPECT_GT(centre[0] + centre[1] + centre[2], edge[0] + edge[1] + edge[2] + 90);
}

TEST(SurfacePicture, TheNearerSurfaceHidesTheFartherAndMarkersShowOnTop) {
  // Two spheres on the line of sight: the near one (valued low, blue) hides
  // the far one (high, red) wherever they overlap, whatever the triangle order.
  SurfacePicture near = sphere(10.0, {0, -30, 0}), far = sphere(10.0, {0, 30, 0});
  SurfacePicture both = far;
  for (double& v : both.values) v = 10.0;
  const auto offset = static_cast<std::int32_t>(both.points.size());
  for (std::size_t i = 0; i < near.points.size(); ++i) {
    both.points.push_back(near.points[i]);
    both.values.push_back(-10.0);
  }
  for (const auto& t : near.triangles) both.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  both.low = -10.0;
  both.high = 10.0;
  both.markers = {{0, -40, 0}};  // on the near sphere's front, at the picture's centre
  both.marker_radius = 1.5;
  const cv::Mat image = decoded(both);
  int blue = 0, red = 0;
  for (int r = 0; r < image.rows - 50; ++r)
    for (int c = 0; c < image.cols; ++c) {
      const cv::Vec3b bgr = image.at<cv::Vec3b>(r, c);
      blue += bgr[0] > bgr[2] + 60;
      red += bgr[2] > bgr[0] + 60;
    }
  EXPECT_GT(blue, 5000);
  EXPECT_LT(red, 10) << "the far sphere is hidden";
  const cv::Vec3b marker = image.at<cv::Vec3b>((28 + 380 - 46) / 2, 210);
  EXPECT_LT(marker[0] + marker[1] + marker[2], 60) << "a black marker, BGR " << marker;
}

TEST(SurfacePicture, RefusesWhatCannotBeDrawn) {
  SurfacePicture p = sphere(10.0);
  SurfacePicture no_triangles = p;
  no_triangles.triangles.clear();
  EXPECT_THROW(draw_surface_png(no_triangles), std::invalid_argument);
  SurfacePicture out_of_range = p;
  out_of_range.triangles.push_back({0, 1, static_cast<std::int32_t>(p.points.size())});
  EXPECT_THROW(draw_surface_png(out_of_range), std::invalid_argument);
  SurfacePicture values = p;
  values.values.pop_back();
  EXPECT_THROW(draw_surface_png(values), std::invalid_argument);
  SurfacePicture nan = p;
  nan.values[3] = std::nan("");
  EXPECT_THROW(draw_surface_png(nan), std::invalid_argument);
  SurfacePicture scale = p;
  scale.high = scale.low;
  EXPECT_THROW(draw_surface_png(scale), std::invalid_argument);
  SurfacePicture view = p;
  view.view_direction = {0, 0, 1};  // along its up
  EXPECT_THROW(draw_surface_png(view), std::invalid_argument);
  SurfacePicture tiny = p;
  tiny.width = 32;
  EXPECT_THROW(draw_surface_png(tiny), std::invalid_argument);
}

}  // namespace
}  // namespace organsim::report
