#pragma once
// Protobuf parsing and serializing shared by the ARIS live protocol's sources (private to them:
// protobuf stays behind the library's API).

#include <google/protobuf/message_lite.h>

#include <climits>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace vog::sonar::detail {

// The serialized message after `front_bytes` zero bytes (room for a length prefix).
inline std::vector<std::uint8_t> serialized(const google::protobuf::MessageLite& msg, std::size_t front_bytes = 0) {
  const std::size_t n = msg.ByteSizeLong();
  std::vector<std::uint8_t> out(front_bytes + n);
  msg.SerializeToArray(out.data() + front_bytes, static_cast<int>(n));
  return out;
}

// False if the bytes are not the message (or any of its required fields is missing).
inline bool parsed(google::protobuf::MessageLite& msg, std::span<const std::uint8_t> bytes) {
  return bytes.size() <= static_cast<std::size_t>(INT_MAX) &&
         msg.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()));
}

}  // namespace vog::sonar::detail
