// Pictures for the laparoscopic scene, made or read with OpenCV: a procedural
// liver-like texture (no third-party images) and a background that is a still
// image or a looping video.
#pragma once

#include <memory>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

namespace organsim::viewer {

/// A liver-like surface texture (BGR, size × size): reddish-brown parenchyma
/// with lobular mottling and fine speckle, from seeded noise at several scales.
/// The same seed gives the same image.
cv::Mat procedural_liver_texture(int size = 512, unsigned seed = 1);

/// Reads an image file as BGR. Throws std::runtime_error naming the file and
/// saying what to do when it is missing or not an image.
cv::Mat read_image(const std::string& path);

/// A background: one image, or the frames of a video, looped.
class Background {
 public:
  /// Opens `path`: an image (PNG, JPEG, …) or a video (AVI, MP4, … that
  /// OpenCV's backends read). Throws std::runtime_error when it cannot.
  explicit Background(const std::string& path);
  /// The next frame (the same one for an image), BGR.
  const cv::Mat& next();
  bool is_video() const { return video_ != nullptr; }

 private:
  std::unique_ptr<cv::VideoCapture> video_;
  cv::Mat frame_;
};

}  // namespace organsim::viewer
