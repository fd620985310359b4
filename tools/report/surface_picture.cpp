#include "surface_picture.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace organsim::report {
namespace {

// Drawn at twice the size and reduced: the edges come out smooth.
constexpr int kSupersampling = 2;
constexpr int kTitleBand = 28, kScaleBand = 46;  // pixels of the final picture

/// Moreland's cool-to-warm scale at t in [0, 1], as BGR.
cv::Vec3d cool_warm(double t) {
  static const double stops[3][3] = {{59, 76, 192}, {221, 221, 221}, {180, 4, 38}};  // RGB
  t = std::clamp(t, 0.0, 1.0);
  const int k = t < 0.5 ? 0 : 1;
  const double f = t < 0.5 ? t / 0.5 : (t - 0.5) / 0.5;
  double rgb[3];
  for (int c = 0; c < 3; ++c) rgb[c] = stops[k][c] + f * (stops[k + 1][c] - stops[k][c]);
  return {rgb[2], rgb[1], rgb[0]};
}

Eigen::Vector3d vec(const std::array<double, 3>& p) { return {p[0], p[1], p[2]}; }

void check(const SurfacePicture& in) {
  if (in.triangles.empty()) throw std::invalid_argument("a surface picture needs triangles");
  if (in.values.size() != in.points.size())
    throw std::invalid_argument(
        fmt::format("a surface picture has {} values for {} points", in.values.size(), in.points.size()));
  for (const auto& t : in.triangles)
    for (const std::int32_t v : t)
      if (v < 0 || static_cast<std::size_t>(v) >= in.points.size())
        throw std::invalid_argument(fmt::format("a triangle refers to point {} of {}", v, in.points.size()));
  for (std::size_t i = 0; i < in.points.size(); ++i)
    if (!vec(in.points[i]).allFinite() || !std::isfinite(in.values[i]))
      throw std::invalid_argument(fmt::format("point {} of a surface picture is not finite", i));
  if (!(in.low < in.high)) throw std::invalid_argument("a surface picture's colour scale needs low < high");
  if (in.width < 64 || in.height < 64) throw std::invalid_argument("a surface picture is at least 64 x 64 pixels");
}

/// The parallel projection of a picture: its eye's frame and how the surface
/// is fitted between the title and the colour bar, in supersampled pixels.
struct Projection {
  Eigen::Vector3d forward, up, right;
  int width = 0, height = 0, top = 0, bottom = 0;
  double scale = 1.0;
  Eigen::Vector2d centre;

  explicit Projection(const SurfacePicture& in) {
    // The eye's frame: x to the right, y up, depth away from the eye.
    forward = vec(in.view_direction);
    if (!(forward.norm() > 0.0) || !forward.allFinite())
      throw std::invalid_argument("a surface picture's view direction must be non-zero and not along its up");
    forward.normalize();
    up = vec(in.view_up) - vec(in.view_up).dot(forward) * forward;
    if (!(up.norm() > 1e-9))
      throw std::invalid_argument("a surface picture's view direction must be non-zero and not along its up");
    up.normalize();
    right = forward.cross(up);
    width = in.width * kSupersampling;
    height = in.height * kSupersampling;
    top = kTitleBand * kSupersampling;
    bottom = height - kScaleBand * kSupersampling;
    Eigen::Vector2d low(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
    Eigen::Vector2d high = -low;
    for (const auto& point : in.points) {
      const Eigen::Vector2d e = eye(vec(point)).head<2>();
      low = low.cwiseMin(e);
      high = high.cwiseMax(e);
    }
    // Fit the surface into the space between the title and the colour bar, 5 % margin.
    const double margin = 0.05;
    const double box_width = width * (1 - 2 * margin), box_height = (bottom - top) * (1 - 2 * margin);
    const Eigen::Vector2d extent = (high - low).cwiseMax(1e-12);
    scale = std::min(box_width / extent.x(), box_height / extent.y());
    centre = 0.5 * (low + high);
  }
  /// x, y and depth in the eye's frame.
  Eigen::Vector3d eye(const Eigen::Vector3d& p) const { return {p.dot(right), p.dot(up), p.dot(forward)}; }
  Eigen::Vector2d to_pixel(const Eigen::Vector3d& e) const {
    return Eigen::Vector2d(0.5 * width + (e.x() - centre.x()) * scale,
                           0.5 * (top + bottom) - (e.y() - centre.y()) * scale);
  }
};

}  // namespace

std::array<double, 2> picture_pixel(const SurfacePicture& picture, const std::array<double, 3>& point) {
  check(picture);
  const Projection projection(picture);
  const Eigen::Vector2d at = projection.to_pixel(projection.eye(vec(point))) / kSupersampling;
  return {at.x(), at.y()};
}

std::vector<unsigned char> draw_surface_png(const SurfacePicture& in) {
  check(in);
  const Projection projection(in);
  const Eigen::Vector3d forward = projection.forward;
  const int width = projection.width, height = projection.height;
  std::vector<Eigen::Vector3d> eye(in.points.size());  // x, y, depth
  for (std::size_t i = 0; i < in.points.size(); ++i) eye[i] = projection.eye(vec(in.points[i]));
  const double scale = projection.scale;
  const auto to_pixel = [&](const Eigen::Vector3d& e) { return projection.to_pixel(e); };

  cv::Mat image(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  std::vector<float> depth(static_cast<std::size_t>(width) * height, std::numeric_limits<float>::infinity());
  for (const auto& t : in.triangles) {
    const Eigen::Vector2d a = to_pixel(eye[t[0]]), b = to_pixel(eye[t[1]]), c = to_pixel(eye[t[2]]);
    const double area = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (std::abs(area) < 1e-12) continue;  // seen edge-on
    // Lit from the eye: a facet facing it is brightest, one seen at a grazing angle darkest.
    const Eigen::Vector3d normal =
        (vec(in.points[t[1]]) - vec(in.points[t[0]])).cross(vec(in.points[t[2]]) - vec(in.points[t[0]]));
    const double facing = normal.norm() > 0.0 ? std::abs(normal.normalized().dot(forward)) : 0.0;
    const double shade = 0.35 + 0.65 * facing;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x(), b.x(), c.x()}))));
    const int x1 = std::min(width - 1, static_cast<int>(std::ceil(std::max({a.x(), b.x(), c.x()}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y(), b.y(), c.y()}))));
    const int y1 = std::min(height - 1, static_cast<int>(std::ceil(std::max({a.y(), b.y(), c.y()}))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2d p(x + 0.5, y + 0.5);
        // Barycentric weights from the signed areas (either winding).
        const double wa = ((b - p).x() * (c - p).y() - (b - p).y() * (c - p).x()) / area;
        const double wb = ((c - p).x() * (a - p).y() - (c - p).y() * (a - p).x()) / area;
        const double wc = 1.0 - wa - wb;
        if (wa < 0.0 || wb < 0.0 || wc < 0.0) continue;
        const double z = wa * eye[t[0]].z() + wb * eye[t[1]].z() + wc * eye[t[2]].z();
        float& nearest = depth[static_cast<std::size_t>(y) * width + x];
        if (z >= nearest) continue;
        nearest = static_cast<float>(z);
        const double value = wa * in.values[t[0]] + wb * in.values[t[1]] + wc * in.values[t[2]];
        const cv::Vec3d colour = cool_warm((value - in.low) / (in.high - in.low)) * shade;
        image.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(colour[0]), cv::saturate_cast<uchar>(colour[1]),
                                              cv::saturate_cast<uchar>(colour[2]));
      }
  }
  for (const auto& m : in.markers) {
    const Eigen::Vector2d at = to_pixel(projection.eye(vec(m)));
    const int radius = std::max(3 * kSupersampling, static_cast<int>(std::lround(in.marker_radius * scale)));
    const cv::Point centre_px(static_cast<int>(std::lround(at.x())), static_cast<int>(std::lround(at.y())));
    cv::circle(image, centre_px, radius + kSupersampling, cv::Scalar(255, 255, 255), cv::FILLED, cv::LINE_AA);
    cv::circle(image, centre_px, radius, cv::Scalar(0, 0, 0), cv::FILLED, cv::LINE_AA);
  }
  cv::Mat picture;
  cv::resize(image, picture, cv::Size(in.width, in.height), 0, 0, cv::INTER_AREA);

  // Title, and the colour bar with its ends and title.
  const cv::Scalar ink(40, 40, 40);
  cv::putText(picture, in.title, cv::Point(8, 19), cv::FONT_HERSHEY_SIMPLEX, 0.5, ink, 1, cv::LINE_AA);
  const int bar_left = in.width / 5, bar_right = in.width - in.width / 5;
  const int bar_top = in.height - kScaleBand + 6, bar_bottom = bar_top + 10;
  for (int x = bar_left; x < bar_right; ++x) {
    const cv::Vec3d colour = cool_warm(static_cast<double>(x - bar_left) / std::max(1, bar_right - bar_left - 1));
    cv::line(picture, cv::Point(x, bar_top), cv::Point(x, bar_bottom), cv::Scalar(colour[0], colour[1], colour[2]));
  }
  cv::rectangle(picture, cv::Point(bar_left, bar_top), cv::Point(bar_right, bar_bottom), ink);
  const auto label = [&](const std::string& text, int x, int y, bool right_aligned) {
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline);
    cv::putText(picture, text, cv::Point(right_aligned ? x - size.width : x, y), cv::FONT_HERSHEY_SIMPLEX, 0.4, ink, 1,
                cv::LINE_AA);
  };
  label(fmt::format("{:g}", in.low), bar_left - 6, bar_bottom, true);
  label(fmt::format("{:.3g}", in.high), bar_right + 6, bar_bottom, false);
  int baseline = 0;
  const cv::Size title_size = cv::getTextSize(in.scale_title, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline);
  label(in.scale_title, (in.width - title_size.width) / 2, bar_bottom + 18, false);

  std::vector<unsigned char> png;
  if (!cv::imencode(".png", picture, png)) throw std::runtime_error("cannot encode a surface picture as PNG");
  return png;
}

}  // namespace organsim::report
