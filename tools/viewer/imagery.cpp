#include "imagery.h"

#include <filesystem>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace organsim::viewer {

cv::Mat procedural_liver_texture(int size, unsigned seed) {
  cv::RNG random(seed);
  // Sum of smoothed noise at lobule (≈ 1/16 of the image), patch and speckle scales.
  cv::Mat field = cv::Mat::zeros(size, size, CV_32F);
  const double weights[] = {0.55, 0.30, 0.15};
  const int cells[] = {size / 48, size / 12, size / 2};
  for (int octave = 0; octave < 3; ++octave) {
    cv::Mat coarse(std::max(cells[octave], 2), std::max(cells[octave], 2), CV_32F);
    random.fill(coarse, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::Mat fine;
    cv::resize(coarse, fine, cv::Size(size, size), 0, 0, cv::INTER_CUBIC);
    field += weights[octave] * fine;
  }
  cv::normalize(field, field, 0.0, 1.0, cv::NORM_MINMAX);
  // Parenchyma colours (BGR): dark maroon to reddish brown, a little sheen.
  const cv::Vec3f dark(28, 30, 92), light(60, 78, 168);
  cv::Mat texture(size, size, CV_8UC3);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c) {
      const float v = field.at<float>(r, c);
      const cv::Vec3f colour = dark + (light - dark) * v;
      texture.at<cv::Vec3b>(r, c) = cv::Vec3b(cv::saturate_cast<uchar>(colour[0]), cv::saturate_cast<uchar>(colour[1]),
                                              cv::saturate_cast<uchar>(colour[2]));
    }
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0.0);
  return texture;
}

cv::Mat read_image(const std::string& path) {
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error(path + " does not exist or is not a file; give an image (PNG, JPEG) or a video");
  cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  if (image.empty()) throw std::runtime_error(path + " is not an image OpenCV can read; give a PNG or JPEG");
  return image;
}

Background::Background(const std::string& path) {
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error(path + " does not exist or is not a file; give an image (PNG, JPEG) or a video");
  frame_ = cv::imread(path, cv::IMREAD_COLOR);
  if (!frame_.empty()) return;
  video_ = std::make_unique<cv::VideoCapture>(path);
  if (!video_->isOpened() || !video_->read(frame_) || frame_.empty())
    throw std::runtime_error(path + " is neither an image nor a video OpenCV can read; give a PNG, JPEG, AVI or MP4");
}

const cv::Mat& Background::next() {
  if (!video_) return frame_;
  cv::Mat frame;
  if (!video_->read(frame) || frame.empty()) {  // end of the video: loop
    video_->set(cv::CAP_PROP_POS_FRAMES, 0);
    video_->read(frame);
  }
  if (!frame.empty()) frame_ = frame;
  return frame_;
}

}  // namespace organsim::viewer
