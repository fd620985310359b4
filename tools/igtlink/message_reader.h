// Reading OpenIGTLink messages from a TCP byte stream: frames the stream into
// messages, checks each one (header, CRC, body size, finite values) and hands
// on the TRANSFORM messages (tool poses) and STRING messages (a grasper's jaws,
// "closed" or "open") that pass. Headers of protocol version 1 and 2 are
// read (version 2 carries an extended header and metadata around the content).
//
// Whatever a client sends, memory stays bounded: a TRANSFORM or STRING body is read into
// a fixed buffer and every other body is skipped as it streams past, whatever
// size its header announces. A header that cannot start a message (an unknown
// version, an unprintable type name) means the stream is out of step, which
// only closing the connection repairs.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace organsim::igtlink {

/// Why a message was dropped.
enum class Problem : std::uint8_t {
  unknown_type,    ///< a message type that serve does not read
  unknown_device,  ///< a TRANSFORM not named tool1 … toolN
  wrong_size,      ///< a TRANSFORM whose content is not 48 bytes (12 float32)
  bad_crc,         ///< the body does not match the header's CRC-64
  non_finite,      ///< NaN or infinity in the matrix
  too_far,         ///< a tip farther than 10 m from the organ (wrong units or frame)
  out_of_step,     ///< a header that cannot start a message: the connection is closed
  bad_jaws,        ///< a STRING whose text is not "closed" or "open"
};
inline constexpr std::size_t kProblemKinds = 8;

/// What is wrong, in words, for a log line ("failed its CRC check").
const char* describe(Problem problem) noexcept;
/// Its short name for counters and JSON ("bad_crc").
const char* name(Problem problem) noexcept;

/// A message's type and device name as its header gives them (NUL-terminated).
struct MessageInfo {
  std::array<char, 13> type{};
  std::array<char, 21> device{};
  std::uint16_t version = 0;
  std::uint64_t body_size = 0;
};

/// A TRANSFORM message that passed every check: the upper 3×4 of the matrix,
/// column by column (r11 r21 r31 r12 r22 r32 r13 r23 r33 tx ty tz), as sent.
struct TransformMessage {
  MessageInfo info;
  std::array<float, 12> matrix{};
};

/// A STRING message that passed every check: a tool's jaws close ("closed")
/// or open ("open"; docs/slicer.md).
struct JawsMessage {
  MessageInfo info;
  bool closed = false;
};

class MessageReader {
 public:
  class Handler {
   public:
    virtual ~Handler() = default;
    virtual void transform(const TransformMessage& message) = 0;
    virtual void jaws(const JawsMessage& message) = 0;
    virtual void dropped(Problem problem, const MessageInfo& info) = 0;
  };

  /// Consumes `size` received bytes, calling the handler for each message they
  /// complete. Returns false once the stream is out of step (the handler was
  /// told); the connection should then be closed.
  bool feed(const std::uint8_t* data, std::size_t size, Handler& handler);

  /// Bytes of bodies skipped so far (messages of other types, wrong sizes).
  std::uint64_t skipped_bytes() const noexcept { return skipped_bytes_; }

 private:
  static constexpr std::size_t kHeaderSize = 58;
  static constexpr std::size_t kMaxTransformBody = 4096;  // 48 bytes of content, room for version-2 metadata

  bool start_body(Handler& handler);
  void finish_body(Handler& handler);

  std::array<std::uint8_t, kHeaderSize> header_bytes_{};
  std::size_t header_filled_ = 0;
  MessageInfo info_;
  std::uint64_t crc_ = 0;
  // The body being read: kept (a TRANSFORM) or skipped (anything else).
  bool in_body_ = false;
  bool keep_body_ = false;
  std::uint64_t body_left_ = 0;
  std::array<std::uint8_t, kMaxTransformBody> body_{};
  std::size_t body_filled_ = 0;
  bool out_of_step_ = false;
  std::uint64_t skipped_bytes_ = 0;
};

}  // namespace organsim::igtlink
