#pragma once
// Common types of the byte-stream transports (serial, TCP).

#include <cstdint>
#include <functional>
#include <span>

namespace asio {
class io_context;
}

namespace vog::io {

// Delivers bytes as they arrive (any chunking), stamped by the transport's StampClock at reception.
using ByteHandler = std::function<void(std::span<const std::uint8_t> bytes, std::int64_t stamp_ns)>;

}  // namespace vog::io
