#include "recording.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "organsim/io/atomic_file.h"

namespace organsim::viewer {

Recorder::Recorder(const std::string& path, cv::Size size) {
  if (path.empty()) return;
  if (std::filesystem::path(path).extension() != ".avi")
    throw std::runtime_error("--record " + path + ": recordings are Motion-JPEG AVI files; name it .avi");
  output_ = std::make_unique<io::AtomicFile>(path, ".avi");
  writer_ =
      std::make_unique<cv::VideoWriter>(output_->temp_path(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 60.0, size);
  if (!writer_->isOpened()) throw std::runtime_error("cannot write the recording " + path + "; check the directory");
}

Recorder::~Recorder() = default;

bool Recorder::active() const { return writer_ != nullptr; }

namespace {

// Frames between checks that the file grows: more than the writer buffers
// (a few hundred kilobytes; a frame is tens of kilobytes).
constexpr long kFramesPerCheck = 120;

std::runtime_error full_disk(const std::string& path, const std::string& what) {
  return std::runtime_error("cannot write the recording '" + path + "': " + what +
                            "; check that the disk has free space (and the file-size limit, ulimit -f)");
}

// Frames OpenCV reads back from a Motion-JPEG AVI; -1 when it cannot. OpenCV
// prints why a truncated file does not parse straight to stderr, which is
// silenced meanwhile: the caller's error says it in one line. (Called once,
// after the loops stopped: no other thread writes to stderr then.)
long frames_in(const std::string& path) {
  std::fflush(stderr);
  const int saved = ::dup(STDERR_FILENO);
  const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (saved >= 0 && null >= 0) ::dup2(null, STDERR_FILENO);
  long frames = -1;
  {
    cv::VideoCapture written(path, cv::CAP_OPENCV_MJPEG);
    if (written.isOpened()) frames = static_cast<long>(written.get(cv::CAP_PROP_FRAME_COUNT));
  }
  std::fflush(stderr);
  if (saved >= 0) {
    ::dup2(saved, STDERR_FILENO);
    ::close(saved);
  }
  if (null >= 0) ::close(null);
  return frames;
}

}  // namespace

void Recorder::add(const cv::Mat& frame) {
  if (!writer_) return;
  writer_->write(frame);
  ++count_;
  if (count_ % kFramesPerCheck != 0) return;
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(output_->temp_path(), error);
  if (error || size <= checked_size_) {
    writer_.reset();  // nothing more is written; the destructor removes the temporary file
    throw full_disk(output_->path(), "the file stopped growing at " + std::to_string(checked_size_ >> 20) + " MiB");
  }
  checked_size_ = size;
}

void Recorder::finish() {
  if (!writer_) return;
  writer_->release();
  writer_.reset();
  const long frames = frames_in(output_->temp_path());
  if (frames != count_)
    throw full_disk(output_->path(), std::to_string(std::max(frames, 0L)) + " of " + std::to_string(count_) +
                                         " frames reached the file");
  output_->commit();
}

void write_png(const cv::Mat& image, const std::string& path) {
  std::vector<unsigned char> bytes;
  if (!cv::imencode(".png", image, bytes)) throw std::runtime_error("cannot encode the screenshot " + path + " as PNG");
  io::write_file_atomically(path, bytes.data(), bytes.size());
}

}  // namespace organsim::viewer
