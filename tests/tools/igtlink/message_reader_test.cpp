// The OpenIGTLink message reader: messages framed whatever the chunking, every
// kind of bad message dropped with its Problem while the stream goes on, and
// bounded memory whatever a header announces.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "igtl_messages.h"
#include "igtlink/message_reader.h"

namespace organsim::igtlink {
namespace {

using testing::Bytes;

struct Collected final : MessageReader::Handler {
  std::vector<TransformMessage> transforms;
  std::vector<std::pair<Problem, std::string>> problems;  // with the device name
  std::vector<JawsMessage> jaws_messages;
  void transform(const TransformMessage& message) override { transforms.push_back(message); }
  void jaws(const JawsMessage& message) override { jaws_messages.push_back(message); }
  void dropped(Problem problem, const MessageInfo& info) override {
    problems.emplace_back(problem, info.device.data());
  }
};

Bytes operator+(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

const std::array<float, 12> kPose = {1, 0, 0, 0, 1, 0, 0, 0, 1, 80.5f, -30.25f, 12.0f};

TEST(IgtlMessageReader, ReadsATransformFedAByteAtATimeOrAllAtOnce) {
  const Bytes message = testing::transform_message("tool1", {80.5, -30.25, 12.0}, {0.0, 1.0, 0.0});
  for (const std::size_t chunk : {std::size_t{1}, std::size_t{7}, message.size()}) {
    MessageReader reader;
    Collected got;
    for (std::size_t at = 0; at < message.size(); at += chunk)
      ASSERT_TRUE(reader.feed(message.data() + at, std::min(chunk, message.size() - at), got));
    ASSERT_EQ(got.transforms.size(), 1u) << "chunk " << chunk;
    EXPECT_TRUE(got.problems.empty());
    const TransformMessage& t = got.transforms[0];
    EXPECT_STREQ(t.info.type.data(), "TRANSFORM");
    EXPECT_STREQ(t.info.device.data(), "tool1");
    EXPECT_FLOAT_EQ(t.matrix[9], 80.5f);
    EXPECT_FLOAT_EQ(t.matrix[10], -30.25f);
    EXPECT_FLOAT_EQ(t.matrix[11], 12.0f);
    EXPECT_NEAR(t.matrix[6], 0.0f, 1e-7);  // third column: the shaft
    EXPECT_NEAR(t.matrix[7], 1.0f, 1e-7);
    EXPECT_NEAR(t.matrix[8], 0.0f, 1e-7);
  }
}

// A STRING named after a tool says whether its jaws are closed or open
// (docs/slicer.md); any other text is dropped and named.
TEST(IgtlMessageReader, ReadsAToolsJawsFromAStringMessage) {
  const Bytes stream = testing::string_message("tool2", "closed") + testing::string_message("tool1", "open") +
                       testing::string_message("tool1", "shut") + testing::string_message("tool1", "") +
                       testing::transform_message("tool1", {80.5, -30.25, 12.0});
  MessageReader reader;
  Collected got;
  for (std::size_t at = 0; at < stream.size(); at += 5)
    ASSERT_TRUE(reader.feed(stream.data() + at, std::min<std::size_t>(5, stream.size() - at), got));
  ASSERT_EQ(got.jaws_messages.size(), 2u);
  EXPECT_STREQ(got.jaws_messages[0].info.device.data(), "tool2");
  EXPECT_TRUE(got.jaws_messages[0].closed);
  EXPECT_STREQ(got.jaws_messages[1].info.device.data(), "tool1");
  EXPECT_FALSE(got.jaws_messages[1].closed);
  ASSERT_EQ(got.problems.size(), 2u);
  EXPECT_EQ(got.problems[0].first, Problem::bad_jaws);
  EXPECT_EQ(got.problems[1].first, Problem::bad_jaws);
  EXPECT_EQ(got.transforms.size(), 1u);
  // A STRING whose length field disagrees with its body is the wrong size.
  Bytes body = {0, 3, 0, 9, 'o', 'p', 'e', 'n'};
  MessageReader again;
  Collected wrong;
  const Bytes message = testing::raw_message("STRING", "tool1", body);
  ASSERT_TRUE(again.feed(message.data(), message.size(), wrong));
  ASSERT_EQ(wrong.problems.size(), 1u);
  EXPECT_EQ(wrong.problems[0].first, Problem::wrong_size);
}

TEST(IgtlMessageReader, DropsEachKindOfBadMessageAndReadsTheNextOne) {
  const std::array<float, 12> nan_pose = {1, 0, 0, 0, 1, 0, 0, 0, std::numeric_limits<float>::quiet_NaN(), 1, 2, 3};
  const Bytes stream = testing::raw_message("STATUS", "tracker", Bytes(30, 0x41)) +
                       testing::raw_message("TRANSFORM", "tool1", testing::transform_body(kPose), 1, true) +
                       testing::raw_message("TRANSFORM", "tool1", Bytes(40, 0)) +
                       testing::raw_message("TRANSFORM", "tool1", Bytes(5000, 0)) +
                       testing::raw_message("TRANSFORM", "tool1", testing::transform_body(nan_pose)) +
                       testing::raw_message("TRANSFORM", "tool2", testing::transform_body(kPose));
  MessageReader reader;
  Collected got;
  ASSERT_TRUE(reader.feed(stream.data(), stream.size(), got));
  ASSERT_EQ(got.problems.size(), 5u);
  EXPECT_EQ(got.problems[0].first, Problem::unknown_type);
  EXPECT_EQ(got.problems[1].first, Problem::bad_crc);
  EXPECT_EQ(got.problems[2].first, Problem::wrong_size);
  EXPECT_EQ(got.problems[3].first, Problem::wrong_size);
  EXPECT_EQ(got.problems[4].first, Problem::non_finite);
  ASSERT_EQ(got.transforms.size(), 1u);
  EXPECT_STREQ(got.transforms[0].info.device.data(), "tool2");
  EXPECT_FLOAT_EQ(got.transforms[0].matrix[10], -30.25f);
  EXPECT_EQ(reader.skipped_bytes(), 30u + 5000u);
}

TEST(IgtlMessageReader, ReadsVersionTwoHeadersWithExtendedHeaderAndMetadata) {
  const Bytes message =
      testing::raw_message("TRANSFORM", "tool3", testing::version2_body(testing::transform_body(kPose)), 2);
  MessageReader reader;
  Collected got;
  ASSERT_TRUE(reader.feed(message.data(), message.size(), got));
  ASSERT_EQ(got.transforms.size(), 1u);
  EXPECT_TRUE(got.problems.empty());
  EXPECT_EQ(got.transforms[0].info.version, 2);
  EXPECT_FLOAT_EQ(got.transforms[0].matrix[9], 80.5f);
  // An extended header claiming more than the body holds is a wrong size, not a crash.
  Bytes lying = testing::version2_body(testing::transform_body(kPose));
  lying[1] = 200;
  const Bytes bad = testing::raw_message("TRANSFORM", "tool3", lying, 2);
  ASSERT_TRUE(reader.feed(bad.data(), bad.size(), got));
  ASSERT_EQ(got.problems.size(), 1u);
  EXPECT_EQ(got.problems[0].first, Problem::wrong_size);
}

TEST(IgtlMessageReader, AHeaderThatCannotStartAMessageStopsTheStream) {
  for (const Bytes& garbage :
       {Bytes(58, 0xff), testing::raw_message("TRANSFORM", "tool1", Bytes(48, 0), 9),
        testing::raw_message("TRANS\x01", "tool1", Bytes(48, 0)), testing::raw_message("", "tool1", Bytes(48, 0)),
        testing::raw_message("IMAGE", "ct", Bytes(), 1, false, std::uint64_t{1} << 50)}) {
    MessageReader reader;
    Collected got;
    const Bytes stream = garbage + testing::transform_message("tool1", {1, 2, 3});
    EXPECT_FALSE(reader.feed(stream.data(), stream.size(), got));
    ASSERT_EQ(got.problems.size(), 1u);
    EXPECT_EQ(got.problems[0].first, Problem::out_of_step);
    EXPECT_TRUE(got.transforms.empty());
  }
}

TEST(IgtlMessageReader, SkipsAHugeBodyAsItStreamsWithoutHoldingIt) {
  // An IMAGE announcing 512 GiB: the reader holds none of it, whatever arrives.
  const Bytes header = testing::raw_message("IMAGE", "ct", Bytes(), 1, false, std::uint64_t{1} << 39);
  MessageReader reader;
  Collected got;
  ASSERT_TRUE(reader.feed(header.data(), header.size(), got));
  const Bytes chunk(1 << 20, 0x5a);
  for (int i = 0; i < 64; ++i) ASSERT_TRUE(reader.feed(chunk.data(), chunk.size(), got));
  EXPECT_EQ(reader.skipped_bytes(), 64u << 20);
  ASSERT_EQ(got.problems.size(), 1u);
  EXPECT_EQ(got.problems[0].first, Problem::unknown_type);
  EXPECT_TRUE(got.transforms.empty());
  EXPECT_LT(sizeof(MessageReader), 8192u);
}

}  // namespace
}  // namespace organsim::igtlink
