// Session files (docs/session-format.md) and the scripted device that plays
// them: the documented format, every documented error (naming the file and the
// line), the writer's round trip, and the device's interpolation and force log.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "organsim/devices/scripted_device.h"
#include "organsim/devices/session_file.h"

namespace organsim::devices {
namespace {

namespace fs = std::filesystem;

// Each test writes its files into a directory of its own (process id and test
// name: parallel runs of the binary do not collide) and removes it afterwards.
class SessionFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("organsim_session_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes `text` byte for byte (binary: "\r\n" stays "\r\n").
  std::string write(const std::string& text, const std::string& name = "test.session") const {
    const std::string path = (dir_ / name).string();
    std::ofstream out(path, std::ios::binary);
    out << text;
    return path;
  }
  static std::string read_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }

  // Expects read_session to throw std::runtime_error whose message begins with
  // "<path>:<line>: " and contains `phrase`.
  void expect_error(const std::string& text, std::size_t line, const std::string& phrase,
                    const SessionLimits& limits = {}) const {
    const std::string path = write(text);
    try {
      read_session(path, limits);
      ADD_FAILURE() << "no error for:\n" << text;
    } catch (const std::runtime_error& e) {
      const std::string message = e.what();
      const std::string prefix = path + ":" + std::to_string(line) + ": ";
      EXPECT_EQ(message.rfind(prefix, 0), 0u) << "expected it to begin with '" << prefix << "': " << message;
      EXPECT_NE(message.find(phrase), std::string::npos) << "expected '" << phrase << "' in: " << message;
    }
  }

  fs::path dir_;
};

constexpr const char* kHeader = "# organsim session 1\n";

/// Reading `path` fails with an error that names the file (without a line) and says `phrase`.
void expect_file_error(const std::string& path, const std::string& phrase) {
  try {
    read_session(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(phrase), std::string::npos) << message;
  }
}

TEST_F(SessionFile, ReadsTwoToolsWithAndWithoutShaftColumns) {
  // Tools interleave; comments and blank lines (anywhere after the header) are
  // ignored; tool 2 has shaft columns of any non-zero length.
  const std::string path = write(std::string(kHeader) +
                                 "# time_s,tool,x_mm,y_mm,z_mm[,shaft_x,shaft_y,shaft_z]\n"
                                 "\n"
                                 "0.000,1,-7.660,-243.088,351.719\n"
                                 "0.000,2,10,20,30,0,3,4\n"
                                 "# a comment between samples\n"
                                 "0.200,1,-7.660,-243.088,351.719\n"
                                 "\n"
                                 "0.500,2,11,21,31,0,0,-2.5\n"
                                 "0.900,1,-6.820,-256.471,358.441\n"
                                 "1.250,2,12,22,32,1e-3,0,0\n");
  const Session s = read_session(path);
  ASSERT_EQ(s.tools.size(), 2u);
  // The session lasts until the last time stamp of any tool (tool 2's, not the
  // last line of tool 1).
  EXPECT_EQ(s.duration, 1.25);

  const Trajectory& one = s.tools[0];
  ASSERT_EQ(one.times.size(), 3u);
  ASSERT_EQ(one.positions.size(), 3u);
  EXPECT_TRUE(one.shafts.empty());
  EXPECT_EQ(one.times[0], 0.0);
  EXPECT_EQ(one.times[1], 0.2);
  EXPECT_EQ(one.times[2], 0.9);
  // Millimetres in the file, metres in memory.
  EXPECT_DOUBLE_EQ(one.positions[0][0], -0.00766);
  EXPECT_DOUBLE_EQ(one.positions[0][1], -0.243088);
  EXPECT_DOUBLE_EQ(one.positions[0][2], 0.351719);
  EXPECT_DOUBLE_EQ(one.positions[2][1], -0.256471);

  const Trajectory& two = s.tools[1];
  ASSERT_EQ(two.times.size(), 3u);
  ASSERT_EQ(two.shafts.size(), 3u);
  EXPECT_EQ(two.times[1], 0.5);
  EXPECT_DOUBLE_EQ(two.positions[1][0], 0.011);
  EXPECT_DOUBLE_EQ(two.positions[2][2], 0.032);
  // Shafts are normalized: (0, 3, 4) → (0, 0.6, 0.8), (0, 0, −2.5) → −z, (1e-3, 0, 0) → +x.
  EXPECT_NEAR((two.shafts[0] - Eigen::Vector3d(0.0, 0.6, 0.8)).norm(), 0.0, 1e-15);
  EXPECT_NEAR((two.shafts[1] - Eigen::Vector3d(0.0, 0.0, -1.0)).norm(), 0.0, 1e-15);
  EXPECT_NEAR((two.shafts[2] - Eigen::Vector3d(1.0, 0.0, 0.0)).norm(), 0.0, 1e-15);
}

TEST_F(SessionFile, ReadsTheExampleFromTheFormatDocument) {
  const Session s =
      read_session(write("# organsim session 1\n"
                         "# free comment lines start with '#'\n"
                         "# time_s,tool,x_mm,y_mm,z_mm\n"
                         "0.000,1,-7.660,-243.088,351.719\n"
                         "0.200,1,-7.660,-243.088,351.719\n"
                         "0.900,1,-6.820,-256.471,358.441\n"
                         "0.000,2,-107.631,-221.041,383.849\n"));
  ASSERT_EQ(s.tools.size(), 2u);
  EXPECT_EQ(s.tools[0].times.size(), 3u);
  EXPECT_EQ(s.tools[1].times.size(), 1u);
  EXPECT_EQ(s.duration, 0.9);
  EXPECT_DOUBLE_EQ(s.tools[1].positions[0][0], -0.107631);
}

TEST_F(SessionFile, CrlfLineEndingsReadTheSameAsLf) {
  const std::string lf = std::string(kHeader) +
                         "# comment\n"
                         "\n"
                         "0,1,1,2,3\n"
                         "0.25,1,4,5,6\n"
                         "0.5,2,7,8,9,0,0,2\n";
  std::string crlf;
  for (char c : lf) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  const Session a = read_session(write(lf, "lf.session"));
  const Session b = read_session(write(crlf, "crlf.session"));
  ASSERT_EQ(b.tools.size(), 2u);
  EXPECT_EQ(b.duration, a.duration);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(b.tools[k].times, a.tools[k].times);
    ASSERT_EQ(b.tools[k].positions.size(), a.tools[k].positions.size());
    for (std::size_t i = 0; i < a.tools[k].positions.size(); ++i)
      EXPECT_EQ(b.tools[k].positions[i], a.tools[k].positions[i]);
    ASSERT_EQ(b.tools[k].shafts.size(), a.tools[k].shafts.size());
  }
  EXPECT_EQ(b.tools[1].shafts[0], Eigen::Vector3d(0.0, 0.0, 1.0));  // the last field lost its '\r'
}

TEST_F(SessionFile, AWrongOrMissingHeaderIsRejectedAtItsLine) {
  expect_error("# organsim session 4\n0,1,0,0,0\n", 1, "version '4' is not one this organsim reads (1, 2 or 3)");
  expect_error("# organsim session\n0,1,0,0,0\n", 1, "first line must be '# organsim session 1', '2' or '3'");
  expect_error("# some other file\n0,1,0,0,0\n", 1, "not an organsim session");
  expect_error("0,1,1,2,3\n", 1, "not an organsim session");
  // The header must be the first line: after a blank line it is only a comment,
  // and the first sample is where the file is found not to be a session.
  expect_error("\n# organsim session 1\n0,1,0,0,0\n", 3, "not an organsim session");
}

// Format version 2 adds `tip,TOOL,RADIUS_MM`: a tool's hemispherical end
// (docs/session-format.md); version 1 files, without it, still read.
TEST_F(SessionFile, Version2GivesToolsATipRadius) {
  const std::string path = write("# organsim session 2\ntip,2,2.5\n0,1,0,0,0\n0,2,1,1,1\ntip,1,0\n");
  const Session session = read_session(path);
  ASSERT_EQ(session.tools.size(), 2u);
  EXPECT_DOUBLE_EQ(session.tools[0].tip_radius, 0.0);
  EXPECT_DOUBLE_EQ(session.tools[1].tip_radius, 2.5e-3);
  EXPECT_LT(read_session(write(std::string(kHeader) + "0,1,0,0,0\n")).tools[0].tip_radius, 0.0) << "not given";

  // Written back: version 2 with the radii, version 1 without any.
  const std::string copy = (dir_ / "copy.session").string();
  write_session(session, copy);
  EXPECT_EQ(read_text(copy).rfind("# organsim session 2\n", 0), 0u);
  const Session again = read_session(copy);
  EXPECT_DOUBLE_EQ(again.tools[1].tip_radius, 2.5e-3);
  EXPECT_DOUBLE_EQ(again.tools[0].tip_radius, 0.0);
  Session without = session;
  for (Trajectory& t : without.tools) t.tip_radius = -1.0;
  write_session(without, copy);
  EXPECT_EQ(read_text(copy).rfind("# organsim session 1\n", 0), 0u);

  const std::string v2 = "# organsim session 2\n0,1,0,0,0\n";
  expect_error(std::string(kHeader) + "tip,1,2.5\n0,1,0,0,0\n", 2, "needs format version 2");
  expect_error(v2 + "tip,1\n", 3, "expected tip,TOOL,RADIUS_MM");
  expect_error(v2 + "tip,1,-1\n", 3, "is not a tip radius");
  expect_error(v2 + "tip,1,nan\n", 3, "is not a tip radius");
  expect_error(v2 + "tip,1,2500\n", 3, "is not a tip radius: a number of millimetres from 0 to 50");
  expect_error(v2 + "tip,17,2\n", 3, "tool numbers are 1 to 16");
  expect_error(v2 + "tip,1,2\ntip,1,3\n", 4, "a second tip line");
  try {
    read_session(write(v2 + "tip,2,2\n"));
    ADD_FAILURE() << "a tip for a tool without samples";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("tool 2 has no samples"), std::string::npos) << e.what();
  }
}

TEST_F(SessionFile, AWrongFieldCountIsRejectedAtItsLine) {
  const std::string phrase = "expected 5 or 8 comma-separated fields";
  expect_error(std::string(kHeader) + "0,1,1,2\n", 2, phrase);
  expect_error(std::string(kHeader) + "0,1,1,2,3\n0.1,1,1,2,3,4\n", 3, phrase);
  expect_error(std::string(kHeader) + "# c\n0,1,1,2,3,4,5\n", 3, phrase);
  expect_error(std::string(kHeader) + "0,1,1,2,3,4,5,6,7\n", 2, phrase);
  expect_error(std::string(kHeader) + "just words\n", 2, phrase);
}

TEST_F(SessionFile, AFieldThatIsNotAFiniteNumberIsRejectedAndQuoted) {
  const std::string h = kHeader;
  expect_error(h + "0,1,abc,2,3\n", 2, "'abc' is not a finite number");
  expect_error(h + "0,1,,2,3\n", 2, "'' is not a finite number");
  expect_error(h + "0,1,1.5mm,2,3\n", 2, "'1.5mm' is not a finite number");
  expect_error(h + "0,1,1,2,3\nx,1,1,2,3\n", 3, "'x' is not a finite number");
  expect_error(h + "0,1,nan,2,3\n", 2, "'nan' is not a finite number");
  expect_error(h + "0,1,1,inf,3\n", 2, "'inf' is not a finite number");
  expect_error(h + "0,1,1,2,-inf\n", 2, "'-inf' is not a finite number");
  expect_error(h + "0,1,1,2,1e400\n", 2, "'1e400' is not a finite number");  // overflows to inf
  expect_error(h + "NaN,1,1,2,3\n", 2, "not a finite number");
  expect_error(h + "0,1,1,2,3,0,0,nan\n", 2, "'nan' is not a finite number");  // shaft fields too
}

TEST_F(SessionFile, ToolNumbersOutsideOneToSixteenAreRejected) {
  const std::string h = kHeader;
  for (const char* tool : {"0", "17", "1.5", "-1", "100"})
    expect_error(h + "0," + tool + ",1,2,3\n", 2, "tool numbers are 1 to 16");
  // 16 is the largest allowed (tools 1..16 all present).
  std::string all = h;
  for (int tool = 1; tool <= 16; ++tool) all += "0," + std::to_string(tool) + ",1,2,3\n";
  EXPECT_EQ(read_session(write(all)).tools.size(), 16u);
}

TEST_F(SessionFile, TimesMustStartAtZeroAndIncreasePerTool) {
  const std::string h = kHeader;
  expect_error(h + "0,1,0,0,0\n1,1,0,0,0\n0.5,1,0,0,0\n", 4, "times of a tool must increase");
  expect_error(h + "0,1,0,0,0\n0,1,1,1,1\n", 3, "times of a tool must increase");  // equal is not increasing
  expect_error(h + "-0.1,1,0,0,0\n", 2, "times start at 0 s");
  // Each tool has its own clock: tool 2 may start before tool 1's latest sample.
  const Session s = read_session(write(h + "0,1,0,0,0\n1,1,0,0,0\n0.5,2,0,0,0\n0.75,2,0,0,0\n"));
  EXPECT_EQ(s.duration, 1.0);
}

TEST_F(SessionFile, AToolMustHaveShaftsOnAllOrNoneOfItsSamples) {
  const std::string h = kHeader;
  const std::string phrase = "all have a shaft direction or all have none";
  expect_error(h + "0,1,0,0,0\n1,1,0,0,0,0,0,1\n", 3, phrase);
  expect_error(h + "0,1,0,0,0,0,0,1\n1,1,0,0,0\n", 3, phrase);
  // Per tool: tool 1 without, tool 2 with is fine.
  const Session s = read_session(write(h + "0,1,0,0,0\n0,2,0,0,0,0,0,1\n1,1,0,0,0\n1,2,0,0,0,0,1,0\n"));
  EXPECT_TRUE(s.tools[0].shafts.empty());
  EXPECT_EQ(s.tools[1].shafts.size(), 2u);
}

TEST_F(SessionFile, AZeroShaftDirectionIsRejected) {
  const std::string h = kHeader;
  expect_error(h + "0,1,0,0,0,0,0,0\n", 2, "the shaft direction is zero");
  expect_error(h + "0,1,0,0,0,1,0,0\n1,1,0,0,0,-0,0,0\n", 3, "the shaft direction is zero");
}

TEST_F(SessionFile, EveryToolFromOneToNMustAppear) {
  // Tool 2 missing between 1 and 3: reported by number, after the whole file
  // was read (so with the file's name but no line).
  expect_file_error(write(std::string(kHeader) + "0,1,0,0,0\n0,3,0,0,0\n"), "tool 2 has no samples");
  // Only tool 2: tool 1 is missing.
  EXPECT_THROW(read_session(write(std::string(kHeader) + "0,2,0,0,0\n")), std::runtime_error);
}

TEST_F(SessionFile, ASessionWithoutSamplesIsRejected) {
  // The error points at the last line read.
  expect_error(kHeader, 1, "the session has no samples");
  expect_error(std::string(kHeader) + "# only comments\n\n# and blank lines\n", 4, "the session has no samples");
}

TEST_F(SessionFile, AMissingFileIsAnErrorNamingThePath) {
  expect_file_error((dir_ / "no_such.session").string(), "cannot open");
}

TEST_F(SessionFile, WriteThenReadRoundTripsToThePrintedPrecision) {
  // The writer prints times to 0.1 ms, positions to 1 µm (0.001 mm) and shafts
  // to 6 decimals: a round trip reproduces the session to half those steps.
  Session session;
  session.tools.resize(2);
  Trajectory& one = session.tools[0];
  one.times = {0.0, 0.12345678, 1.0 / 3.0, 0.5};
  one.positions = {{0.0123456789, -0.2430884, 0.351719}, {-0.00766, 0.0, 1e-7}, {0.1, -0.1, 0.05}, {0.0, 0.0, 0.0}};
  Trajectory& two = session.tools[1];
  two.times = {0.0, 0.25, 2.0000049};
  two.positions = {{0.01, 0.02, 0.03}, {0.011, 0.021, 0.031}, {-0.5, 0.25, 0.125}};
  two.shafts = {Eigen::Vector3d(0.0, 0.6, 0.8), Eigen::Vector3d(1.0, 2.0, 3.0).normalized(),
                Eigen::Vector3d(-1.0, 0.0, 0.0)};
  session.duration = 2.0000049;

  const std::string path = (dir_ / "round_trip.session").string();
  write_session(session, path);
  // The file begins with the version line, so the reader accepts it.
  EXPECT_EQ(read_text(path).rfind("# organsim session 1\n", 0), 0u);
  const Session back = read_session(path);

  ASSERT_EQ(back.tools.size(), 2u);
  EXPECT_NEAR(back.duration, session.duration, 5e-5 + 1e-12);
  for (std::size_t k = 0; k < 2; ++k) {
    const Trajectory& a = session.tools[k];
    const Trajectory& b = back.tools[k];
    ASSERT_EQ(b.times.size(), a.times.size()) << k;
    ASSERT_EQ(b.positions.size(), a.positions.size()) << k;
    ASSERT_EQ(b.shafts.size(), a.shafts.size()) << k;
    for (std::size_t i = 0; i < a.times.size(); ++i) {
      EXPECT_NEAR(b.times[i], a.times[i], 5e-5 + 1e-12) << k << " " << i;
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.positions[i][c], a.positions[i][c], 5e-7 + 1e-12) << k << " " << i;
      if (!a.shafts.empty()) {
        EXPECT_NEAR(b.shafts[i].norm(), 1.0, 1e-15);
        EXPECT_NEAR((b.shafts[i] - a.shafts[i]).norm(), 0.0, 2e-6) << k << " " << i;
      }
    }
  }
  // Values already on the printed grid come back exactly (to the mm → m product).
  EXPECT_EQ(back.tools[1].times[1], 0.25);
  EXPECT_DOUBLE_EQ(back.tools[1].positions[2][0], -0.5);
  EXPECT_DOUBLE_EQ(back.tools[1].positions[2][2], 0.125);

  // Writing again replaces the file (atomically: no temporary file is left).
  session.tools.resize(1);
  write_session(session, path);
  EXPECT_EQ(read_session(path).tools.size(), 1u);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(SessionFile, WritingIntoAMissingDirectoryThrows) {
  Session session;
  session.tools.resize(1);
  session.tools[0].times = {0.0};
  session.tools[0].positions = {Eigen::Vector3d::Zero()};
  EXPECT_THROW(write_session(session, (dir_ / "missing" / "x.session").string()), std::runtime_error);
}

// --- ScriptedDevice ---------------------------------------------------------

Trajectory three_samples() {
  Trajectory t;
  t.times = {0.5, 1.0, 2.0};
  t.positions = {{0.0, 0.0, 0.0}, {0.01, -0.02, 0.04}, {0.03, 0.0, 0.04}};
  return t;
}

TEST(ScriptedDevice, InterpolatesLinearlyBetweenSamples) {
  ScriptedDevice device(three_samples(), {}, 0);
  ToolPose pose;
  ASSERT_TRUE(device.read_pose(0.75, pose));  // halfway through the first interval
  EXPECT_NEAR((pose.tip - Eigen::Vector3d(0.005, -0.01, 0.02)).norm(), 0.0, 1e-16);
  ASSERT_TRUE(device.read_pose(1.25, pose));  // a quarter into the second
  EXPECT_NEAR((pose.tip - Eigen::Vector3d(0.015, -0.015, 0.04)).norm(), 0.0, 1e-16);
  ASSERT_TRUE(device.read_pose(1.0, pose));  // on a sample: the sample itself
  EXPECT_EQ(pose.tip, Eigen::Vector3d(0.01, -0.02, 0.04));
  ASSERT_TRUE(device.read_pose(1.9, pose));
  EXPECT_NEAR((pose.tip - Eigen::Vector3d(0.028, -0.002, 0.04)).norm(), 0.0, 1e-15);
  EXPECT_EQ(pose.shaft, Eigen::Vector3d::Zero());  // no shafts: unknown
}

TEST(ScriptedDevice, HoldsTheFirstSampleBeforeAndTheLastAfter) {
  const Trajectory t = three_samples();
  ScriptedDevice device(t, {}, 0);
  ToolPose pose;
  for (const double time : {-10.0, 0.0, 0.4999}) {
    ASSERT_TRUE(device.read_pose(time, pose));
    EXPECT_EQ(pose.tip, t.positions[0]) << time;
  }
  for (const double time : {2.0, 2.0001, 1e6}) {
    ASSERT_TRUE(device.read_pose(time, pose));
    EXPECT_EQ(pose.tip, t.positions[2]) << time;
  }
  // A single sample is held at every time.
  Trajectory one;
  one.times = {0.3};
  one.positions = {{0.1, 0.2, 0.3}};
  ScriptedDevice still(one, {}, 0);
  for (const double time : {0.0, 0.3, 5.0}) {
    ASSERT_TRUE(still.read_pose(time, pose));
    EXPECT_EQ(pose.tip, Eigen::Vector3d(0.1, 0.2, 0.3));
  }
}

TEST(ScriptedDevice, InterpolatesTheShaftThenNormalizesIt) {
  Trajectory t;
  t.times = {0.0, 1.0, 2.0};
  t.positions.assign(3, Eigen::Vector3d::Zero());
  t.shafts = {Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Vector3d(0.0, 1.0, 0.0), Eigen::Vector3d(0.0, -1.0, 0.0)};
  ScriptedDevice device(t, {}, 0);
  ToolPose pose;
  ASSERT_TRUE(device.read_pose(0.5, pose));
  EXPECT_NEAR((pose.shaft - Eigen::Vector3d(1.0, 1.0, 0.0) / std::sqrt(2.0)).norm(), 0.0, 1e-15);
  // Linear then normalized (not a uniform rotation): at s = ¼ the direction of (¾, ¼, 0).
  ASSERT_TRUE(device.read_pose(0.25, pose));
  EXPECT_NEAR((pose.shaft - Eigen::Vector3d(3.0, 1.0, 0.0) / std::sqrt(10.0)).norm(), 0.0, 1e-15);
  EXPECT_NEAR(pose.shaft.norm(), 1.0, 1e-15);
  // Held before and after, like the tip.
  ASSERT_TRUE(device.read_pose(-1.0, pose));
  EXPECT_EQ(pose.shaft, Eigen::Vector3d(1.0, 0.0, 0.0));
  ASSERT_TRUE(device.read_pose(3.0, pose));
  EXPECT_EQ(pose.shaft, Eigen::Vector3d(0.0, -1.0, 0.0));
  // Halfway between opposite directions the interpolated shaft vanishes: it is
  // reported as unknown (zero), never as a NaN from normalizing zero.
  ASSERT_TRUE(device.read_pose(1.5, pose));
  EXPECT_EQ(pose.shaft, Eigen::Vector3d::Zero());
  ASSERT_TRUE(device.read_pose(1.25, pose));
  EXPECT_EQ(pose.shaft, Eigen::Vector3d(0.0, 1.0, 0.0));  // (0, ½, 0) normalized
}

TEST(ScriptedDevice, TimeMayGoBack) {
  // The device keeps a cursor for speed; a time before the last one read (a
  // replay restarted, a viewer scrubbing) must still give the right pose.
  const Trajectory t = three_samples();
  ScriptedDevice forward(t, {}, 0);
  ToolPose a, b;
  for (const double time : {1.9, 1.25, 0.75, 0.1, 1.5, 0.6, 2.5, 0.5, 1.0}) {
    ASSERT_TRUE(forward.read_pose(time, a));
    ScriptedDevice fresh(t, {}, 0);  // no history
    ASSERT_TRUE(fresh.read_pose(time, b));
    EXPECT_EQ(a.tip, b.tip) << time;
  }
}

TEST_F(SessionFile, SessionsLongerThanADayOrFarFromTheOrganAreRefusedNamingTheLine) {
  expect_error(std::string(kHeader) + "0,1,0,0,0\n99999999,1,1,0,0\n", 3, "later than a session may last (24 h)");
  expect_error(std::string(kHeader) + "0,1,0,0,0\n86400.5,1,1,0,0\n", 3, "check that times are in seconds");
  SessionLimits organ;
  organ.organ_box = Eigen::AlignedBox3d(Eigen::Vector3d(-0.1, -0.1, -0.1), Eigen::Vector3d(0.1, 0.1, 0.1));
  expect_error(std::string(kHeader) + "0,1,0,0,0\n1,2,1e308,0,0\n", 3, "tool 2 is 1e+305 m from the organ", organ);
  expect_error(std::string(kHeader) + "0,1,0,0,-10200\n", 2, "tool 1 is 10.1 m from the organ (at most 10 m)", organ);
  // At the limits: a day, and 10 m from the organ's box.
  const Session day = read_session(write(std::string(kHeader) + "0,1,0,0,10100\n86400,1,0,0,0\n"), organ);
  EXPECT_EQ(day.duration, 86400.0);
  // Without an organ box, any finite position; with --long-session, any length.
  SessionLimits any;
  any.max_duration = std::numeric_limits<double>::infinity();
  EXPECT_EQ(read_session(write(std::string(kHeader) + "0,1,1e308,0,0\n99999999,1,0,0,0\n"), any).duration, 99999999.0);
}

TEST_F(SessionFile, AShaftWithHugeComponentsIsNormalizedNotLost) {
  // Found by the fuzzer: squaring 1e200 overflowed, and the shaft became zero.
  const Session s = read_session(write(std::string(kHeader) + "0,1,0,0,0,1e200,0,1e200\n1,1,0,0,0,1e308,0,0\n"));
  EXPECT_NEAR((s.tools[0].shafts[0] - Eigen::Vector3d(std::sqrt(0.5), 0.0, std::sqrt(0.5))).norm(), 0.0, 1e-15);
  EXPECT_NEAR((s.tools[0].shafts[1] - Eigen::Vector3d(1.0, 0.0, 0.0)).norm(), 0.0, 1e-15);
}

// Format version 3 adds `jaw,TOOL,TIME_S,closed|open`: a grasper's jaws
// (docs/session-format.md); versions 1 and 2 still read, and a file without
// jaw events is still written as one of them.
TEST_F(SessionFile, Version3GivesGraspersJawEvents) {
  const std::string path =
      write("# organsim session 3\ntip,1,2.5\n0,1,0,0,0\n1,1,0,0,5\njaw,1,0.25,closed\n0,2,1,1,1\njaw,1,0.75,open\n");
  const Session session = read_session(path);
  ASSERT_EQ(session.tools.size(), 2u);
  EXPECT_EQ(session.tools[0].jaw_times, (std::vector<double>{0.25, 0.75}));
  EXPECT_EQ(session.tools[0].jaw_closed, (std::vector<unsigned char>{1, 0}));
  EXPECT_TRUE(session.tools[1].jaw_times.empty()) << "a probe";
  EXPECT_DOUBLE_EQ(session.tools[0].tip_radius, 2.5e-3);

  const std::string copy = (dir_ / "copy.session").string();
  write_session(session, copy);
  EXPECT_EQ(read_text(copy).rfind("# organsim session 3\n", 0), 0u);
  const Session again = read_session(copy);
  EXPECT_EQ(again.tools[0].jaw_times, session.tools[0].jaw_times);
  EXPECT_EQ(again.tools[0].jaw_closed, session.tools[0].jaw_closed);
  EXPECT_EQ(again.tools[0].times, session.tools[0].times);
  Session probes = session;
  for (Trajectory& t : probes.tools) {
    t.jaw_times.clear();
    t.jaw_closed.clear();
  }
  write_session(probes, copy);
  EXPECT_EQ(read_text(copy).rfind("# organsim session 2\n", 0), 0u);

  // A jaw event after the last sample lengthens the session.
  EXPECT_DOUBLE_EQ(read_session(write("# organsim session 3\n0,1,0,0,0\njaw,1,2.5,closed\n")).duration, 2.5);

  const std::string v3 = "# organsim session 3\n0,1,0,0,0\n";
  expect_error("# organsim session 2\n0,1,0,0,0\njaw,1,0,closed\n", 3, "needs format version 3");
  expect_error(v3 + "jaw,1,0\n", 3, "expected jaw,TOOL,TIME_S,closed or jaw,TOOL,TIME_S,open");
  expect_error(v3 + "jaw,1,0,shut\n", 3, "'shut' is not a jaw state: write closed or open");
  expect_error(v3 + "jaw,1,nan,closed\n", 3, "is not a finite number");
  expect_error(v3 + "jaw,1,-1,closed\n", 3, "times start at 0 s");
  expect_error(v3 + "jaw,0,1,closed\n", 3, "tool numbers are 1 to 16");
  expect_error(v3 + "jaw,1,1,closed\njaw,1,1,open\n", 4, "jaw times of a tool must increase");
  expect_error(v3 + "jaw,1,90000,closed\n", 3, "later than a session may last");
  try {
    read_session(write(v3 + "jaw,2,1,closed\n"));
    ADD_FAILURE() << "jaws for a tool without samples";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("tool 2 has no samples"), std::string::npos) << e.what();
  }
}

// The jaws are open before the first event and as the last event at or
// before the time left them after it, also when time goes back or repeats.
TEST(ScriptedDevice, PlaysTheJawsAsAStepFunction) {
  Trajectory t = three_samples();
  t.jaw_times = {0.5, 1.0};
  t.jaw_closed = {1, 0};
  ScriptedDevice device(t, {}, 0, 2.0);
  ToolPose pose;
  const std::pair<double, bool> expected[] = {{0.0, false}, {0.49, false}, {0.5, true}, {0.9, true}, {1.0, false},
                                              {1.9, false}, {0.6, true},   {2.6, true}, {3.2, false}};
  for (const auto& [time, closed] : expected) {
    ASSERT_TRUE(device.read_pose(time, pose));
    EXPECT_EQ(pose.jaws_closed, closed) << time;
  }
  ScriptedDevice probe(three_samples(), {}, 0);
  ASSERT_TRUE(probe.read_pose(0.7, pose));
  EXPECT_FALSE(pose.jaws_closed);
}

TEST(ScriptedDevice, RepeatsItsTrajectoryEveryRepeatPeriod) {
  ScriptedDevice device(three_samples(), {}, 0, 2.0);
  ToolPose first, again;
  for (const double t : {0.75, 1.5}) {
    ASSERT_TRUE(device.read_pose(t, first));
    ASSERT_TRUE(device.read_pose(t + 2.0, again));
    EXPECT_EQ(first.tip, again.tip) << t;
    ASSERT_TRUE(device.read_pose(t + 2000.0, again));
    EXPECT_EQ(first.tip, again.tip) << t;
  }
}

// The force loop writes while another thread takes the records out: every
// record arrives once, in order, through a ring much smaller than the run.
TEST(ScriptedDevice, StreamsRecordsThroughItsRingToAReaderThread) {
  ScriptedDevice device(three_samples(), {}, 64);
  constexpr int kRecords = 200000;
  std::thread loop([&] {
    for (int k = 0; k < kRecords; ++k) {
      while (device.record_count() == 64) std::this_thread::yield();  // a real loop drops instead (counted)
      device.write_force(k * 1e-3, Eigen::Vector3d(k, 0, 0), true);
    }
  });
  int expected = 0;
  bool in_order = true;
  ForceRecord record;
  while (expected < kRecords) {
    if (!device.take_record(record)) continue;
    in_order = in_order && record.force[0] == expected && record.time == expected * 1e-3;
    ++expected;
  }
  loop.join();
  EXPECT_TRUE(in_order);
  EXPECT_EQ(device.dropped_records(), 0u);
  EXPECT_FALSE(device.take_record(record));
}

TEST(ScriptedDevice, NoPoseForANonFiniteTimeOrAnEmptyTrajectory) {
  ScriptedDevice device(three_samples(), {}, 0);
  ToolPose pose;
  EXPECT_FALSE(device.read_pose(std::numeric_limits<double>::quiet_NaN(), pose));
  EXPECT_FALSE(device.read_pose(std::numeric_limits<double>::infinity(), pose));
  EXPECT_FALSE(device.read_pose(-std::numeric_limits<double>::infinity(), pose));
  EXPECT_TRUE(device.read_pose(0.75, pose));  // and it recovers
  ScriptedDevice empty(Trajectory{}, {}, 0);
  EXPECT_FALSE(empty.read_pose(0.0, pose));
}

TEST(ScriptedDevice, RecordsForcesUpToItsCapacityAndCountsTheRest) {
  SafetyLimits limits;
  limits.max_force = 1.5;
  limits.stall_timeout = 0.25;
  ScriptedDevice device(three_samples(), limits, 3);
  EXPECT_EQ(device.limits().max_force, 1.5);  // the limits it was given
  EXPECT_EQ(device.limits().stall_timeout, 0.25);
  EXPECT_EQ(device.record_count(), 0u);
  EXPECT_EQ(device.dropped_records(), 0u);
  for (int k = 0; k < 5; ++k) device.write_force(0.001 * k, Eigen::Vector3d(1.0 * k, -1.0 * k, 0.5 * k), k % 2 == 1);
  EXPECT_EQ(device.record_count(), 3u);
  EXPECT_EQ(device.dropped_records(), 2u);
  for (std::size_t k = 0; k < 3; ++k) {  // the first three, in order
    EXPECT_EQ(device.record(k).time, 0.001 * static_cast<double>(k));
    EXPECT_EQ(device.record(k).force, Eigen::Vector3d(1.0 * k, -1.0 * k, 0.5 * k));
    EXPECT_EQ(device.record(k).in_contact, k % 2 == 1);
  }
  ScriptedDevice none(three_samples(), {}, 0);  // capacity 0: everything dropped
  none.write_force(0.0, Eigen::Vector3d::Ones(), true);
  EXPECT_EQ(none.record_count(), 0u);
  EXPECT_EQ(none.dropped_records(), 1u);
}

TEST_F(SessionFile, ASessionReadFromFilePlaysInMetres) {
  // End to end: the file's millimetres come out of the device as metres, the
  // file's shaft lengths as unit directions.
  const Session s = read_session(write(std::string(kHeader) + "0,1,0,0,0,0,0,5\n1,1,10,-20,40,0,5,0\n"));
  ScriptedDevice device(s.tools[0], {}, 0);
  ToolPose pose;
  ASSERT_TRUE(device.read_pose(0.5, pose));
  EXPECT_NEAR((pose.tip - Eigen::Vector3d(0.005, -0.01, 0.02)).norm(), 0.0, 1e-15);
  EXPECT_NEAR((pose.shaft - Eigen::Vector3d(0.0, 1.0, 1.0) / std::sqrt(2.0)).norm(), 0.0, 1e-15);
}

TEST(Session, ReadsTheDocumentedFormatAndRejectsBadFiles) {
  const std::string path = ::testing::TempDir() + "organsim_session_test.session";
  auto write = [&](const std::string& text) {
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs(text.c_str(), f);
    std::fclose(f);
  };
  write("# organsim session 1\n# time_s,tool,x_mm,y_mm,z_mm\n0,1,1,2,3\n1,1,4,5,6\n0.5,2,0,0,0\n");
  const Session s = read_session(path);
  ASSERT_EQ(s.tools.size(), 2u);
  EXPECT_DOUBLE_EQ(s.duration, 1.0);
  EXPECT_DOUBLE_EQ(s.tools[0].positions[1][2], 0.006);  // mm → m
  ScriptedDevice device(s.tools[0], {}, 4);
  ToolPose pose;
  ASSERT_TRUE(device.read_pose(0.5, pose));
  EXPECT_TRUE(pose.tip.isApprox(Eigen::Vector3d(0.0025, 0.0035, 0.0045)));
  EXPECT_EQ(pose.shaft, Eigen::Vector3d::Zero());  // no shaft columns
  const std::pair<const char*, const char*> bad[] = {
      {"0,1,1,2,3\n", "first line"},
      {"# organsim session 1\n0,1,1,2\n", "5 or 8 comma-separated"},
      {"# organsim session 1\n0,1,nan,2,3\n", "not a finite number"},
      {"# organsim session 1\n1,1,0,0,0\n0.5,1,0,0,0\n", "must increase"},
      {"# organsim session 1\n0,17,0,0,0\n", "1 to 16"},
      {"# organsim session 1\n0,2,0,0,0\n", "tool 1 has no samples"},
      {"# organsim session 1\n", "no samples"},
  };
  for (const auto& [text, message] : bad) {
    write(text);
    try {
      read_session(path);
      ADD_FAILURE() << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
  std::remove(path.c_str());
}

}  // namespace
}  // namespace organsim::devices
