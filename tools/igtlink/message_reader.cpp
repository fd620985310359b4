#include "igtlink/message_reader.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include <igtl_header.h>
#include <igtl_transform.h>
#include <igtl_util.h>

namespace organsim::igtlink {
namespace {

static_assert(IGTL_HEADER_SIZE == 58 && IGTL_HEADER_TYPE_SIZE == 12 && IGTL_HEADER_NAME_SIZE == 20,
              "the OpenIGTLink header layout this reader assumes");

constexpr std::size_t kTransformContent = 12 * sizeof(float);
// Larger bodies than this are not skipped but taken for garbage: no
// OpenIGTLink message (an image of a whole CT included) comes near a terabyte.
constexpr std::uint64_t kLargestBody = std::uint64_t{1} << 40;

// A field of the header is text: printable characters, then NULs to its end.
bool is_text_field(const char* field, std::size_t size, bool allow_empty) {
  std::size_t length = 0;
  while (length < size && field[length] != '\0') {
    const unsigned char c = static_cast<unsigned char>(field[length]);
    if (c < 0x20 || c > 0x7e) return false;
    ++length;
  }
  for (std::size_t i = length; i < size; ++i)
    if (field[i] != '\0') return false;
  return allow_empty || length > 0;
}

std::uint32_t big_endian(const std::uint8_t* p, std::size_t bytes) {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < bytes; ++i) value = (value << 8) | p[i];
  return value;
}

}  // namespace

const char* describe(Problem problem) noexcept {
  switch (problem) {
    case Problem::unknown_type: return "is of a type serve does not read (it reads TRANSFORM and STRING)";
    case Problem::unknown_device: return "is not named after a tool served (tool1, tool2, …; see --tools)";
    case Problem::wrong_size: return "has a body of the wrong size for a TRANSFORM (12 float32 values)";
    case Problem::bad_crc: return "failed its CRC check (damaged in transit)";
    case Problem::non_finite: return "holds NaN or infinite values";
    case Problem::too_far: return "puts the tool more than 10 m from the organ (positions are mm in the model's frame)";
    case Problem::out_of_step: return "has a header that cannot start a message (the stream is out of step)";
    case Problem::bad_jaws: return "is a STRING whose text is not 'closed' or 'open' (a tool's jaws)";
  }
  return "is malformed";
}

const char* name(Problem problem) noexcept {
  switch (problem) {
    case Problem::unknown_type: return "unknown_type";
    case Problem::unknown_device: return "unknown_device";
    case Problem::wrong_size: return "wrong_size";
    case Problem::bad_crc: return "bad_crc";
    case Problem::non_finite: return "non_finite";
    case Problem::too_far: return "too_far";
    case Problem::out_of_step: return "out_of_step";
    case Problem::bad_jaws: return "bad_jaws";
  }
  return "unknown";
}

bool MessageReader::feed(const std::uint8_t* data, std::size_t size, Handler& handler) {
  while (size > 0 && !out_of_step_) {
    if (!in_body_) {
      const std::size_t take = std::min(size, kHeaderSize - header_filled_);
      std::memcpy(header_bytes_.data() + header_filled_, data, take);
      header_filled_ += take;
      data += take;
      size -= take;
      if (header_filled_ < kHeaderSize) break;
      header_filled_ = 0;
      if (!start_body(handler)) return false;
      if (body_left_ == 0 && keep_body_) finish_body(handler);
      in_body_ = body_left_ > 0;
      continue;
    }
    const std::size_t take = static_cast<std::size_t>(std::min<std::uint64_t>(size, body_left_));
    if (keep_body_) {
      std::memcpy(body_.data() + body_filled_, data, take);
      body_filled_ += take;
    } else {
      skipped_bytes_ += take;
    }
    data += take;
    size -= take;
    body_left_ -= take;
    if (body_left_ == 0) {
      in_body_ = false;
      if (keep_body_) finish_body(handler);
    }
  }
  return !out_of_step_;
}

bool MessageReader::start_body(Handler& handler) {
  igtl_header header;
  std::memcpy(&header, header_bytes_.data(), sizeof header);
  igtl_header_convert_byte_order(&header);
  info_ = MessageInfo{};
  std::memcpy(info_.type.data(), header.name, IGTL_HEADER_TYPE_SIZE);
  std::memcpy(info_.device.data(), header.device_name, IGTL_HEADER_NAME_SIZE);
  info_.version = header.version;
  info_.body_size = header.body_size;
  crc_ = header.crc;
  const bool readable =
      (header.version == 1 || header.version == 2) && is_text_field(header.name, IGTL_HEADER_TYPE_SIZE, false) &&
      is_text_field(header.device_name, IGTL_HEADER_NAME_SIZE, true) && header.body_size <= kLargestBody;
  if (!readable) {
    // The fields may hold anything: keep the names printable for the log.
    for (char& c : info_.type) c = (c == '\0' || (c >= 0x20 && c <= 0x7e)) ? c : '?';
    for (char& c : info_.device) c = (c == '\0' || (c >= 0x20 && c <= 0x7e)) ? c : '?';
    out_of_step_ = true;
    handler.dropped(Problem::out_of_step, info_);
    return false;
  }
  body_left_ = header.body_size;
  body_filled_ = 0;
  keep_body_ = false;
  if (std::strcmp(info_.type.data(), "TRANSFORM") != 0 && std::strcmp(info_.type.data(), "STRING") != 0)
    handler.dropped(Problem::unknown_type, info_);
  else if (header.body_size > kMaxTransformBody)
    handler.dropped(Problem::wrong_size, info_);
  else
    keep_body_ = true;
  return true;
}

void MessageReader::finish_body(Handler& handler) {
  keep_body_ = false;
  if (crc64(body_.data(), body_filled_, 0) != crc_) return handler.dropped(Problem::bad_crc, info_);
  // Version 2: extended header (its own size first), content, metadata header, metadata.
  std::size_t content_begin = 0, content_size = body_filled_;
  if (info_.version == 2) {
    if (body_filled_ < 12) return handler.dropped(Problem::wrong_size, info_);
    const std::size_t extended = big_endian(body_.data(), 2);
    const std::size_t metadata = big_endian(body_.data() + 2, 2) + std::size_t{big_endian(body_.data() + 4, 4)};
    if (extended < 12 || extended + metadata > body_filled_) return handler.dropped(Problem::wrong_size, info_);
    content_begin = extended;
    content_size = body_filled_ - extended - metadata;
  }
  if (std::strcmp(info_.type.data(), "STRING") == 0) {
    // Encoding (2 bytes), length (2 bytes), the text; a jaw state is ASCII.
    if (content_size < 4 || content_size != 4 + std::size_t{big_endian(body_.data() + content_begin + 2, 2)})
      return handler.dropped(Problem::wrong_size, info_);
    const std::string text(reinterpret_cast<const char*>(body_.data() + content_begin + 4), content_size - 4);
    if (text != "closed" && text != "open") return handler.dropped(Problem::bad_jaws, info_);
    JawsMessage message;
    message.info = info_;
    message.closed = text == "closed";
    return handler.jaws(message);
  }
  if (content_size != kTransformContent) return handler.dropped(Problem::wrong_size, info_);
  TransformMessage message;
  message.info = info_;
  std::memcpy(message.matrix.data(), body_.data() + content_begin, kTransformContent);
  igtl_transform_convert_byte_order(message.matrix.data());
  for (float value : message.matrix)
    if (!std::isfinite(value)) return handler.dropped(Problem::non_finite, info_);
  handler.transform(message);
}

}  // namespace organsim::igtlink
