// What the viewer writes: a recording of every drawn frame (Motion-JPEG AVI)
// and PNG screenshots, both published atomically (organsim/io/atomic_file.h).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "organsim/io/atomic_file.h"

namespace organsim::viewer {

/// Records frames into a Motion-JPEG AVI at 60 frames per second. The file
/// appears at `path` only when finish() is called; until then the frames go to
/// a temporary file that is removed if the recording is abandoned. OpenCV's
/// writer does not report failed writes, so the recorder checks that the file
/// keeps growing and, at finish(), that every frame reached it: a full disk
/// or a file-size limit is an error naming the path, and nothing is published.
class Recorder {
 public:
  /// An empty `path` makes a recorder that records nothing. Throws
  /// std::runtime_error when the path does not end in .avi or cannot be written.
  Recorder(const std::string& path, cv::Size size);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  bool active() const;
  /// Adds one BGR frame of the constructor's size. Throws std::runtime_error
  /// when the file has stopped growing (the disk is full).
  void add(const cv::Mat& frame);
  /// Closes the video, checks that it holds every frame and publishes it at
  /// `path`. Throws std::runtime_error otherwise.
  void finish();
  long count() const { return count_; }

 private:
  std::unique_ptr<io::AtomicFile> output_;
  std::unique_ptr<cv::VideoWriter> writer_;
  long count_ = 0;
  std::uintmax_t checked_size_ = 0;  // the temporary file's size at the last check
};

/// Writes a BGR image as a PNG file, atomically. Throws std::runtime_error
/// naming the path when it cannot.
void write_png(const cv::Mat& image, const std::string& path);

}  // namespace organsim::viewer
