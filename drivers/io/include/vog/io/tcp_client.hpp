#pragma once
// TCP client byte stream with reconnect (HAUV backseat link, PROTOCOLS.md: default port 29500).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "vog/core/result.hpp"
#include "vog/io/byte_stream.hpp"
#include "vog/io/health.hpp"
#include "vog/io/reconnect.hpp"

namespace vog::io {

struct TcpClientConfig {
  std::string address = "127.0.0.1";  // numeric server address
  std::uint16_t port = 29500;
  int connect_timeout_ms = 2000;
  std::size_t read_chunk_bytes = 4096;
  ReconnectConfig reconnect;

  Status validate(const std::string& prefix = "tcp") const;
};

// Lifecycle: construct, start() (connects asynchronously, reconnects with backoff after a refused
// connect, a timeout, EOF or an error), write() while connected, stop() or destruction.
// Threading: io_context thread only; callbacks run there. stop() reports the "stopped" state,
// then no callback is invoked; destruction reports nothing.
class TcpClient {
 public:
  TcpClient(asio::io_context& io, TcpClientConfig config, StampClock clock, ByteHandler on_bytes,
            StateHandler on_state = {});
  ~TcpClient();
  TcpClient(const TcpClient&) = delete;
  TcpClient& operator=(const TcpClient&) = delete;

  Status start();
  void stop();
  Status write(std::span<const std::uint8_t> bytes);
  const DeviceHealth& health() const;

  class Impl;

 private:
  std::shared_ptr<Impl> impl_;
};

}  // namespace vog::io
