#include "recording.h"

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
  writer_ = std::make_unique<cv::VideoWriter>(output_->temp_path(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 60.0,
                                              size);
  if (!writer_->isOpened()) throw std::runtime_error("cannot write the recording " + path + "; check the directory");
}

Recorder::~Recorder() = default;

bool Recorder::active() const { return writer_ != nullptr; }

void Recorder::add(const cv::Mat& frame) {
  if (!writer_) return;
  writer_->write(frame);
  ++count_;
}

void Recorder::finish() {
  if (!writer_) return;
  writer_->release();
  output_->commit();
  writer_.reset();
}

void write_png(const cv::Mat& image, const std::string& path) {
  std::vector<unsigned char> bytes;
  if (!cv::imencode(".png", image, bytes)) throw std::runtime_error("cannot encode the screenshot " + path + " as PNG");
  io::write_file_atomically(path, bytes.data(), bytes.size());
}

}  // namespace organsim::viewer
