#include "igtl_messages.h"

#include <algorithm>
#include <cstring>

#include <Eigen/Geometry>
#include <igtlStringMessage.h>
#include <igtlTransformMessage.h>
#include <igtl_header.h>
#include <igtl_transform.h>
#include <igtl_util.h>

namespace organsim::testing {

Bytes transform_message(const std::string& device, const std::array<double, 3>& tip,
                        const std::array<double, 3>& shaft) {
  const Eigen::Vector3d z = Eigen::Vector3d(shaft[0], shaft[1], shaft[2]).normalized();
  const Eigen::Vector3d x = z.unitOrthogonal();
  const Eigen::Vector3d y = z.cross(x);
  igtl::Matrix4x4 matrix;
  igtl::IdentityMatrix(matrix);
  for (int r = 0; r < 3; ++r) {
    matrix[r][0] = static_cast<float>(x[r]);
    matrix[r][1] = static_cast<float>(y[r]);
    matrix[r][2] = static_cast<float>(z[r]);
    matrix[r][3] = static_cast<float>(tip[static_cast<std::size_t>(r)]);
  }
  igtl::TransformMessage::Pointer message = igtl::TransformMessage::New();
  message->SetDeviceName(device.c_str());
  message->SetMatrix(matrix);
  message->Pack();
  const auto* begin = static_cast<const std::uint8_t*>(message->GetPackPointer());
  return Bytes(begin, begin + message->GetPackSize());
}

Bytes string_message(const std::string& device, const std::string& text) {
  igtl::StringMessage::Pointer message = igtl::StringMessage::New();
  message->SetDeviceName(device.c_str());
  message->SetString(text.c_str());
  message->Pack();
  const auto* begin = static_cast<const std::uint8_t*>(message->GetPackPointer());
  return Bytes(begin, begin + message->GetPackSize());
}

Bytes transform_body(const std::array<float, 12>& matrix) {
  std::array<float, 12> swapped = matrix;
  igtl_transform_convert_byte_order(swapped.data());
  Bytes body(sizeof swapped);
  std::memcpy(body.data(), swapped.data(), sizeof swapped);
  return body;
}

Bytes raw_message(const std::string& type, const std::string& device, const Bytes& body, std::uint16_t version,
                  bool damage_crc, std::uint64_t announced_body_size) {
  igtl_header header{};
  header.version = version;
  std::memcpy(header.name, type.data(), std::min<std::size_t>(type.size(), IGTL_HEADER_TYPE_SIZE));
  std::memcpy(header.device_name, device.data(), std::min<std::size_t>(device.size(), IGTL_HEADER_NAME_SIZE));
  header.body_size = announced_body_size == ~std::uint64_t{0} ? body.size() : announced_body_size;
  Bytes copy = body;
  header.crc = crc64(copy.data(), copy.size(), 0) ^ (damage_crc ? 1u : 0u);
  igtl_header_convert_byte_order(&header);
  Bytes message(IGTL_HEADER_SIZE);
  std::memcpy(message.data(), &header, IGTL_HEADER_SIZE);
  message.insert(message.end(), body.begin(), body.end());
  return message;
}

Bytes version2_body(const Bytes& content) {
  const std::string key = "Source", value = "test";
  // Metadata header: count (2), then per key: key size (2), value encoding (2), value size (4).
  Bytes metadata_header = {0, 1, 0, static_cast<std::uint8_t>(key.size()),  0, 3,
                           0, 0, 0, static_cast<std::uint8_t>(value.size())};
  Bytes metadata(key.begin(), key.end());
  metadata.insert(metadata.end(), value.begin(), value.end());
  const std::uint16_t extended = 12;
  const auto metadata_header_size = static_cast<std::uint16_t>(metadata_header.size());
  const auto metadata_size = static_cast<std::uint32_t>(metadata.size());
  Bytes body = {0, static_cast<std::uint8_t>(extended),
                0, static_cast<std::uint8_t>(metadata_header_size),
                0, 0,
                0, static_cast<std::uint8_t>(metadata_size),
                0, 0,
                0, 7};  // message id 7
  body.insert(body.end(), content.begin(), content.end());
  body.insert(body.end(), metadata_header.begin(), metadata_header.end());
  body.insert(body.end(), metadata.begin(), metadata.end());
  return body;
}

}  // namespace organsim::testing
