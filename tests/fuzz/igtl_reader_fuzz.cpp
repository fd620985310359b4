// Fuzz target for the OpenIGTLink message reader (`organsim serve`: the one
// parser that faces a network). Each input is a byte stream; it is fed to one
// reader whole, and to another in pieces whose sizes come from the stream's
// first bytes (so every split point is tried over the corpus). Both must hand
// on the same messages in the same order; every TRANSFORM handed on must be
// finite, its names terminated within their fields (the server then decides
// whether the device is one of its tools); the reader must stop after the
// stream is out of step.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "igtlink/message_reader.h"

namespace {

using namespace organsim::igtlink;

struct Recorder final : MessageReader::Handler {
  std::vector<std::string> events;
  void transform(const TransformMessage& m) override {
    for (float v : m.matrix)
      if (!std::isfinite(v)) std::abort();
    if (m.info.device.back() != '\0' || m.info.type.back() != '\0') std::abort();  // names end within their fields
    std::string event = "T:" + std::string(m.info.device.data());
    for (float v : m.matrix) event += "," + std::to_string(v);
    events.push_back(event);
  }
  void jaws(const JawsMessage& m) override {
    if (m.info.device.back() != '\0' || m.info.type.back() != '\0') std::abort();
    events.push_back("J:" + std::string(m.info.device.data()) + (m.closed ? ":closed" : ":open"));
  }
  void dropped(Problem problem, const MessageInfo& info) override {
    if (static_cast<std::size_t>(problem) >= kProblemKinds) std::abort();
    events.push_back("D:" + std::string(name(problem)) + ":" + std::string(info.type.data()));
  }
};

/// Feeds `size` bytes in pieces; false once the reader says out of step.
bool feed_in_pieces(MessageReader& reader, const std::uint8_t* data, std::size_t size, Recorder& recorder) {
  const std::size_t first = size > 0 ? data[0] % 61 + 1 : 1, step = size > 1 ? data[1] % 7 + 1 : 1;
  std::size_t at = 0, piece = first;
  while (at < size) {
    const std::size_t n = std::min(piece, size - at);
    if (!reader.feed(data + at, n, recorder)) return false;
    at += n;
    piece = piece % 64 + step;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  MessageReader whole_reader, pieces_reader;
  Recorder whole, pieces;
  const bool whole_ok = whole_reader.feed(data, size, whole);
  const bool pieces_ok = feed_in_pieces(pieces_reader, data, size, pieces);
  if (whole_ok != pieces_ok || whole.events != pieces.events) std::abort();
  if (!whole_ok) {
    // Out of step: the reader is done with this connection.
    const std::size_t before = whole.events.size();
    const std::uint8_t more[1] = {0};
    whole_reader.feed(more, 1, whole);
    if (whole.events.size() != before) std::abort();
  }
  return 0;
}
