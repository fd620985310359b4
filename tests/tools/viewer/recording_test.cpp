// The viewer's outputs: a recording holds every frame added and appears only
// when finished; screenshots are PNG files written atomically.
#include <filesystem>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "viewer/imagery.h"
#include "viewer/recording.h"
#include "temp_directory.h"

namespace organsim::viewer {
namespace {

namespace fs = std::filesystem;

class ViewerOutput : public organsim::testing::TempDirectoryTest {
 protected:
};

TEST_F(ViewerOutput, ARecordingAppearsWithEveryFrameOnlyWhenFinished) {
  const fs::path path = dir_ / "session.avi";
  const cv::Mat frame = procedural_liver_texture(64, 3);
  Recorder recorder(path.string(), frame.size());
  for (int i = 0; i < 5; ++i) recorder.add(frame);
  EXPECT_FALSE(fs::exists(path));
  recorder.finish();
  ASSERT_TRUE(fs::exists(path));
  EXPECT_EQ(recorder.count(), 5);
  EXPECT_EQ(entries(), 1);
  cv::VideoCapture video(path.string());
  ASSERT_TRUE(video.isOpened());
  EXPECT_EQ(static_cast<int>(video.get(cv::CAP_PROP_FRAME_COUNT)), 5);
}

TEST_F(ViewerOutput, AnAbandonedRecordingLeavesNothing) {
  {
    Recorder recorder((dir_ / "session.avi").string(), cv::Size(64, 64));
    recorder.add(cv::Mat(64, 64, CV_8UC3, cv::Scalar(10, 20, 30)));
  }
  EXPECT_EQ(entries(), 0);
}

TEST_F(ViewerOutput, ARecordingMustBeAnAvi) {
  EXPECT_THROW(Recorder((dir_ / "session.mp4").string(), cv::Size(64, 64)), std::runtime_error);
  const Recorder none("", cv::Size(64, 64));
  EXPECT_FALSE(none.active());
}

TEST_F(ViewerOutput, AScreenshotIsAPngWithThePixels) {
  const fs::path path = dir_ / "shot.png";
  const cv::Mat image = procedural_liver_texture(32, 5);
  write_png(image, path.string());
  const cv::Mat read = cv::imread(path.string(), cv::IMREAD_COLOR);
  ASSERT_EQ(read.size(), image.size());
  EXPECT_EQ(cv::norm(read, image, cv::NORM_INF), 0.0);
  EXPECT_EQ(entries(), 1);
}

}  // namespace
}  // namespace organsim::viewer
